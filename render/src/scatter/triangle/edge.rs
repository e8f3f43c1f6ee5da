//! Where the solution curve of `f(t, a, b) = 0` crosses the edges of a triangle ([H15] §3.2.2–3.2.3).
//!
//! The crossings bound each triangle's contribution in t. Each edge (a = 0, b = 0, a + b = 1) is
//! first scanned for sign changes of a scalar that vanishes exactly where the edge point's refracted
//! light ray meets the camera line, so that every crossing is found — including a second crossing
//! of the same edge, which [H15]'s Algorithm 1 needs a second pass for. Each bracket is then
//! solved exactly by the damped Newton on the edge, in `(t, s)`, and classified as a lower or an
//! upper bound of t from the curve's tangent (physics.md §2.3 rules).

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::scatter::triangle::curve::CurvePoint;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::{Residual, TrianglePatch};
use crate::scatter::triangle::small_list::SmallList;
use crate::scatter::triangle::solve::{NewtonSettings, Slice, is_physical, newton};

/// The three edges of a triangle in barycentric coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Edge {
    /// a = 0, from P0 (s = 0) to P2 (s = 1); s = b.
    A0,
    /// b = 0, from P0 (s = 0) to P1 (s = 1); s = a.
    B0,
    /// a + b = 1, from P1 (s = 0) to P2 (s = 1); s = b, a = 1 − s.
    Ab1,
}

/// Sign changes looked for along each line (the scan resolves crossings further apart than 1/16
/// of the line).
pub const LINE_SCAN: usize = 16;

/// A straight segment `(a, b) = origin + s·dir`, `s ∈ [0, 1]`, in barycentric coordinates: an
/// edge of the triangle or a line across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarycentricLine {
    /// `(a, b)` at s = 0.
    pub origin: [f64; 2],
    /// `(Δa, Δb)` from s = 0 to s = 1.
    pub dir: [f64; 2],
}

impl BarycentricLine {
    /// `(a, b)` at s.
    #[inline]
    pub fn at(&self, s: f64) -> (f64, f64) {
        (
            self.origin[0] + s * self.dir[0],
            self.origin[1] + s * self.dir[1],
        )
    }

    /// The slice of parameter space on this line, with slice coordinates `(u, v) = (t, s)`.
    pub fn slice(&self) -> Slice {
        Slice {
            origin: [0.0, self.origin[0], self.origin[1]],
            du: [1.0, 0.0, 0.0],
            dv: [0.0, self.dir[0], self.dir[1]],
        }
    }

    /// A signed offset of `(a, b)` from the line's support, to detect crossings.
    #[inline]
    pub fn side(&self, a: f64, b: f64) -> f64 {
        (a - self.origin[0]) * self.dir[1] - (b - self.origin[1]) * self.dir[0]
    }
}

impl Edge {
    /// All three edges.
    pub const ALL: [Edge; 3] = [Edge::A0, Edge::B0, Edge::Ab1];

    /// `(a, b)` of the edge point with parameter s.
    #[inline]
    pub fn barycentric(self, s: f64) -> (f64, f64) {
        match self {
            Edge::A0 => (0.0, s),
            Edge::B0 => (s, 0.0),
            Edge::Ab1 => (1.0 - s, s),
        }
    }

    /// The edge as a line, with the parameter s of [`Edge::barycentric`].
    pub fn line(self) -> BarycentricLine {
        match self {
            Edge::A0 => BarycentricLine {
                origin: [0.0, 0.0],
                dir: [0.0, 1.0],
            },
            Edge::B0 => BarycentricLine {
                origin: [0.0, 0.0],
                dir: [1.0, 0.0],
            },
            Edge::Ab1 => BarycentricLine {
                origin: [1.0, 0.0],
                dir: [-1.0, 1.0],
            },
        }
    }

    /// The slice of parameter space on this edge, with slice coordinates `(u, v) = (t, s)`.
    pub fn slice(self) -> Slice {
        self.line().slice()
    }

