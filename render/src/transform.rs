//! Object placement: scale, then rotate about x, y and z (in that order), then translate.
//!
//! Positions map by `M·p + t` with `M = Rz·Ry·Rx·S` (`spindle_common::transform::Affine`); normals map by the inverse transpose of
//! `M` (then renormalised), so they stay perpendicular to the surface under non-uniform scale.
//! A mirroring transform (negative determinant) reverses the winding so it stays outward.

use glam::{DMat3, DVec3};
use spindle_common::scene as desc;
use spindle_common::transform::Affine;

use crate::mesh::TriangleMesh;

/// A validated affine transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    linear: DMat3,
    normal: DMat3,
    translate: DVec3,
}

/// What is wrong with a transform; the field is named relative to the transform.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TransformError {
    #[error("scale: every component must be finite and non-zero, got {0:?}")]
    Scale([f64; 3]),
    #[error("rotate_deg: must be finite, got {0:?}")]
    Rotation([f64; 3]),
    #[error("translate: must be finite, got {0:?}")]
    Translation([f64; 3]),
}

impl Transform {
    pub fn new(t: &desc::Transform) -> Result<Transform, TransformError> {
        let scale = DVec3::from_array(t.scale);
        if !scale.is_finite() || scale.x == 0.0 || scale.y == 0.0 || scale.z == 0.0 {
            return Err(TransformError::Scale(t.scale));
        }
        let rot = DVec3::from_array(t.rotate_deg);
        if !rot.is_finite() {
            return Err(TransformError::Rotation(t.rotate_deg));
        }
        let translate = DVec3::from_array(t.translate);
        if !translate.is_finite() {
            return Err(TransformError::Translation(t.translate));
        }
        // The one matrix of a transform, which the coordinator's extent check uses too; glam
        // maps points in `Affine::point`'s order, so a vertex lands on the same bits.
        let linear = DMat3::from_cols_array_2d(&Affine::new(t).columns());
        Ok(Transform {
            linear,
            normal: linear.inverse().transpose(),
            translate,
        })
    }

    pub fn point(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.translate
    }

    /// A transformed unit normal.
    pub fn normal(&self, n: DVec3) -> DVec3 {
        (self.normal * n).normalize_or_zero()
    }

    /// The mesh in world space.
    pub fn apply(&self, mesh: &TriangleMesh) -> TriangleMesh {
        mesh.mapped(
            |p| self.point(p),
            |n| self.normal(n),
            self.linear.determinant() < 0.0,
        )
    }
}

#[cfg(test)]
mod tests;
