use super::*;
use crate::bvh::Bvh;
use crate::procedural::icosphere;
use crate::sampler::Sampler;

#[test]
fn offset_rays_never_hit_their_own_face_from_either_side() {
    // Convex icospheres at three scales, away from the origin. From a surface point, a ray
    // leaving outward must hit nothing (convexity); a ray leaving inward starts inside the
    // closed mesh, so it must hit a triangle, and never the one it starts on.
    for scale in [1e-4, 1.0, 1e4] {
        let centre = DVec3::new(3.0, -2.0, 1.5) * scale;
        let mesh = icosphere(scale, 4);
        let tris: Vec<[DVec3; 3]> = (0..mesh.triangle_count())
            .map(|i| mesh.corners(i).map(|p| p + centre))
            .collect();
        let bvh = Bvh::build(&tris);
        let scene_scale = 4.0 * scale;
        let mut s = Sampler::new(17, 0, 0, 0);
        for i in 0..2000 {
            // A random point on a random triangle, including points on edges and corners.
            let tri = (s.next_f64() * tris.len() as f64) as usize;
            let (mut a, mut b) = (s.next_f64(), s.next_f64());
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            match i % 4 {
                0 => a = 0.0,
                1 => (a, b) = (0.0, 0.0),
                _ => {}
            }
            let [p0, p1, p2] = tris[tri];
            let p = p0 + a * (p1 - p0) + b * (p2 - p0);
            let ng = (p1 - p0).cross(p2 - p0).normalize();
            // Directions from grazing to normal, on each side.
            let tangent = ng.any_orthonormal_vector();
            let c = 1e-3 + s.next_f64();
            for side in [1.0, -1.0] {
                let dir = (side * c * ng + tangent).normalize();
                let ray = Ray::leaving(p, ng, dir, scene_scale);
                let hit = bvh.closest_hit(&ray);
                if side > 0.0 {
                    assert!(
                        hit.is_none(),
                        "scale {scale} ray {i}: outward ray hit {hit:?}"
                    );
                } else {
                    let hit =
                        hit.unwrap_or_else(|| panic!("scale {scale} ray {i}: inward ray escaped"));
                    assert_ne!(
                        hit.triangle as usize, tri,
                        "scale {scale} ray {i}: self-hit"
                    );
                }
            }
        }
    }
}
