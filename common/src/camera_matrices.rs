//! The camera matrices an EXR header carries, `worldToCamera` and `worldToNDC`, computed from a
//! scene's pinhole camera: how a compositor (Nuke's `exr/worldToCamera`, a camera from
//! metadata) puts 3D elements in the rendered frame. Here, in `common`, because the
//! coordinator writes them too and never links the renderer.
//!
//! Conventions, as OpenEXR's standard attributes define them (`ImfStandardAttributes.h`) and
//! Arnold and RenderMan write them:
//! - Imath's `M44f`: 16 floats, row-major (`m[row][column]`, row after row), applied to row
//!   vectors: `p' = [x y z 1] · M`, so the translation is the last row.
//! - Camera space is left-handed: origin at the camera, +x right and +y up in the image, +z the
//!   viewing direction (a point in front has z > 0).
//! - NDC: x right, y down, (0, 0) the top-left and (1, 1) the bottom-right corner of the
//!   display window (the whole film, also for a crop); a world point's NDC position is
//!   `[x y z 1] · worldToNDC` divided by its w, z discarded. Here w is the camera-space depth
//!   and z/w = 1 / depth.
//!
//! The camera is the renderer's: forward = look_at − position, right = forward × up, up
//! re-orthogonalised as right × forward, `fov_y` the full vertical angle, square pixels.

use crate::scene::Camera;

/// A 4×4 matrix in Imath's layout (see the module documentation).
pub type M44 = [[f64; 4]; 4];

/// A camera's `worldToCamera` and `worldToNDC` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraMatrices {
    pub world_to_camera: M44,
    pub world_to_ndc: M44,
}

impl CameraMatrices {
    /// The matrices of `camera` for a `width` × `height` film; `None` for a camera the scene's
    /// validation refuses (look_at at the position, up along the view, a zero-sized film).
    pub fn of(camera: &Camera, width: u32, height: u32) -> Option<CameraMatrices> {
        let forward = normalize(sub(camera.look_at, camera.position))?;
        let right = normalize(cross(forward, camera.up))?;
        let up = cross(right, forward);
        let p = camera.position;
        // Columns are the camera axes; the last row moves the camera to the origin.
        let mut world_to_camera = [[0.0; 4]; 4];
        for (j, axis) in [right, up, forward].into_iter().enumerate() {
            for i in 0..3 {
                world_to_camera[i][j] = axis[i];
            }
            world_to_camera[3][j] = -dot(axis, p);
        }
        world_to_camera[3][3] = 1.0;

        // Camera → NDC: x/z and y/z on the plane at unit depth span ±tan(fov_y / 2)·aspect and
        // ±tan(fov_y / 2); NDC x = 0.5 + x / (2 z t a), y = 0.5 − y / (2 z t), w = z, z = 1.
        if width == 0 || height == 0 {
            return None;
        }
        let t = (camera.fov_y.to_radians() / 2.0).tan();
        let aspect = f64::from(width) / f64::from(height);
        let mut projection = [[0.0; 4]; 4];
        projection[0][0] = 1.0 / (2.0 * t * aspect);
        projection[1][1] = -1.0 / (2.0 * t);
        projection[2][0] = 0.5;
        projection[2][1] = 0.5;
        projection[2][3] = 1.0;
        projection[3][2] = 1.0;
        let world_to_ndc = multiply(&world_to_camera, &projection);
        Some(CameraMatrices {
            world_to_camera,
            world_to_ndc,
        })
    }
}

/// `[x y z 1] · m`, divided by its w: how OpenEXR (Imath's `multVecMatrix`) applies a matrix
/// to a point.
pub fn transform_point(m: &M44, p: [f64; 3]) -> [f64; 3] {
    let row = [p[0], p[1], p[2], 1.0];
    let column = |j: usize| (0..4).map(|i| row[i] * m[i][j]).sum::<f64>();
    let w = column(3);
    [column(0) / w, column(1) / w, column(2) / w]
}

/// The matrix as the 16 f32 of an EXR `m44f` attribute, row after row.
pub fn to_m44f(m: &M44) -> [f32; 16] {
    let mut out = [0.0; 16];
    for (i, v) in m.iter().flatten().enumerate() {
        out[i] = *v as f32;
    }
    out
}

/// The matrix of an EXR `m44f` attribute's 16 f32.
pub fn from_m44f(m: &[f32; 16]) -> M44 {
    let mut out = [[0.0; 4]; 4];
    for (i, v) in m.iter().enumerate() {
        out[i / 4][i % 4] = f64::from(*v);
    }
    out
}

fn multiply(a: &M44, b: &M44) -> M44 {
    let mut out = [[0.0; 4]; 4];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let length = dot(a, a).sqrt();
    (length > 0.0 && length.is_finite()).then(|| [a[0] / length, a[1] / length, a[2] / length])
}

#[cfg(test)]
mod tests;
