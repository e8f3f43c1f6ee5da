//! What a path meets where it hits a dielectric surface: the media on its two sides and the
//! index across.
//!
//! An object's surface parts its medium from the one beyond, which is decided at the point hit
//! (`Scene::across`): the medium around the object (`nesting`), or the medium of a partner whose
//! surface coincides with it there (`contact`). Of two coincident triangles the ray may hit
//! either; both give the same crossing.

use glam::DVec3;

use crate::bvh::Hit;
use crate::scene::Scene;

/// A path's arrival at a dielectric surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// The object whose triangle was hit.
    pub object: usize,
    /// The point hit.
    pub p: DVec3,
    /// The hit triangle's unit geometric normal (pointing out of `object`).
    pub geometric: DVec3,
    /// The shading normal turned to face the arriving ray.
    pub facing: DVec3,
    /// Whether the ray arrives from outside `object` (geometry's call, by `geometric`).
    pub entering: bool,
    /// Whether the surface bounds the medium the path arrives in, so that a reflection is an
    /// internal one: leaving `object`, or entering it from a partner (a shared interface, which
    /// bounds the partner too) — not entering a nested object from the medium around it.
    pub internal: bool,
    /// The medium the path arrives in (`None`: the air).
    pub before: Option<usize>,
    /// The medium on the other side.
    pub after: Option<usize>,
    /// The index of `after` over the index of `before`.
    pub eta: f64,
}

impl Crossing {
    /// The crossing where the ray with unit direction `dir` hits the dielectric surface `hit`.
    pub fn at(scene: &Scene, hit: &Hit, dir: DVec3) -> Crossing {
        let (object, triangle) = scene.locate(hit.triangle);
        let mesh = &scene.objects()[object].mesh;
        let p = mesh.point(triangle, hit.a, hit.b);
        let geometric = mesh.geometric_normal(triangle).normalize_or_zero();
        let shading = mesh.shading_normal(triangle, hit.a, hit.b);
        Crossing::of(scene, object, p, geometric, shading, dir)
    }

    /// The crossing at `p` on object `object`'s surface, where the unit geometric normal is
    /// `geometric` and the shading normal `shading`, for a ray with unit direction `dir`: for a
    /// caller that has the hit's point and normals already.
    pub fn of(
        scene: &Scene,
        object: usize,
        p: DVec3,
        geometric: DVec3,
        shading: DVec3,
        dir: DVec3,
    ) -> Crossing {
        let facing = if dir.dot(shading) < 0.0 {
            shading
        } else {
            -shading
        };
        let entering = dir.dot(geometric) < 0.0;
        let beyond = scene.across(object, p, geometric);
        let (before, after) = if entering {
            (beyond, Some(object))
        } else {
            (Some(object), beyond)
        };
        Crossing {
            object,
            p,
            geometric,
            facing,
            entering,
            internal: !entering || (beyond.is_some() && beyond != scene.outer(object)),
            before,
            after,
            eta: scene.absolute_eta(after) / scene.absolute_eta(before),
        }
    }

    /// The medium a path leaving the surface in direction `dir` travels in: `object`'s below the
    /// surface, the other one above it.
    pub fn medium_toward(&self, dir: DVec3) -> Option<usize> {
        let (inside, outside) = if self.entering {
            (self.after, self.before)
        } else {
            (self.before, self.after)
        };
        if dir.dot(self.geometric) < 0.0 {
            inside
        } else {
            outside
        }
    }
}
