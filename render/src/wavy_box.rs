//! The box shape: an axis-aligned box whose top may be a wavy water surface.
//!
//! The scenes people draw first — a pool, a sea bed, a tank — need a closed water volume with a
//! displaced top; writing that mesh by hand in OBJ is where they give up. The top (the +y face)
//! is the height field of a [`WaveField`] sampled on an even grid, with the field's exact
//! normals; each side runs from the bottom edge up to the top's border, so the box is closed
//! (every edge is shared by two triangles, by position); the bottom is a fan from its centre to
//! the sides' lower edges, so no edge ends in the middle of another. Each face has its own
//! vertices and normals: the box's edges stay sharp while its top is smooth.

use glam::{DVec2, DVec3};

use crate::mesh::TriangleMesh;
use crate::sampler::Sampler;

/// The number of sine waves summed.
const WAVES: usize = 4;

/// A smooth height field `h(x, z)`: the mean of [`WAVES`] sine waves `sin(kᵢ·p + φᵢ)` with
/// seeded directions, wavelengths in `[wavelength/2, wavelength]` and phases, times the
/// amplitude; so `|h| <= amplitude` everywhere.
#[derive(Debug, Clone)]
pub struct WaveField {
    amplitude: f64,
    /// Wave vectors `kᵢ` (|kᵢ| = 2π / wavelengthᵢ) and phases `φᵢ`.
    waves: [(DVec2, f64); WAVES],
}

impl WaveField {
    /// The field of the given amplitude and longest wavelength, drawn from `seed`.
    pub fn new(amplitude: f64, wavelength: f64, seed: u64) -> WaveField {
        let tau = std::f64::consts::TAU;
        let mut rng = Sampler::new(seed, u32::MAX, u32::MAX, u32::MAX);
        let waves = std::array::from_fn(|_| {
            let angle = tau * rng.next_f64();
            let length = wavelength / (1.0 + rng.next_f64());
            let k = DVec2::new(angle.cos(), angle.sin()) * (tau / length);
            (k, tau * rng.next_f64())
        });
        WaveField { amplitude, waves }
    }

    /// The height at `p = (x, z)`.
    pub fn height(&self, p: DVec2) -> f64 {
        let sum: f64 = self
            .waves
            .iter()
            .map(|(k, phase)| (k.dot(p) + phase).sin())
            .sum();
        self.amplitude * sum / WAVES as f64
    }

    /// The gradient `(∂h/∂x, ∂h/∂z)` at `p = (x, z)`.
    pub fn slope(&self, p: DVec2) -> DVec2 {
        let sum: DVec2 = self
            .waves
            .iter()
            .map(|&(k, phase)| k * (k.dot(p) + phase).cos())
            .sum();
        sum * (self.amplitude / WAVES as f64)
    }

    /// The upward unit normal of the surface `y = c + h(x, z)` at `p = (x, z)`.
    pub fn normal(&self, p: DVec2) -> DVec3 {
        let g = self.slope(p);
        DVec3::new(-g.x, 1.0, -g.y).normalize()
    }
}

/// A box of extents `size`, centred at the origin, whose top is displaced by `waves` on a
/// `segments × segments` grid (`None`: a flat box, one square). Triangle count:
/// `2n² + 12n` for `n` segments (`spindle_common::validate::box_triangles`).
///
/// The caller checks that `size` is positive and the amplitude less than half the height.
pub fn wavy_box(size: DVec3, waves: Option<(&WaveField, u32)>) -> TriangleMesh {
    let n = waves.map_or(1, |(_, segments)| segments.max(1)) as usize;
    let half = size / 2.0;
    // Grid coordinates, exact at both ends so the sides meet the top at the same positions.
    let along = |i: usize, half: f64| {
        if i == n {
            half
        } else {
            -half + 2.0 * half * i as f64 / n as f64
        }
    };
    let xz = |i: usize, j: usize| DVec2::new(along(i, half.x), along(j, half.z));
    let top = |i: usize, j: usize| {
        let p = xz(i, j);
        let h = waves.map_or(0.0, |(field, _)| field.height(p));
        DVec3::new(p.x, half.y + h, p.y)
    };
    let bottom = |i: usize, j: usize| {
        let p = xz(i, j);
        DVec3::new(p.x, -half.y, p.y)
    };

    let mut mesh = Builder::default();
    // The top.
    let first = mesh.positions.len() as u32;
    for j in 0..=n {
        for i in 0..=n {
            let normal = waves.map_or(DVec3::Y, |(field, _)| field.normal(xz(i, j)));
            mesh.vertex(top(i, j), normal);
        }
    }
    let index = |i: usize, j: usize| first + (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            mesh.triangle([a, b, c], DVec3::Y);
            mesh.triangle([a, c, d], DVec3::Y);
        }
    }
    // The top's border, once around: side s holds border points s·n … s·n + n.
    let border: Vec<(usize, usize)> = (0..n)
        .map(|i| (i, 0))
        .chain((0..n).map(|j| (n, j)))
        .chain((0..n).map(|i| (n - i, n)))
        .chain((0..n).map(|j| (0, n - j)))
        .collect();
    let outward = [-DVec3::Z, DVec3::X, DVec3::Z, -DVec3::X];
    // The sides: one quad per border edge, from the bottom up to the top.
    for (k, &(i0, j0)) in border.iter().enumerate() {
        let (i1, j1) = border[(k + 1) % border.len()];
        let normal = outward[k / n];
        let b0 = mesh.vertex(bottom(i0, j0), normal);
        let b1 = mesh.vertex(bottom(i1, j1), normal);
        let t1 = mesh.vertex(top(i1, j1), normal);
        let t0 = mesh.vertex(top(i0, j0), normal);
        mesh.triangle([b0, b1, t1], normal);
        mesh.triangle([b0, t1, t0], normal);
    }
    // The bottom: a fan from its centre to every lower edge of the sides.
    let centre = mesh.vertex(DVec3::new(0.0, -half.y, 0.0), -DVec3::Y);
    let rim: Vec<u32> = border
        .iter()
        .map(|&(i, j)| mesh.vertex(bottom(i, j), -DVec3::Y))
        .collect();
    for k in 0..rim.len() {
        mesh.triangle([centre, rim[k], rim[(k + 1) % rim.len()]], -DVec3::Y);
    }
    TriangleMesh::new(mesh.positions, Some(mesh.normals), mesh.triangles)
        .expect("a box of finite positive size is a valid mesh")
}

/// Vertices with normals, and triangles wound so that their geometric normal points along a
/// given outward direction.
#[derive(Default)]
struct Builder {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    fn vertex(&mut self, position: DVec3, normal: DVec3) -> u32 {
        self.positions.push(position);
        self.normals.push(normal);
        self.positions.len() as u32 - 1
    }

    /// Adds the triangle, counter-clockwise seen from the side `outward` points to.
    fn triangle(&mut self, [a, b, c]: [u32; 3], outward: DVec3) {
        let p = |v: u32| self.positions[v as usize];
        let normal = (p(b) - p(a)).cross(p(c) - p(a));
        self.triangles.push(if normal.dot(outward) >= 0.0 {
            [a, b, c]
        } else {
            [a, c, b]
        });
    }
}

#[cfg(test)]
mod tests;