    /// The component of a parameter-space direction g pointing into the triangle across this
    /// edge.
    #[inline]
    pub fn inward(self, g: CurvePoint) -> f64 {
        match self {
            Edge::A0 => g.a,
            Edge::B0 => g.b,
            Edge::Ab1 => -(g.a + g.b),
        }
    }
}

/// Whether an edge crossing is a lower or an upper bound of t on the triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// The curve enters the triangle as t increases: t is a minimum.
    Lower,
    /// The curve leaves the triangle as t increases: t is a maximum.
    Upper,
}

/// One point where the solution curve crosses an edge inside the edge's extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Which edge.
    pub edge: Edge,
    /// The point of the curve.
    pub x: CurvePoint,
    /// The oriented curve tangent there (see [`Residual::tangent`]).
    pub g: CurvePoint,
    /// Lower or upper bound of t, from the tangent.
    pub bound: Bound,
}

/// Classifies a crossing from the curve tangent g (physics.md §2.3, [H15] §3.2.3): on a = 0, t is
/// a maximum if `g_t/g_a < 0`; on b = 0 if `g_t/g_b < 0`; on a + b = 1 if `g_t/(g_a+g_b) > 0`. All
/// three say: t is a maximum when moving into the triangle decreases t. None when the curve is
/// tangent to the edge or to t = const there (no decision possible).
pub fn classify(edge: Edge, g: CurvePoint) -> Option<Bound> {
    let product = g.t * edge.inward(g);
    if product > 0.0 {
        Some(Bound::Lower)
    } else if product < 0.0 {
        Some(Bound::Upper)
    } else {
        None
    }
}

/// The skew scalar at one point of a line, with the camera parameter `t` of the meeting point and
/// the distance λ from the point along the refracted ray (positive = inside); `None` where no
/// refracted ray exists (see [`skew`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skew {
    pub value: f64,
    pub t: f64,
    pub lambda: f64,
}

/// What the scan keeps of the skew scalar at one point: the sign of [`Skew::value`] (0 where it
/// is zero or NaN: such a point brackets a crossing with either neighbour, like a sign change),
/// and whether λ > 0. Enough to find the brackets; the full [`Skew`] is computed only at their
/// ends. Two bytes, so that a scan is cheap to store, share and copy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SkewSign {
    pub sign: i8,
    pub ahead: bool,
}

impl SkewSign {
    /// The sign of `value` (0 for zero or NaN), and `ahead`.
    #[inline]
    fn new(value: f64, ahead: bool) -> Self {
        let sign = if value > 0.0 {
            1
        } else if value < 0.0 {
            -1
        } else {
            0
        };
        SkewSign { sign, ahead }
    }

    /// Whether the skew scalar has one strict sign at both points (no crossing between them is
    /// seen).
    #[inline]
    pub fn same_sign(self, other: SkewSign) -> bool {
        self.sign * other.sign > 0
    }
}

/// The scan of a line at the [`LINE_SCAN`]` + 1` evenly spaced points `s = i / LINE_SCAN`.
pub type LineScan = [Option<SkewSign>; LINE_SCAN + 1];

