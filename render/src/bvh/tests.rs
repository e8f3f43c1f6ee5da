use super::*;
use crate::procedural::icosphere;
use crate::sampler::Sampler;

fn random_unit(s: &mut Sampler) -> DVec3 {
    let z = 2.0 * s.next_f64() - 1.0;
    let phi = 2.0 * std::f64::consts::PI * s.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn triangles_of(mesh: &crate::mesh::TriangleMesh) -> Vec<[DVec3; 3]> {
    (0..mesh.triangle_count())
        .map(|i| mesh.corners(i))
        .collect()
}

#[test]
fn closest_and_any_hit_agree_with_brute_force() {
    // A closed icosphere (1280 triangles) plus a second, offset one, so rays cross
    // several surfaces; origins both inside the first sphere and outside everything.
    let mut tris = triangles_of(&icosphere(1.0, 3));
    let second = icosphere(0.5, 2);
    tris.extend(
        triangles_of(&second)
            .into_iter()
            .map(|t| t.map(|p| p + DVec3::new(1.8, 0.3, -0.2))),
    );
    let bvh = Bvh::build(&tris);
    assert_eq!(bvh.triangle_count(), tris.len());
    let mut s = Sampler::new(7, 0, 0, 0);
    let (mut hits, mut inside_hits) = (0, 0);
    for i in 0..3000 {
        let inside = i % 2 == 0;
        let origin = if inside {
            random_unit(&mut s) * 0.9 * s.next_f64()
        } else {
            random_unit(&mut s) * 4.0
        };
        let dir = random_unit(&mut s);
        let ray = Ray::new(origin, dir);
        let fast = bvh.closest_hit(&ray);
        let slow = bvh.closest_hit_brute_force(&ray);
        match (fast, slow) {
            (Some(f), Some(b)) => {
                assert!(
                    (f.t - b.t).abs() <= 1e-12 * b.t.max(1.0),
                    "ray {i}: {f:?} vs {b:?}"
                );
                hits += 1;
                inside_hits += inside as u32;
            }
            (None, None) => {}
            other => panic!(
                "ray {i} {ray:?}: bvh {:?} vs brute force {:?}",
                other.0, other.1
            ),
        }
        // Any-hit with a random limit against the brute-force answer.
        let t_max = 6.0 * s.next_f64();
        let expected = slow.is_some_and(|h| h.t < t_max);
        assert_eq!(
            bvh.any_hit(origin, dir, t_max),
            expected,
            "ray {i} t_max {t_max}"
        );
    }
    // Every ray from inside the closed sphere must hit it.
    assert_eq!(inside_hits, 1500);
    assert!(hits > 1500);
}

#[test]
fn no_ray_leaks_out_of_a_closed_mesh_through_edges_or_vertices() {
    // Rays from inside aimed exactly at vertices and edge points (where two or more
    // triangles meet, the case where an f32 test lets about one ray in a million through)
    // must all hit: the f64 test includes edges.
    let mesh = icosphere(1.0, 5);
    let bvh = Bvh::build(&triangles_of(&mesh));
    let mut s = Sampler::new(23, 0, 0, 0);
    let mut rays = 0;
    for i in 0..mesh.triangle_count() {
        let [p0, p1, p2] = mesh.corners(i);
        let origin = random_unit(&mut s) * 0.7 * s.next_f64();
        let w = s.next_f64();
        for target in [
            p0,
            p0 + w * (p1 - p0),
            p1 + w * (p2 - p1),
            p2 + w * (p0 - p2),
        ] {
            let ray = Ray::new(origin, (target - origin).normalize());
            assert!(
                bvh.closest_hit(&ray).is_some(),
                "triangle {i}: {ray:?} leaked"
            );
            rays += 1;
        }
    }
    assert_eq!(rays, 4 * 20480);
}

#[test]
fn barycentrics_follow_the_documented_convention() {
    let tri = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 3.0, 0.0),
    ];
    let bvh = Bvh::build(&[tri]);
    // Aim at 0.2·P0 + 0.3·P1 + 0.5·P2.
    let target = 0.2 * tri[0] + 0.3 * tri[1] + 0.5 * tri[2];
    let hit = bvh
        .closest_hit(&Ray::new(target + DVec3::new(0.0, 0.0, 2.0), -DVec3::Z))
        .unwrap();
    assert!((hit.a - 0.3).abs() < 1e-14 && (hit.b - 0.5).abs() < 1e-14);
    assert!((hit.t - 2.0).abs() < 1e-14);
    assert_eq!(hit.triangle, 0);
}

#[test]
fn hierarchy_covers_every_triangle_once() {
    let mesh = icosphere(1.0, 2);
    let bvh = Bvh::build(&triangles_of(&mesh));
    let mut seen = vec![0u32; mesh.triangle_count()];
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        match bvh.children(n) {
            Some(c) => stack.extend(c),
            None => bvh.leaf_triangles(n).for_each(|t| seen[t as usize] += 1),
        }
    }
    assert!(seen.iter().all(|&c| c == 1));
}

#[test]
fn empty_bvh_never_hits() {
    let bvh = Bvh::build(&[]);
    assert!(bvh.closest_hit(&Ray::new(DVec3::ZERO, DVec3::X)).is_none());
    assert!(!bvh.any_hit(DVec3::ZERO, DVec3::X, 1.0));
    assert!(bvh.nodes().is_empty());
}
