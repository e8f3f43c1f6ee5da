//! The flat faces of a dielectric's boundary, through which a directional light (the sun) enters
//! the medium as a directional light again: the exact second interface for an object nested in
//! a medium with flat sides (a jade bunny in a calm pool, a pebble in a glass tank).
//!
//! Why it exists: single scattering and the receivers follow light through one refractive
//! interface, the object's own. Light that reaches a nested object from the air crosses the outer
//! medium's boundary first. Where that boundary is a plane and the light is directional, the
//! crossing is known in closed form: every ray of direction `ω` refracts into the same direction
//! `ω_t` with the same transmittance, so in the outer medium the light *is* a directional light,
//! of perpendicular irradiance `E · (1 − F(θ_i)) · cos θ_i / cos θ_t` (the power `E cos θ_i` per
//! unit of the face spread over the refracted beam's cross-section `cos θ_t`), attenuated by the
//! outer medium from the face onward. A sun disk is exact too: each sampled direction of the disk
//! is refracted on its own.
//!
//! A face is a maximal set of the mesh's triangles in one plane (normals within
//! [`NORMAL_TOLERANCE`], offsets within [`OFFSET_TOLERANCE`] of the scene's scale) whose corner
//! normals all equal the plane's normal: a face whose shading normals bend (a smoothed mesh, the
//! waves on a box's top) is not flat to the light, and light through it is not modelled (the
//! scene's warnings give the share). At most [`MAX_FLAT_FACES`] faces per object are kept, the
//! largest by area.

use glam::DVec3;

use crate::fresnel::{reflectance, refract};
use crate::mesh::TriangleMesh;

/// Unit normals closer than this (1 − n·m) are the same plane's.
pub const NORMAL_TOLERANCE: f64 = 1e-10;
/// Plane offsets closer than this, in units of the scene's scale, are the same plane's.
pub const OFFSET_TOLERANCE: f64 = 1e-9;
/// The largest faces kept per object: each is a light of its own for every directional light.
pub const MAX_FLAT_FACES: usize = 16;
/// Planes followed while grouping; a mesh with more distinct planes keeps the largest of these.
const MAX_PLANES: usize = 1024;

/// One flat face of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatFace {
    /// The unit outward normal.
    pub normal: DVec3,
    /// `normal · x` for every point `x` of the face.
    pub offset: f64,
    /// The face's area.
    pub area: f64,
}

/// The flat faces of one mesh and which face each triangle belongs to.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FlatFaces {
    pub faces: Vec<FlatFace>,
    /// `face_of[t]`: the index in `faces` of triangle `t`'s face, if it is on a kept face.
    face_of: Vec<Option<u8>>,
}

impl FlatFaces {
    /// The flat faces of `mesh`, whose scene has the length scale `scale`.
    pub fn of(mesh: &TriangleMesh, scale: f64) -> FlatFaces {
        let offset_tolerance = OFFSET_TOLERANCE * scale;
        let mut planes: Vec<FlatFace> = Vec::new();
        let mut plane_of = vec![None; mesh.triangle_count()];
        for (t, slot) in plane_of.iter_mut().enumerate() {
            let cross = mesh.geometric_normal(t);
            let area = 0.5 * cross.length();
            let Some(normal) = cross.try_normalize() else {
                continue;
            };
            let bent = mesh
                .corner_normals(t)
                .iter()
                .any(|m| 1.0 - m.dot(normal) > NORMAL_TOLERANCE);
            if bent {
                continue;
            }
            let offset = normal.dot(mesh.corners(t)[0]);
            let same = planes.iter().position(|f| {
                1.0 - f.normal.dot(normal) <= NORMAL_TOLERANCE
                    && (f.offset - offset).abs() <= offset_tolerance
            });
            match same {
                Some(i) => {
                    planes[i].area += area;
                    *slot = Some(i);
                }
                None if planes.len() < MAX_PLANES => {
                    planes.push(FlatFace {
                        normal,
                        offset,
                        area,
                    });
                    *slot = Some(planes.len() - 1);
                }
                None => {}
            }
        }
        // Keep the largest faces, in a fixed order (area, then first triangle).
        let mut order: Vec<usize> = (0..planes.len()).collect();
        order.sort_by(|&a, &b| planes[b].area.total_cmp(&planes[a].area).then(a.cmp(&b)));
        order.truncate(MAX_FLAT_FACES);
        let mut kept = vec![None; planes.len()];
        for (rank, &plane) in order.iter().enumerate() {
            kept[plane] = Some(rank as u8);
        }
        FlatFaces {
            faces: order.iter().map(|&i| planes[i]).collect(),
            face_of: plane_of.iter().map(|p| p.and_then(|p| kept[p])).collect(),
        }
    }

    /// The kept face triangle `triangle` lies on, if any.
    pub fn face_of(&self, triangle: usize) -> Option<usize> {
        self.face_of
            .get(triangle)
            .copied()
            .flatten()
            .map(usize::from)
    }
}

/// A directional light after a flat face of a medium of relative index `eta` (inside over
/// outside): arriving from the unit direction `toward_light` (from the medium toward the light,
/// outside), it continues inside from `toward_light_inside` with its perpendicular irradiance
/// multiplied by `factor`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refracted {
    pub toward_light_inside: DVec3,
    pub factor: f64,
}

/// The light of direction `toward_light` refracted into the medium through `face` (module doc);
/// `None` if the face looks away from the light.
pub fn through_face(face: &FlatFace, toward_light: DVec3, eta: f64) -> Option<Refracted> {
    let cos_i = face.normal.dot(toward_light);
    if cos_i <= 0.0 {
        return None;
    }
    let travel = refract(-toward_light, face.normal, eta)?;
    let cos_t = -face.normal.dot(travel);
    if cos_t <= 0.0 {
        return None;
    }
    let factor = (1.0 - reflectance(cos_i, eta)) * cos_i / cos_t;
    Some(Refracted {
        toward_light_inside: -travel,
        factor,
    })
}

#[cfg(test)]
mod tests;
