use super::*;

const TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

#[test]
fn tetrahedron_is_closed_with_outward_smooth_normals() {
    let mesh = parse_obj(TETRA.as_bytes()).unwrap();
    let report = mesh.report();
    assert_eq!(report.triangles, 4);
    assert!(report.closed);
    let centre = DVec3::splat(0.25);
    for (p, n) in mesh.positions().iter().zip(mesh.normals()) {
        assert!(n.dot(*p - centre) > 0.0);
    }
}

#[test]
fn quads_are_triangulated_and_file_normals_used() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 2\nf 1//1 2//1 3//1 4//1\n";
    let mesh = parse_obj(text.as_bytes()).unwrap();
    assert_eq!(mesh.triangle_count(), 2);
    assert!(mesh.normals().iter().all(|n| *n == DVec3::Z));
    assert!(!mesh.report().closed);
}

#[test]
fn nan_and_infinite_coordinates_are_rejected() {
    for bad in ["nan", "inf", "-inf"] {
        let text = TETRA.replace("v 0 1 0", &format!("v 0 {bad} 0"));
        // Refused by the scan the coordinator runs too, naming the line.
        let e = parse_obj(text.as_bytes()).unwrap_err();
        assert!(
            matches!(&e, ObjError::Parse(m) if m.starts_with(&format!("line 3: a vertex coordinate \"{bad}\""))),
            "{bad}: {e}"
        );
    }
}

#[test]
fn out_of_range_index_and_empty_file_are_rejected() {
    let text = TETRA.replace("f 2 3 4", "f 2 3 9");
    let e = parse_obj(text.as_bytes()).unwrap_err();
    assert!(!e.to_string().is_empty());
    assert!(
        matches!(
            e,
            ObjError::Parse(_) | ObjError::Mesh(MeshError::IndexOutOfRange { .. })
        ),
        "{e}"
    );
    for empty in [&b""[..], b"v 0 0 0\nv 1 0 0\n"] {
        assert!(
            matches!(parse_obj(empty).unwrap_err(), ObjError::Parse(m) if m.contains("no faces"))
        );
    }
}

/// One face of 10,000 corners made the build quadratic (9.6 s); it is refused before the
/// triangulation, naming its line, and a face at the bound is still read.
#[test]
fn a_face_of_too_many_corners_is_refused_before_it_is_triangulated() {
    let fan = |n: usize| {
        let corners: String = (1..=n).map(|i| format!(" {i}")).collect();
        let vertices: String = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                format!("v {} {} 0\n", a.cos(), a.sin())
            })
            .collect();
        format!("{vertices}f{corners}\n")
    };
    let n = spindle_common::validate::MAX_FACE_CORNERS;
    let mesh = parse_obj(fan(n).as_bytes()).unwrap();
    assert_eq!(mesh.report().triangles, n - 2);
    let started = std::time::Instant::now();
    let e = parse_obj(fan(10_000).as_bytes()).unwrap_err().to_string();
    assert_eq!(
        e,
        "not a valid OBJ file: line 10001: a face of 10000 corners; at most 64 (split it into \
         smaller faces)"
    );
    println!("a 10,000-corner face refused in {:?}", started.elapsed());
}
