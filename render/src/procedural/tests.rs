use super::*;

fn outward(mesh: &TriangleMesh) -> bool {
    (0..mesh.triangle_count()).all(|i| {
        let c = mesh.corners(i).iter().copied().sum::<DVec3>() / 3.0;
        mesh.geometric_normal(i).dot(c) > 0.0
    }) && mesh
        .positions()
        .iter()
        .zip(mesh.normals())
        .all(|(p, n)| n.dot(*p) > 0.0 && (n.length() - 1.0).abs() < 1e-12)
}

#[test]
fn icosphere_is_closed_outward_with_exact_normals() {
    for s in 0..5 {
        let mesh = icosphere(2.5, s);
        let report = mesh.report();
        assert_eq!(report.triangles, 20 * 4usize.pow(s));
        assert!(report.closed && report.boundary_edges == 0 && report.degenerate == 0);
        // Euler: V − E + F = 2 with E = 3F/2.
        assert_eq!(mesh.positions().len(), 2 + report.triangles / 2);
        assert!(outward(&mesh));
        for (p, n) in mesh.positions().iter().zip(mesh.normals()) {
            assert!((p.length() - 2.5).abs() < 1e-12);
            assert!((*n - *p / 2.5).length() < 1e-12);
        }
    }
}

#[test]
fn bumpy_sphere_is_closed_outward_and_within_its_amplitude() {
    let mesh = bumpy_sphere(1.0, 4, 0.2, 3.0, 9);
    let report = mesh.report();
    assert_eq!(report.triangles, 5120);
    assert!(report.closed && report.degenerate == 0);
    assert!(outward(&mesh));
    let radii: Vec<f64> = mesh.positions().iter().map(|p| p.length()).collect();
    let (lo, hi) = radii
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    assert!(lo >= 0.8 - 1e-12 && hi <= 1.2 + 1e-12, "{lo} {hi}");
    assert!(
        hi - lo > 0.1,
        "the noise should actually displace: {lo} {hi}"
    );
    // Another seed gives another surface.
    assert_ne!(
        bumpy_sphere(1.0, 2, 0.2, 3.0, 10).positions(),
        bumpy_sphere(1.0, 2, 0.2, 3.0, 9).positions()
    );
}

#[test]
fn a_million_triangles_are_closed() {
    let mesh = icosphere(1.0, 8);
    assert_eq!(mesh.triangle_count(), 1_310_720);
    assert!(mesh.report().closed);
}
