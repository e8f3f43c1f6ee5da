//! A triangle's plane and how a point faces its interpolated shading normals: the sidedness
//! conditions of a refraction point (physics.md §2.3, §2.5 item 3), as bounds over a triangle.

use glam::DVec3;

/// The plane of a triangle: unit geometric normal `n` (the winding's, outward on a closed mesh)
/// and offset `n·p0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrianglePlane {
    pub normal: DVec3,
    pub offset: f64,
}

impl TrianglePlane {
    /// The plane of the triangle `p`, its normal oriented like the vertex normals `n` (as
    /// `TrianglePatch` orients it). None for a degenerate triangle (no normal).
    pub fn of_triangle(p: [DVec3; 3], n: [DVec3; 3]) -> Option<Self> {
        let winding = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize()?;
        let normal = if (n[0] + n[1] + n[2]).dot(winding) < 0.0 {
            -winding
        } else {
            winding
        };
        Some(TrianglePlane {
            normal,
            offset: normal.dot(p[0]),
        })
    }

    /// Signed distance of `x` from the plane, positive on the normal's side.
    pub fn distance(&self, x: DVec3) -> f64 {
        self.normal.dot(x) - self.offset
    }

    /// Geometric sidedness (physics.md §2.3) for the camera points `origin + t·dir`, `t ∈ range`,
    /// and the light point `light`: None if the light is not strictly in front of the plane or
    /// no camera point of the range is behind it by at least `margin`; else the closed part of
    /// the range where they are.
    pub fn behind_range(
        &self,
        origin: DVec3,
        dir: DVec3,
        light: DVec3,
        range: (f64, f64),
        margin: f64,
    ) -> Option<(f64, f64)> {
        if self.distance(light) <= 0.0 {
            return None;
        }
        let height = self.distance(origin);
        let rate = self.normal.dot(dir);
        let (mut lo, mut hi) = range;
        // height + rate·t ≤ −margin.
        if rate > 0.0 {
            hi = hi.min((-height - margin) / rate);
        } else if rate < 0.0 {
            lo = lo.max((-height - margin) / rate);
        } else if height > -margin {
            return None;
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// Bounds `(lo, hi)` on `n(a, b)·(x − P(a, b))` over the triangle `P(a, b)` with vertices `p`
/// and linearly interpolated (unnormalised) normal `n(a, b)` from the vertex normals `n`: the
/// sign of how the point `x` faces the shading normal. The function is a product of two linear
/// functions, a quadratic whose Bernstein coefficients on the triangle are `n_i·(x − p_i)` at
/// the vertices and `(n_i·(x − p_j) + n_j·(x − p_i))/2` on the edges; it lies between their
/// smallest and largest.
pub fn facing_bounds(p: [DVec3; 3], n: [DVec3; 3], x: DVec3) -> (f64, f64) {
    let d = [x - p[0], x - p[1], x - p[2]];
    let coefficients = [
        n[0].dot(d[0]),
        n[1].dot(d[1]),
        n[2].dot(d[2]),
        0.5 * (n[0].dot(d[1]) + n[1].dot(d[0])),
        0.5 * (n[1].dot(d[2]) + n[2].dot(d[1])),
        0.5 * (n[2].dot(d[0]) + n[0].dot(d[2])),
    ];
    coefficients
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &c| {
            (lo.min(c), hi.max(c))
        })
}
