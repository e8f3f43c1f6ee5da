//! The winding number and the distance against geometry whose answers are known: an icosphere
//! (inside, outside, on a vertex, an edge and a face), a cube with one face removed, and brute
//! force over a fine grid of triangle points.

use super::*;
use crate::bvh::Bvh;
use crate::procedural::icosphere;

#[test]
fn winding_number_tells_inside_from_outside() {
    let sphere = icosphere(1.0, 3);
    for (p, expected) in [
        (DVec3::ZERO, 1.0),
        (DVec3::new(0.3, -0.5, 0.6), 1.0),
        (DVec3::new(0.0, 0.0, 0.98), 1.0),
        (DVec3::new(0.0, 0.0, 1.02), 0.0),
        (DVec3::new(5.0, 1.0, -3.0), 0.0),
        (DVec3::new(1e6, 0.0, 0.0), 0.0),
    ] {
        let w = winding_number(&sphere, p);
        assert!((w - expected).abs() < 1e-9, "{p}: {w}");
    }
    // On the surface, at a vertex, on an edge and inside a face: the number is not defined there
    // (a triangle through p counts ±½ by the sign of a rounded zero), but it is finite, and the
    // surface holds the point.
    let [a, b, c] = sphere.corners(7);
    for p in [a, 0.5 * (a + b), (a + b + c) / 3.0] {
        let w = winding_number(&sphere, p);
        assert!(w.is_finite(), "{p}: {w}");
        assert!(holds(&sphere, p), "{p}: on the surface holds");
    }
    assert!(holds(&sphere, DVec3::ZERO));
    assert!(!holds(&sphere, DVec3::new(0.0, 0.0, 1.001)));
}

#[test]
fn an_open_mesh_degrades_gracefully() {
    // A unit cube without its top face: points deep inside are still inside, far above outside.
    let positions: Vec<DVec3> = (0..8)
        .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles: Vec<[u32; 3]> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    let cube = TriangleMesh::new(positions, None, triangles).unwrap();
    assert!(winding_number(&cube, DVec3::new(0.5, 0.5, 0.2)) > INSIDE_WINDING);
    assert!(winding_number(&cube, DVec3::new(0.5, 0.5, 3.0)) < INSIDE_WINDING);
}

#[test]
fn distance_matches_brute_force() {
    let sphere = icosphere(1.0, 1);
    for p in [
        DVec3::ZERO,
        DVec3::new(0.2, 0.9, -0.1),
        DVec3::new(2.0, -1.0, 0.5),
        DVec3::new(0.0, 0.0, 1.3),
    ] {
        let mut brute = f64::INFINITY;
        for i in 0..sphere.triangle_count() {
            let n = 60;
            for u in 0..=n {
                for v in 0..=(n - u) {
                    let (a, b) = (u as f64 / n as f64, v as f64 / n as f64);
                    brute = brute.min(sphere.point(i, a, b).distance(p));
                }
            }
        }
        let d = distance_to_mesh(&sphere, p);
        assert!(
            d <= brute + 1e-12 && brute - d < 0.01,
            "{p}: {d} vs {brute}"
        );
    }
}

/// Two unit icospheres: apart, one inside the other, touching at a point and overlapping.
#[test]
fn surfaces_cross_only_where_media_overlap() {
    let sphere = |center: DVec3, radius: f64| {
        let mesh = icosphere(radius, 2).mapped(|p| p + center, |n| n, false);
        let bvh = Bvh::build(
            &(0..mesh.triangle_count())
                .map(|t| mesh.corners(t))
                .collect::<Vec<_>>(),
        );
        (mesh, bvh)
    };
    let (a, a_bvh) = sphere(DVec3::ZERO, 1.0);
    for (center, radius, expected) in [
        (DVec3::new(3.0, 0.0, 0.0), 1.0, false),
        (DVec3::new(0.1, 0.0, 0.0), 0.5, false),
        (DVec3::new(0.0, 0.0, 0.0), 2.0, false),
        (DVec3::new(1.0, 0.0, 0.0), 1.0, true),
        (DVec3::new(0.0, 0.0, 0.5), 0.7, true),
        (DVec3::new(0.0, 1.5, 0.0), 1.0, true),
    ] {
        let (b, b_bvh) = sphere(center, radius);
        assert_eq!(
            surfaces_cross(&a, &a_bvh, &b, &b_bvh),
            expected,
            "a sphere of radius {radius} at {center}"
        );
        assert_eq!(surfaces_cross(&b, &b_bvh, &a, &a_bvh), expected);
    }
}

#[test]
fn an_interior_point_lies_inside_even_where_the_surface_is_shared() {
    let cube = |lo: DVec3, hi: DVec3| {
        let positions: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 1 { hi.x } else { lo.x },
                    if i & 2 == 2 { hi.y } else { lo.y },
                    if i & 4 == 4 { hi.z } else { lo.z },
                )
            })
            .collect();
        let triangles = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriangleMesh::new(positions, None, triangles).expect("cube")
    };
    let below = cube(DVec3::new(0.0, 0.0, -1.0), DVec3::new(1.0, 1.0, 0.0));
    let above = cube(DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 1.0));
    assert!(
        winding_number(&below, DVec3::new(0.5, 0.5, -0.5)) > 0.99,
        "wound outward"
    );
    // A point of `above`'s surface on the shared face is held by `below`; its interior point is
    // not.
    assert!(holds(&below, DVec3::new(0.5, 0.5, 0.0)));
    let q = interior_point(&above).expect("a closed cube has an inside");
    assert!(winding_number(&above, q) > 0.99 && !holds(&below, q), "{q}");
    // The gap between coincident faces is zero; between faces 1e-8 apart, 1e-8.
    let below_bvh = Bvh::build(&(0..12).map(|t| below.corners(t)).collect::<Vec<_>>());
    assert!(contact_gap(&above, &below, &below_bvh) < 1e-20);
    let lifted = cube(DVec3::new(0.0, 0.0, 1e-8), DVec3::new(1.0, 1.0, 1.0));
    let gap = contact_gap(&lifted, &below, &below_bvh);
    assert!((gap - 1e-8).abs() < 1e-15, "{gap:e}");
    // Apart by more than TOUCHING: no contact, no gap.
    let apart = cube(DVec3::new(0.0, 0.0, 1e-3), DVec3::new(1.0, 1.0, 1.0));
    assert_eq!(contact_gap(&apart, &below, &below_bvh), 0.0);
}
