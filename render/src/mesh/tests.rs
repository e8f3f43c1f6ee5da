use super::*;

/// A unit cube, 12 triangles wound outward, 8 shared vertices.
pub(crate) fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = (0..8)
        .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
        .collect();
    let t = vec![
        [0, 2, 1],
        [1, 2, 3], // z = 0, normal -z
        [4, 5, 6],
        [5, 7, 6], // z = 1, normal +z
        [0, 1, 4],
        [1, 5, 4], // y = 0, normal -y
        [2, 6, 3],
        [3, 6, 7], // y = 1, normal +y
        [0, 4, 2],
        [2, 4, 6], // x = 0, normal -x
        [1, 3, 5],
        [3, 7, 5], // x = 1, normal +x
    ];
    (p, t)
}

#[test]
fn cube_is_closed_and_normals_point_out_along_the_diagonals() {
    let (p, t) = cube();
    let mesh = TriangleMesh::new(p, None, t).unwrap();
    let report = mesh.report();
    assert_eq!(
        report,
        MeshReport {
            triangles: 12,
            degenerate: 0,
            closed: true,
            boundary_edges: 0,
            flipped_edges: 0,
            inside_out: false,
        }
    );
    let centre = DVec3::splat(0.5);
    for (p, n) in mesh.positions().iter().zip(mesh.normals()) {
        // Angle weighting makes a cube corner's normal the exact diagonal.
        let expected = (*p - centre).normalize();
        assert!((*n - expected).length() < 1e-12, "{p} {n}");
    }
    for i in 0..12 {
        let c = mesh.corners(i).iter().copied().sum::<DVec3>() / 3.0;
        assert!(mesh.geometric_normal(i).dot(c - centre) > 0.0);
    }
}

#[test]
fn inside_out_cube_is_turned_outward() {
    let (p, mut t) = cube();
    for tri in &mut t {
        tri.swap(0, 1);
    }
    let mesh = TriangleMesh::new(p, None, t).unwrap();
    for i in 0..12 {
        let c = mesh.corners(i).iter().copied().sum::<DVec3>() / 3.0;
        assert!(mesh.geometric_normal(i).dot(c - DVec3::splat(0.5)) > 0.0);
    }
    assert!(mesh.normals()[7].dot(DVec3::ONE) > 0.0);
}

#[test]
fn open_mesh_reports_boundary_edges_and_degenerates() {
    let (p, mut t) = cube();
    t.pop(); // one triangle missing: its 3 edges become boundary edges
    t.push([0, 0, 1]); // a degenerate sliver (two equal corners)
    let mesh = TriangleMesh::new(p, None, t).unwrap();
    let report = mesh.report();
    assert!(!report.closed);
    assert_eq!(report.boundary_edges, 3);
    assert_eq!(report.degenerate, 1);
    assert!(
        mesh.normals()
            .iter()
            .all(|n| (n.length() - 1.0).abs() < 1e-12)
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let (p, t) = cube();
    let mut nan = p.clone();
    nan[3].y = f64::NAN;
    assert!(matches!(
        TriangleMesh::new(nan, None, t.clone()),
        Err(MeshError::NonFinitePosition { vertex: 3, .. })
    ));
    let mut bad = t.clone();
    bad[5][2] = 8;
    let e = TriangleMesh::new(p.clone(), None, bad).unwrap_err();
    assert_eq!(
        e.to_string(),
        "triangle 5 refers to vertex 8, but there are only 8 vertices"
    );
    assert_eq!(
        TriangleMesh::new(p, None, vec![]).unwrap_err(),
        MeshError::Empty
    );
}

#[test]
fn welded_seam_duplicates_share_one_normal() {
    // Two triangles of a tent roof; vertex 1 and 4 are the same point (a UV seam copy).
    let p = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
    ];
    let t = vec![[0, 2, 1], [3, 4, 5]];
    let n = smooth_normals(&p, &t);
    assert_eq!(n[1], n[4]);
    assert!((n[1] - DVec3::Y).length() < 1e-12, "{}", n[1]);
}

#[test]
fn a_crease_angle_keeps_a_cubes_edges_sharp() {
    let (p, t) = cube();
    let mesh = TriangleMesh::with_crease(p, t, 60f64.to_radians()).unwrap();
    // Each of the 8 corners meets 3 faces at 90°: one vertex per face normal.
    assert_eq!(mesh.positions().len(), 24);
    assert!(
        mesh.report().closed,
        "splitting vertices keeps the mesh closed"
    );
    for i in 0..mesh.triangle_count() {
        let face = mesh.geometric_normal(i).normalize();
        // The faces are axis-aligned: the normal is ±x, ±y or ±z exactly.
        assert_eq!(face.abs().max_element(), 1.0);
        for n in mesh.corner_normals(i) {
            assert!((n - face).length() < 1e-15, "triangle {i}: {n} vs {face}");
        }
    }
    assert_eq!(mesh.sharp_edges(60f64.to_radians()), (12, 18));
    // Flat (0°) splits the same way here; the diagonals join coplanar faces.
    let (p, t) = cube();
    assert_eq!(
        TriangleMesh::with_crease(p, t, 0.0)
            .unwrap()
            .positions()
            .len(),
        24
    );
}

#[test]
fn a_crease_of_180_degrees_or_above_a_meshs_edges_is_the_smooth_rule_exactly() {
    let (p, t) = cube();
    let smooth = TriangleMesh::new(p.clone(), None, t.clone()).unwrap();
    let creased = TriangleMesh::with_crease(p, t, std::f64::consts::PI).unwrap();
    assert_eq!(creased, smooth);
    // A fine sphere has no edge near 60°: nothing splits, and the normals are the same bits.
    let sphere = crate::procedural::icosphere(1.0, 3);
    let (p, t) = (sphere.positions().to_vec(), sphere.triangles().to_vec());
    let smooth = TriangleMesh::new(p.clone(), None, t.clone()).unwrap();
    let creased = TriangleMesh::with_crease(p, t, 60f64.to_radians()).unwrap();
    assert_eq!(creased, smooth);
    assert_eq!(smooth.sharp_edges(60f64.to_radians()).0, 0);
}
