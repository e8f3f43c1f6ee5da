//! Object placement: scale, then rotate about x, y and z (in that order), then translate.
//!
//! Positions map by `M·p + t` with `M = Rz·Ry·Rx·S`; normals map by the inverse transpose of
//! `M` (then renormalised), so they stay perpendicular to the surface under non-uniform scale.
//! A mirroring transform (negative determinant) reverses the winding so it stays outward.

use glam::{DMat3, DVec3};
use spindle_common::scene as desc;

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
        let rotation = DMat3::from_rotation_z(rot.z.to_radians())
            * DMat3::from_rotation_y(rot.y.to_radians())
            * DMat3::from_rotation_x(rot.x.to_radians());
        let linear = rotation * DMat3::from_diagonal(scale);
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
mod tests {
    use super::*;

    #[test]
    fn order_is_scale_then_rotate_xyz_then_translate() {
        let t = Transform::new(&desc::Transform {
            scale: [2.0, 1.0, 1.0],
            rotate_deg: [90.0, 90.0, 0.0],
            translate: [0.0, 0.0, 10.0],
        })
        .unwrap();
        // (1,0,0) → scale (2,0,0) → Rx(90) (2,0,0) → Ry(90) (0,0,-2) → translate (0,0,8).
        assert!((t.point(DVec3::X) - DVec3::new(0.0, 0.0, 8.0)).length() < 1e-12);
        // (0,1,0) → (0,1,0) → Rx(90) (0,0,1) → Ry(90) (1,0,0) → (1,0,10).
        assert!((t.point(DVec3::Y) - DVec3::new(1.0, 0.0, 10.0)).length() < 1e-12);
    }

    #[test]
    fn normals_stay_perpendicular_under_non_uniform_scale() {
        let t = Transform::new(&desc::Transform {
            scale: [3.0, 0.5, 1.0],
            rotate_deg: [10.0, 20.0, 30.0],
            translate: [1.0, 2.0, 3.0],
        })
        .unwrap();
        // A tangent plane spanned by u, v with normal u × v.
        let (u, v) = (DVec3::new(1.0, 2.0, 0.5), DVec3::new(-0.3, 0.2, 1.0));
        let n = t.normal(u.cross(v).normalize());
        let (tu, tv) = (
            t.point(u) - t.point(DVec3::ZERO),
            t.point(v) - t.point(DVec3::ZERO),
        );
        assert!(n.dot(tu).abs() < 1e-12 && n.dot(tv).abs() < 1e-12);
        assert!(n.dot(tu.cross(tv)) > 0.0);
    }

    #[test]
    fn zero_scale_is_rejected() {
        let e = Transform::new(&desc::Transform {
            scale: [1.0, 0.0, 1.0],
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.to_string().starts_with("scale:"));
    }
}