/// The light ray refracted at the point `p` with (unnormalised) shading normal `n`, and how it
/// meets the camera line: `(rel, w, cross, len2)` with `rel = p − origin`, `w` the refracted
/// direction (scaled by ‖L − P‖: only its direction matters), `cross = r̂ × w` and `len2 = ‖cross‖²`.
/// `None` where the light is behind the normal, totally reflected, or the lines are parallel.
#[inline]
fn refracted(p: DVec3, n: DVec3, ends: &PathEnds) -> Option<(DVec3, DVec3, DVec3, f64)> {
    // Used at the two ends of a bracket only; the scans use `skew_sign`'s division-free form.
    let d = p - ends.light;
    let nn = n.length_squared();
    let norms = (nn * d.length_squared()).sqrt(); // ‖n‖‖d‖
    if !(norms > 0.0 && norms.is_finite()) {
        return None;
    }
    let cos_i = -d.dot(n) / norms;
    if cos_i.is_nan() || cos_i <= 0.0 {
        return None;
    }
    let inv_eta = ends.eta.recip();
    let sin2_t = (1.0 - cos_i * cos_i) * (inv_eta * inv_eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let w = d * inv_eta + ((cos_i * inv_eta - cos_t) * norms / nn) * n;
    let cross = ends.dir.cross(w);
    let len2 = cross.length_squared();
    if len2.is_nan() || len2 <= 1e-24 * w.length_squared() {
        return None;
    }
    Some((p - ends.origin, w, cross, len2))
}

/// The scalar whose zeros along an edge are the crossings: the light ray from L refracted into the
/// medium at the point `p` with (unnormalised) shading normal `n` meets the camera line iff the
/// two lines are coplanar, `(P − origin)·(r̂ × w) = 0`, normalised by `‖r̂ × w‖`.
pub fn skew(p: DVec3, n: DVec3, ends: &PathEnds) -> Option<Skew> {
    let (rel, w, cross, len2) = refracted(p, n, ends)?;
    let value = rel.dot(cross) / len2.sqrt();
    // Closest points of the lines origin + t·r̂ and p + λ·w (λ in units of ‖w‖).
    let (rd, rw, dw) = (rel.dot(ends.dir), rel.dot(w), ends.dir.dot(w));
    let t = (rd * w.length_squared() - dw * rw) / len2;
    let lambda = (dw * rd - rw) / len2;
    Some(Skew { value, t, lambda })
}

/// [`skew`]'s signs only. Both are linear in the refracted direction w, so any positive multiple
/// of it serves: here `‖n‖² w` (w as in [`refracted`]), which needs no division and one square
/// root, `‖n‖² w = ‖n‖²/η d − (d·n/η + ‖n‖‖d‖ cos θ_t) n` with `(‖n‖‖d‖ cos θ_t)² = ‖n‖²‖d‖² −
/// (‖n‖²‖d‖² − (d·n)²)/η²`, `d = P − L`. None exactly where [`refracted`] is None (up to
/// rounding). [`skew_signs`] does the same operations, batched.
#[cfg(test)]
#[inline]
pub fn skew_sign(p: DVec3, n: DVec3, ends: &PathEnds) -> Option<SkewSign> {
    let d = p - ends.light;
    let nn = n.length_squared();
    let nd = nn * d.length_squared();
    let dn = d.dot(n);
    let inv_eta = ends.eta.recip();
    let tangential = (nd - dn * dn) * (inv_eta * inv_eta);
    let k = -(dn * inv_eta + (nd - tangential).sqrt());
    let w = d * (nn * inv_eta) + k * n;
    let cross = ends.dir.cross(w);
    let len2 = cross.length_squared();
    // The light in front of the normal (cos θ_i > 0), no total reflection, lines not parallel.
    let valid = nd > 0.0
        && nd.is_finite()
        && dn < 0.0
        && tangential < nd
        && !(len2.is_nan() || len2 <= 1e-24 * w.length_squared());
    if !valid {
        return None;
    }
    let rel = p - ends.origin;
    let ahead = ends.dir.dot(w) * rel.dot(ends.dir) - rel.dot(w) > 0.0;
    Some(SkewSign::new(rel.dot(cross), ahead))
}

/// The scan of a line of the triangle, from the patch.
pub fn scan_line(patch: &TrianglePatch, ends: &PathEnds, line: &BarycentricLine) -> LineScan {
    let mut points = ScanPoints::default();
    for i in 0..=LINE_SCAN {
        let (a, b) = line.at(i as f64 / LINE_SCAN as f64);
        points.set(i, patch.point(a, b), patch.normal(a, b));
    }
    skew_signs(&points, ends)
}

/// The scan of a straight edge from `p0` (normal `n0`) to `p1` (normal `n1`), the same whichever
/// triangle the edge belongs to (see `edge_scans`).
pub fn scan_edge(p: [DVec3; 2], n: [DVec3; 2], ends: &PathEnds) -> LineScan {
    let (dp, dn) = (p[1] - p[0], n[1] - n[0]);
    let mut points = ScanPoints::default();
    for i in 0..=LINE_SCAN {
        let s = i as f64 / LINE_SCAN as f64;
        points.set(i, p[0] + s * dp, n[0] + s * dn);
    }
    skew_signs(&points, ends)
}

/// The points of one scan, by coordinate (structure of arrays), so that [`skew_signs`] runs the
/// same arithmetic on all of them in a loop the compiler vectorises.
#[derive(Default)]
struct ScanPoints {
    p: [[f64; LINE_SCAN + 1]; 3],
    n: [[f64; LINE_SCAN + 1]; 3],
}

impl ScanPoints {
    fn set(&mut self, i: usize, p: DVec3, n: DVec3) {
        for (k, (pk, nk)) in p.to_array().into_iter().zip(n.to_array()).enumerate() {
            self.p[k][i] = pk;
            self.n[k][i] = nk;
        }
    }
}

/// `skew_sign` at every point of `points`, with exactly its operations in its order (so the same
/// bits), computed for all points and then masked where `skew_sign` would return None.
///
/// It is compiled twice, for the baseline x86-64 and for AVX2 (four lanes instead of two), and
/// the CPU's best is chosen at run time (`multiversion`). Both run the same IEEE operations in the
/// same order (Rust never fuses a multiply and an add), so a scan has the same bits on every
/// machine and a farm of mixed machines still renders the image bit for bit.
#[multiversion::multiversion(targets("x86_64+avx+avx2"))]
fn skew_signs(points: &ScanPoints, ends: &PathEnds) -> LineScan {
    const N: usize = LINE_SCAN + 1;
    let [px, py, pz] = &points.p;
    let [nx, ny, nz] = &points.n;
    let (l, o, r) = (ends.light, ends.origin, ends.dir);
    let inv_eta = ends.eta.recip();
    let mut value = [0.0; N];
    let mut ahead = [false; N];
    let mut valid = [false; N];
    for i in 0..N {
        let (dx, dy, dz) = (px[i] - l.x, py[i] - l.y, pz[i] - l.z);
        let nn = nx[i] * nx[i] + ny[i] * ny[i] + nz[i] * nz[i];
        let nd = nn * (dx * dx + dy * dy + dz * dz);
        let dn = dx * nx[i] + dy * ny[i] + dz * nz[i];
        let tangential = (nd - dn * dn) * (inv_eta * inv_eta);
        let k = -(dn * inv_eta + (nd - tangential).sqrt());
        let scale = nn * inv_eta;
        let (wx, wy, wz) = (
            dx * scale + k * nx[i],
            dy * scale + k * ny[i],
            dz * scale + k * nz[i],
        );
        let (cx, cy, cz) = (
            r.y * wz - wy * r.z,
            r.z * wx - wz * r.x,
            r.x * wy - wx * r.y,
        );
        let len2 = cx * cx + cy * cy + cz * cz;
        let w2 = wx * wx + wy * wy + wz * wz;
        let (rx, ry, rz) = (px[i] - o.x, py[i] - o.y, pz[i] - o.z);
        let rel_dir = rx * r.x + ry * r.y + rz * r.z;
        let rel_w = rx * wx + ry * wy + rz * wz;
        let dir_w = r.x * wx + r.y * wy + r.z * wz;
        value[i] = rx * cx + ry * cy + rz * cz;
        ahead[i] = dir_w * rel_dir - rel_w > 0.0;
        valid[i] = nd > 0.0
            && nd.is_finite()
            && dn < 0.0
            && tangential < nd
            && !(len2.is_nan() || len2 <= 1e-24 * w2);
    }
    let mut scan = [None; N];
    for (i, out) in scan.iter_mut().enumerate() {
        if valid[i] {
            *out = Some(SkewSign::new(value[i], ahead[i]));
        }
    }
    scan
}

/// The solution curve of one triangle and camera segment within a depth range, solved to a
/// tolerance: what the searches for its crossings with lines of the triangle share.
#[derive(Debug, Clone, Copy)]
pub struct CrossingSearch<'a> {
    /// The triangle.
    pub patch: &'a TrianglePatch,
    /// The camera segment and the light point.
    pub ends: &'a PathEnds,
    /// The depths searched.
    pub range: DepthRange,
    /// The Newton tolerance of each crossing.
    pub tolerance: f64,
}

