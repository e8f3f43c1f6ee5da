use glam::DVec3;

use super::*;

#[test]
fn triangle_plane_is_the_triangle_plane() {
    let p = [
        DVec3::new(1.0, 0.0, 2.0),
        DVec3::new(0.0, 1.0, 2.0),
        DVec3::new(0.0, 0.0, 2.0),
    ];
    let up = [DVec3::Z; 3];
    let plane = TrianglePlane::of_triangle(p, up).unwrap();
    assert_eq!(plane.normal, DVec3::new(0.0, 0.0, 1.0));
    assert!((plane.distance(DVec3::new(5.0, -3.0, 2.5)) - 0.5).abs() < 1e-15);
    // Oriented by the vertex normals, whatever the winding.
    let flipped = TrianglePlane::of_triangle([p[1], p[0], p[2]], up).unwrap();
    assert_eq!(flipped.normal, DVec3::new(0.0, 0.0, 1.0));
    let down = TrianglePlane::of_triangle(p, [-DVec3::Z; 3]).unwrap();
    assert_eq!(down.normal, DVec3::new(0.0, 0.0, -1.0));
    assert!(TrianglePlane::of_triangle([p[0], p[0], p[1]], up).is_none());
}

/// The camera points behind the plane z = 0 by a margin, for a segment running either way
/// through it, along it, and with the light behind: hand-solved ranges.
#[test]
fn behind_range_keeps_the_camera_points_behind_the_plane() {
    let plane =
        TrianglePlane::of_triangle([DVec3::ZERO, DVec3::X, DVec3::Y], [DVec3::Z; 3]).unwrap();
    let light = DVec3::new(0.0, 0.0, 5.0);
    let m = 1e-3;
    // From z = 1 going down: behind (z <= -m) from t = 1 + m on.
    let down = plane.behind_range(DVec3::Z, -DVec3::Z, light, (0.0, 3.0), m);
    assert_eq!(down, Some((1.0 + m, 3.0)));
    // From z = -1 going up: behind until t = 1 - m.
    let up = plane.behind_range(-DVec3::Z, DVec3::Z, light, (0.0, 3.0), m);
    assert_eq!(up, Some((0.0, 1.0 - m)));
    // Along the plane: all behind, or none.
    let below = plane.behind_range(-DVec3::Z, DVec3::X, light, (0.0, 3.0), m);
    assert_eq!(below, Some((0.0, 3.0)));
    assert_eq!(
        plane.behind_range(DVec3::ZERO, DVec3::X, light, (0.0, 3.0), m),
        None
    );
    // The light behind the plane: nothing.
    assert_eq!(
        plane.behind_range(DVec3::Z, -DVec3::Z, -light, (0.0, 3.0), m),
        None
    );
    // Entirely in front.
    assert_eq!(
        plane.behind_range(DVec3::Z, -DVec3::Z, light, (0.0, 0.5), m),
        None
    );
}

/// The facing bounds hold `n(a, b)·(x − P(a, b))` at 20,000 random points of random curved
/// triangles, and are attained at the vertices when the function is linear (flat normals).
#[test]
fn facing_bounds_bound_the_facing_function() {
    let mut state = 5u64;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut vec = |scale: f64| DVec3::new(next(), next(), next()) * scale;
    for _ in 0..200 {
        let p = [vec(1.0), vec(1.0), vec(1.0)];
        let n = [
            (DVec3::Z + vec(0.8)).normalize(),
            (DVec3::Z + vec(0.8)).normalize(),
            (DVec3::Z + vec(0.8)).normalize(),
        ];
        let x = vec(3.0);
        let (lo, hi) = facing_bounds(p, n, x);
        for i in 0..100 {
            let (mut a, mut b) = (f64::from(i % 10) / 9.0, f64::from(i / 10) / 9.0);
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            let point = p[0] + a * (p[1] - p[0]) + b * (p[2] - p[0]);
            let normal = n[0] + a * (n[1] - n[0]) + b * (n[2] - n[0]);
            let q = normal.dot(x - point);
            assert!(lo - 1e-12 <= q && q <= hi + 1e-12, "{lo} <= {q} <= {hi}");
        }
    }
    let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let (lo, hi) = facing_bounds(p, [DVec3::Z; 3], DVec3::new(0.2, 0.3, 1.5));
    assert_eq!((lo, hi), (1.5, 1.5));
}

#[test]
fn normal_cone_contains_its_normals_and_refuses_hemispheres() {
    let n = [
        DVec3::new(0.1, 0.0, 1.0).normalize(),
        DVec3::new(-0.2, 0.3, 1.0).normalize(),
        DVec3::new(0.0, -0.4, 1.0).normalize(),
    ];
    let cone = NormalCone::of_normals(n).unwrap();
    for ni in n {
        assert!(angle_between(cone.axis, ni) <= cone.half_angle + 1e-15);
    }
    assert_eq!(
        NormalCone::of_normals([DVec3::X, -DVec3::X, DVec3::Y]),
        None
    );
}
