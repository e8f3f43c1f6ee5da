//! The pinhole camera: which ray a point of the image looks along.
//!
//! Image x goes right and y goes down (row 0 at the top); pixel `(i, j)` covers
//! `[i, i+1) × [j, j+1)`, so its centre is `(i + 0.5, j + 0.5)`. `fov_y` is the full vertical angle.

use glam::DVec3;
use spindle_common::scene as desc;

use crate::ray::Ray;

/// A pinhole camera for an image of a given size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    position: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half_fov: f64,
    width: f64,
    height: f64,
}

/// What is wrong with the camera; the field is named relative to `camera` (or `film`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("{0}: must be finite")]
    NotFinite(&'static str),
    #[error("look_at: must differ from position")]
    LookAtIsPosition,
    #[error("up: must not be parallel to the viewing direction")]
    UpParallel,
    #[error("fov_y: must be in (0, 180) degrees, got {0}")]
    Fov(f64),
    #[error("film size: width and height must be > 0, got {0}x{1}")]
    Size(u32, u32),
}

impl Camera {
    pub fn new(camera: &desc::Camera, width: u32, height: u32) -> Result<Camera, CameraError> {
        let position = DVec3::from_array(camera.position);
        let look_at = DVec3::from_array(camera.look_at);
        let up = DVec3::from_array(camera.up);
        for (name, v) in [("position", position), ("look_at", look_at), ("up", up)] {
            if !v.is_finite() {
                return Err(CameraError::NotFinite(name));
            }
        }
        if !(camera.fov_y > 0.0 && camera.fov_y < 180.0) {
            return Err(CameraError::Fov(camera.fov_y));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::Size(width, height));
        }
        let forward = (look_at - position)
            .try_normalize()
            .ok_or(CameraError::LookAtIsPosition)?;
        let side = forward.cross(up);
        if side.length() <= 1e-9 * up.length() {
            return Err(CameraError::UpParallel);
        }
        let right = side.try_normalize().ok_or(CameraError::UpParallel)?;
        Ok(Camera {
            position,
            forward,
            right,
            up: right.cross(forward),
            tan_half_fov: (camera.fov_y.to_radians() / 2.0).tan(),
            width: width as f64,
            height: height as f64,
        })
    }

    /// The ray through image point `(x, y)` in pixel units (`(i + 0.5, j + 0.5)` is the centre of
    /// pixel `(i, j)`), with a unit direction.
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        let aspect = self.width / self.height;
        let sx = (2.0 * x / self.width - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * y / self.height) * self.tan_half_fov;
        Ray::new(
            self.position,
            (self.forward + sx * self.right + sy * self.up).normalize(),
        )
    }

    pub fn position(&self) -> DVec3 {
        self.position
    }

    /// The viewing axis (unit): camera-space depth is measured along it.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }
}

#[cfg(test)]
mod tests;
