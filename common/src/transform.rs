//! An object's placement in the world as arithmetic: the one matrix of a scene `transform`.
//!
//! The coordinator does not link the renderer, yet must refuse at submission an OBJ that its
//! transform carries past the scene's extent, as a worker would at build
//! ([`crate::validate::check_obj_placement`]). So the transform's arithmetic lives here, once:
//! the renderer takes its matrix from [`Affine::columns`] and maps points in the same order of
//! operations as [`Affine::point`], so a vertex lands on the same bits on either side and both
//! decide the same.

use crate::scene::{Transform, Vec3};

/// A 3×3 matrix as its three columns.
pub type Columns = [Vec3; 3];

/// `p ↦ M·p + t` with `M = Rz·Ry·Rx·S`: scale, then rotate about x, y and z (in that order, by
/// `rotate_deg`), then translate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    columns: Columns,
    translate: Vec3,
}

impl Affine {
    /// The placement `transform` describes (its values are checked by
    /// [`crate::scene::SceneDescription::validate`]; this only computes).
    pub fn new(transform: &Transform) -> Affine {
        let [x, y, z] = transform.rotate_deg.map(f64::to_radians);
        let rotation = product(&product(&rotation_z(z), &rotation_y(y)), &rotation_x(x));
        let [sx, sy, sz] = transform.scale;
        let scale = [[sx, 0.0, 0.0], [0.0, sy, 0.0], [0.0, 0.0, sz]];
        Affine {
            columns: product(&rotation, &scale),
            translate: transform.translate,
        }
    }

    /// `M`, column by column.
    pub fn columns(&self) -> Columns {
        self.columns
    }

    /// `M·p + t`.
    pub fn point(&self, p: Vec3) -> Vec3 {
        let m = apply(&self.columns, p);
        [
            m[0] + self.translate[0],
            m[1] + self.translate[1],
            m[2] + self.translate[2],
        ]
    }
}

/// `M·v`, summed column after column (the order fixes the rounding; see the module doc).
fn apply(m: &Columns, v: Vec3) -> Vec3 {
    std::array::from_fn(|row| m[0][row] * v[0] + m[1][row] * v[1] + m[2][row] * v[2])
}

/// `A·B`, column by column.
fn product(a: &Columns, b: &Columns) -> Columns {
    b.map(|column| apply(a, column))
}

fn rotation_x(angle: f64) -> Columns {
    let (sin, cos) = angle.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, cos, sin], [0.0, -sin, cos]]
}

fn rotation_y(angle: f64) -> Columns {
    let (sin, cos) = angle.sin_cos();
    [[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]]
}

fn rotation_z(angle: f64) -> Columns {
    let (sin, cos) = angle.sin_cos();
    [[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]]
}

#[cfg(test)]
mod tests;