impl CrossingSearch<'_> {
    /// Calls `found(x, residual)` for every point x where the curve crosses `line` at
    /// `s ∈ [0, 1]` and t in the range: sign changes of the skew scalar on [`LINE_SCAN`]
    /// intervals (`scan`, the line's [`LineScan`]), each solved exactly by Newton on the line in
    /// `(t, s)`. Newton work and failures go to `stats`.
    pub fn line_crossings(
        &self,
        line: &BarycentricLine,
        scan: &LineScan,
        stats: &mut RenderStats,
        mut found: impl FnMut(CurvePoint, &Residual),
    ) {
        let (patch, ends, range) = (self.patch, self.ends, self.range);
        let full = |s: f64| {
            let (a, b) = line.at(s);
            skew(patch.point(a, b), patch.normal(a, b), ends)
        };
        for (i, pair) in scan.windows(2).enumerate() {
            let [Some(c0), Some(c1)] = [pair[0], pair[1]] else {
                continue;
            };
            // A sign change with the meeting point in front of P (inside the medium): found on
            // the signs, confirmed on the full values at both ends.
            if c0.same_sign(c1) || !(c0.ahead || c1.ahead) {
                continue;
            }
            let (s0, s1) = (
                i as f64 / LINE_SCAN as f64,
                (i + 1) as f64 / LINE_SCAN as f64,
            );
            let (Some(v0), Some(v1)) = (full(s0), full(s1)) else {
                continue;
            };
            if v0.value * v1.value > 0.0
                || !(v0.lambda > 0.0 || v1.lambda > 0.0)
                || v0.value == v1.value
            {
                continue;
            }
            let theta = v0.value / (v0.value - v1.value);
            let s_guess = s0 + theta * (s1 - s0);
            let t_guess = (v0.t + theta * (v1.t - v0.t)).clamp(range.lo, range.hi);
            let settings = NewtonSettings::new(self.tolerance, range);
            let (zero, spent) = newton(patch, ends, &line.slice(), (t_guess, s_guess), &settings);
            stats.newton_iterations += spent as u64;
            match zero {
                Some(z) => {
                    let (t, s) = z.uv;
                    if (-1e-12..=1.0 + 1e-12).contains(&s) && range.contains(t) {
                        found(z.x, &z.residual);
                    }
                }
                None => stats.newton_failures += 1,
            }
        }
    }

    /// Appends to `out` every crossing of the curve with `edge` at t in the range, from the
    /// edge's `scan` (beyond the list's capacity they are dropped, and counted in
    /// `stats.capacity_drops`). Newton evaluations and failures go to `stats`.
    pub fn edge_crossings<const N: usize>(
        &self,
        edge: Edge,
        scan: &LineScan,
        out: &mut SmallList<Crossing, N>,
        stats: &mut RenderStats,
    ) {
        let mut dropped = 0;
        self.line_crossings(&edge.line(), scan, stats, |x, r| {
            push_crossing(out, self.patch, edge, x, r, &mut dropped)
        });
        stats.capacity_drops += dropped;
    }
}

/// Adds a crossing unless it is not a physical path, a duplicate of one already found, or has no
/// usable tangent; counts it in `dropped` if the list is full.
fn push_crossing<const N: usize>(
    out: &mut SmallList<Crossing, N>,
    patch: &TrianglePatch,
    edge: Edge,
    x: CurvePoint,
    r: &Residual,
    dropped: &mut u64,
) {
    if !is_physical(patch, r) {
        return;
    }
    let Some(g) = r.tangent() else { return };
    let Some(bound) = classify(edge, g) else {
        return;
    };
    let duplicate = out.iter().any(|c| {
        c.edge == edge
            && (c.x.t - x.t).abs() <= 1e-9 * (1.0 + x.t.abs())
            && (c.x.a - x.a).abs() <= 1e-9
            && (c.x.b - x.b).abs() <= 1e-9
    });
    if !duplicate {
        out.push_or_count(Crossing { edge, x, g, bound }, dropped);
    }
}

#[cfg(test)]
mod tests;
