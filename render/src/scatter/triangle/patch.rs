//! One triangle of the refractive boundary with interpolated vertex normals, and the function
//! `f(t, a, b) = Ĥ + N̂s` whose zeros are the refraction paths ([H15] eqs. 1–7, physics.md §0, §2.1).
//!
//! The solver, the distance factor and the interval search all evaluate `f` and its exact 3×3
//! Jacobian through [`TrianglePatch::residual`], so the formulas live here once.

use glam::DVec3;

use crate::scatter::geometry::facing_bounds;
use crate::scatter::triangle::curve::CurvePoint;
use crate::scatter::triangle::ends::PathEnds;

/// Relative threshold below which a triangle is degenerate: `‖E1×E2‖ < DEGENERATE · max edge²`,
/// i.e. the sine of its flattest angle (times an edge ratio) is below 1e-7 (physics.md §2.5 item 7).
const DEGENERATE: f64 = 1e-7;

/// Normals closer than this (component-wise, unit vectors) to the geometric normal count as flat.
const FLAT_NORMAL: f64 = 1e-12;

/// A triangle `P(a,b) = P0 + a·E1 + b·E2` with the unnormalised interpolated normal
/// `n(a,b) = N0 + a·dN1 + b·dN2`, in f64.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrianglePatch {
    /// Vertex P0.
    pub p0: DVec3,
    /// E1 = P1 − P0.
    pub e1: DVec3,
    /// E2 = P2 − P0.
    pub e2: DVec3,
    /// Unit vertex normal N0 (outward).
    pub n0: DVec3,
    /// dN1 = N1 − N0.
    pub dn1: DVec3,
    /// dN2 = N2 − N0.
    pub dn2: DVec3,
    /// Dual basis: `a = (X − P0)·G1` for X in the plane.
    pub g1: DVec3,
    /// Dual basis: `b = (X − P0)·G2` for X in the plane.
    pub g2: DVec3,
    /// Unit geometric normal, oriented to the side of the vertex normals (so a mesh whose winding
    /// disagrees with its normals still passes the sidedness tests the right way round).
    pub normal_g: DVec3,
    /// `‖E1 × E2‖`, twice the area.
    pub double_area: f64,
    /// All three vertex normals equal the geometric normal: the closed form (3) of D applies.
    pub flat: bool,
}

/// `f` and its Jacobian at one `(t, a, b)`, with the intermediate quantities the callers reuse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    /// `f = Ĥ + N̂s`, zero on a refraction path.
    pub f: DVec3,
    /// ∂f/∂t.
    pub jt: DVec3,
    /// ∂f/∂a.
    pub ja: DVec3,
    /// ∂f/∂b.
    pub jb: DVec3,
    /// The point P(a, b) on the triangle's plane.
    pub p: DVec3,
    /// The camera point V(t).
    pub v: DVec3,
    /// `‖V − P‖`.
    pub d_v: f64,
    /// `‖L − P‖`.
    pub d_l: f64,
    /// `(V − P)/d_V`, pointing into the medium.
    pub omega_v: DVec3,
    /// `(L − P)/d_L`, pointing to the light.
    pub omega_l: DVec3,
    /// The unit shading normal N̂s at (a, b).
    pub normal_s: DVec3,
    /// `‖n(a, b)‖`, the length of the unnormalised interpolated normal.
    pub normal_len: f64,
    /// `h = η ω_V + ω_L`, unnormalised half vector.
    pub h: DVec3,
    /// `∇‖h‖ = (ĥ·∂h/∂t, ĥ·∂h/∂a, ĥ·∂h/∂b)`, for the scaled residual `‖h‖·f` (see
    /// [`Residual::scaled_apply`]).
    pub h_len_grad: [f64; 3],
}

impl Residual {
    /// `J · x` for a direction `x = (x_t, x_a, x_b)` in parameter space.
    #[inline]
    pub fn apply(&self, x: [f64; 3]) -> DVec3 {
        self.jt * x[0] + self.ja * x[1] + self.jb * x[2]
    }

    /// The scaled residual `g = ‖h‖·f = h + ‖h‖·N̂s`, which has the same zeros as f.
    ///
    /// Near η = 1, h is nearly linear in `(t, a, b)` and almost vanishes at the zero (`‖h‖ ≥ η − 1`,
    /// physics.md §2.5 item 2). Farther than about η − 1 from the zero, `Ĥ` then depends only on
    /// the direction toward the zero, not on the distance: f is nearly homogeneous of degree 0
    /// about its zero, J nearly singular along that direction, and Newton on f creeps (at
    /// η = 1 + 1e-6 it does not reach the zero from 1e-3 away in 60 evaluations). g is nearly
    /// homogeneous of degree 1 instead, like the straight path it tends to, so Newton on g
    /// converges from as far as at any η. Where `‖h‖` is of order 1 the two differ by a smooth
    /// positive factor.
    #[inline]
    pub fn scaled(&self) -> DVec3 {
        self.h.length() * self.f
    }

    /// `J_g · x` for the scaled residual g: `‖h‖ J·x + f (∇‖h‖·x)`.
    #[inline]
    pub fn scaled_apply(&self, x: [f64; 3]) -> DVec3 {
        let grad = self.h_len_grad;
        self.h.length() * self.apply(x)
            + self.f * (grad[0] * x[0] + grad[1] * x[1] + grad[2] * x[2])
    }

    /// The tangent of the solution curve in `(t, a, b)`: the kernel of J, taken as the cross
    /// product of the two ROWS of J with the largest cross product (physics.md §2.3; [H15] §3.2.3
    /// says columns, which spans the kernel of Jᵀ instead).
    ///
    /// It is oriented like `(N̂s·(J_a×J_b), N̂s·(J_b×J_t), N̂s·(J_t×J_a))`, an orientation that
    /// varies continuously along the curve, so the sign of `g_t` distinguishes the two branches
    /// meeting at a fold. Returns None where J has rank < 2.
    pub fn tangent(&self) -> Option<CurvePoint> {
        let rows = [
            DVec3::new(self.jt.x, self.ja.x, self.jb.x),
            DVec3::new(self.jt.y, self.ja.y, self.jb.y),
            DVec3::new(self.jt.z, self.ja.z, self.jb.z),
        ];
        let candidates = [
            rows[0].cross(rows[1]),
            rows[1].cross(rows[2]),
            rows[2].cross(rows[0]),
        ];
        let mut g = candidates[0];
        for c in &candidates[1..] {
            if c.length_squared() > g.length_squared() {
                g = *c;
            }
        }
        let scale = self.jt.length() + self.ja.length() + self.jb.length();
        if g.length().is_nan() || g.length() <= 1e-14 * scale * scale {
            return None;
        }
        let oriented = self.oriented_tangent();
        let g = if DVec3::from_array(oriented.to_array()).dot(g) < 0.0 {
            -g
        } else {
            g
        };
        Some(CurvePoint::from_array(g.to_array()))
    }

    /// The tangent in the closed form `(N̂s·(J_a×J_b), N̂s·(J_b×J_t), N̂s·(J_t×J_a))`
    /// (physics.md §1.3 corollary). Exact on the curve, where every column of J is ⟂ N̂s;
    /// its first component is proportional to D, with the sign that labels the branch.
    pub fn oriented_tangent(&self) -> CurvePoint {
        let n = self.normal_s;
        CurvePoint::new(
            n.dot(self.ja.cross(self.jb)),
            n.dot(self.jb.cross(self.jt)),
            n.dot(self.jt.cross(self.ja)),
        )
    }
}

/// `Q(x)·y`: the derivative of `x/‖x‖` in the direction y ([H15] eq. 15), given `x̂` and `‖x‖`.
#[inline]
fn d_normalize(unit: DVec3, len: f64, y: DVec3) -> DVec3 {
    (y - unit * unit.dot(y)) / len
}

impl TrianglePatch {
    /// Builds the patch from three positions and three unit outward normals. None if the triangle
    /// is degenerate (`‖E1×E2‖` tiny relative to its longest edge squared) or if any input is not
    /// finite or a normal is zero.
    pub fn new(p: [DVec3; 3], n: [DVec3; 3]) -> Option<Self> {
        if !p.iter().chain(n.iter()).all(|v| v.is_finite()) {
            return None;
        }
        let n = [
            n[0].try_normalize()?,
            n[1].try_normalize()?,
            n[2].try_normalize()?,
        ];
        let e1 = p[1] - p[0];
        let e2 = p[2] - p[0];
        let ng = e1.cross(e2);
        let double_area = ng.length();
        let longest = e1
            .length_squared()
            .max(e2.length_squared())
            .max((e2 - e1).length_squared());
        if double_area.is_nan() || double_area <= DEGENERATE * longest {
            return None;
        }
        let inv = 1.0 / (double_area * double_area);
        let g1 = e2.cross(ng) * inv;
        let g2 = ng.cross(e1) * inv;
        let unit_g = ng / double_area;
        let normal_g = if (n[0] + n[1] + n[2]).dot(unit_g) < 0.0 {
            -unit_g
        } else {
            unit_g
        };
        let flat = n
            .iter()
            .all(|ni| (*ni - normal_g).abs().max_element() <= FLAT_NORMAL);
        Some(TrianglePatch {
            p0: p[0],
            e1,
            e2,
            n0: n[0],
            dn1: n[1] - n[0],
            dn2: n[2] - n[0],
            g1,
            g2,
            normal_g,
            double_area,
            flat,
        })
    }

    /// The point `P0 + a·E1 + b·E2`.
    #[inline]
    pub fn point(&self, a: f64, b: f64) -> DVec3 {
        self.p0 + a * self.e1 + b * self.e2
    }

    /// The unnormalised interpolated normal `N0 + a·dN1 + b·dN2`.
    #[inline]
    pub fn normal(&self, a: f64, b: f64) -> DVec3 {
        self.n0 + a * self.dn1 + b * self.dn2
    }

    /// Barycentric coordinates `(a, b)` of the projection of `x` onto the triangle's plane.
    #[inline]
    pub fn barycentric(&self, x: DVec3) -> (f64, f64) {
        let d = x - self.p0;
        (d.dot(self.g1), d.dot(self.g2))
    }

    /// Whether `(a, b)` lies in the triangle, up to `tolerance` in barycentric units.
    #[inline]
    pub fn contains(&self, a: f64, b: f64, tolerance: f64) -> bool {
        a >= -tolerance && b >= -tolerance && a + b <= 1.0 + tolerance
    }

    /// Whether the point `(a, b)`, inside the triangle up to `tolerance`, belongs to this
    /// triangle rather than to a neighbour: a point on an edge or a vertex (within `tolerance`)
    /// is on every triangle that shares it, and a solution curve that runs along one (a camera
    /// segment on the refracted ray of a vertex, by symmetry) would be counted by each. Such a
    /// point belongs to the triangle that a step from it along a tangent direction `d` of the
    /// shading normal enters (the rule of rasterisers, which give a pixel centre on an edge to
    /// one side). `d` is a function of the shading normal alone (`any_orthonormal_pair`), which
    /// the triangles of a smooth vertex or edge share, so they agree on the one owner; where `d`
    /// runs along an edge the second tangent decides. Interior points belong to the triangle.
    pub fn owns(&self, a: f64, b: f64, tolerance: f64) -> bool {
        let on = [a <= tolerance, b <= tolerance, a + b >= 1.0 - tolerance];
        if !on.iter().any(|&on| on) {
            return true;
        }
        let Some(normal) = self.normal(a, b).try_normalize() else {
            return false;
        };
        let (d1, d2) = normal.any_orthonormal_pair();
        for d in [d1, d2] {
            // The rates at which a step along d moves into the triangle across each side.
            let (rate_a, rate_b) = (d.dot(self.g1), d.dot(self.g2));
            let inward = [rate_a, rate_b, -(rate_a + rate_b)];
            let active = || on.iter().zip(inward).filter(|(on, _)| **on).map(|(_, r)| r);
            if active().any(|r| r == 0.0) {
                continue;
            }
            return active().all(|r| r > 0.0);
        }
        false
    }

    /// A lower bound on the cosine `c = N̂s·(x − P)/‖x − P‖` between the shading normal and the
    /// direction to `x`, over the whole triangle (see [`facing_bounds`]; `‖n(a, b)‖ ≤ 1` and
    /// `‖x − P‖` is at most its largest value at a vertex). Negative when `x` may be behind
    /// some shading normal.
    pub fn min_facing_cosine(&self, x: DVec3) -> f64 {
        let p = [self.p0, self.p0 + self.e1, self.p0 + self.e2];
        let n = [self.n0, self.n0 + self.dn1, self.n0 + self.dn2];
        let (lo, _) = facing_bounds(p, n, x);
        let farthest = p.iter().map(|q| q.distance(x)).fold(0.0_f64, f64::max);
        if lo > 0.0 { lo / farthest } else { lo }
    }

    /// Signed distance of `x` from the triangle's plane, positive on the side of `normal_g`.
    #[inline]
    pub fn plane_distance(&self, x: DVec3) -> f64 {
        (x - self.p0).dot(self.normal_g)
    }

    /// `f(t, a, b) = Ĥ + N̂s` and its exact Jacobian (physics.md §2.1). None where f is undefined:
    /// V or L on P, a vanishing half vector (η = 1 at the solution) or interpolated normal.
    ///
    /// Always inlined, so that it is compiled into each of [`newton`]'s versions (baseline and
    /// AVX2), its one hot caller.
    ///
    /// [`newton`]: crate::scatter::triangle::solve::newton
    #[inline(always)]
    pub fn residual(&self, ends: &PathEnds, t: f64, a: f64, b: f64) -> Option<Residual> {
        let p = self.point(a, b);
        let v = ends.camera_point(t);
        let to_v = v - p;
        let to_l = ends.light - p;
        let n = self.normal(a, b);
        let d_v = to_v.length();
        let d_l = to_l.length();
        let normal_len = n.length();
        let usable = |x: f64| x.is_finite() && x > 0.0;
        if !(usable(d_v) && usable(d_l) && usable(normal_len)) {
            return None;
        }
        let omega_v = to_v / d_v;
        let omega_l = to_l / d_l;
        let normal_s = n / normal_len;
        let h = ends.eta * omega_v + omega_l;
        let h_len = h.length();
        if h_len.is_nan() || h_len <= 1e-300 {
            return None;
        }
        let h_unit = h / h_len;
        let f = h_unit + normal_s;

        // Derivatives of h along t, a, b: ∂v/∂t = r̂, ∂v/∂a = ∂l/∂a = −E1, ∂v/∂b = ∂l/∂b = −E2.
        let dh_dt = ends.eta * d_normalize(omega_v, d_v, ends.dir);
        let dh_da =
            -ends.eta * d_normalize(omega_v, d_v, self.e1) - d_normalize(omega_l, d_l, self.e1);
        let dh_db =
            -ends.eta * d_normalize(omega_v, d_v, self.e2) - d_normalize(omega_l, d_l, self.e2);
        let jt = d_normalize(h_unit, h_len, dh_dt);
        let ja = d_normalize(h_unit, h_len, dh_da) + d_normalize(normal_s, normal_len, self.dn1);
        let jb = d_normalize(h_unit, h_len, dh_db) + d_normalize(normal_s, normal_len, self.dn2);
        Some(Residual {
            f,
            jt,
            ja,
            jb,
            p,
            v,
            d_v,
            d_l,
            omega_v,
            omega_l,
            normal_s,
            normal_len,
            h,
            h_len_grad: [h_unit.dot(dh_dt), h_unit.dot(dh_da), h_unit.dot(dh_db)],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scatter::triangle::ground_truth::{SplitMix, curved_patch};

    fn random_unit(rng: &mut SplitMix) -> DVec3 {
        loop {
            let v = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// A random curved triangle near the origin, random V segment below and L above.
    fn random_configuration(rng: &mut SplitMix) -> (TrianglePatch, PathEnds, f64, f64, f64) {
        loop {
            let p = [
                DVec3::new(
                    rng.range(-2.0, 0.0),
                    rng.range(-2.0, 0.0),
                    rng.range(-0.2, 0.2),
                ),
                DVec3::new(
                    rng.range(0.5, 2.0),
                    rng.range(-1.5, 0.0),
                    rng.range(-0.2, 0.2),
                ),
                DVec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(0.5, 2.0),
                    rng.range(-0.2, 0.2),
                ),
            ];
            let n = [0, 1, 2]
                .map(|_| DVec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), 1.0).normalize());
            let Some(patch) = TrianglePatch::new(p, n) else {
                continue;
            };
            let ends = PathEnds {
                origin: DVec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-3.0, -0.5),
                ),
                dir: random_unit(rng),
                light: DVec3::new(
                    rng.range(-3.0, 3.0),
                    rng.range(-3.0, 3.0),
                    rng.range(0.5, 3.0),
                ),
                eta: rng.range(1.05, 2.5),
            };
            return (
                patch,
                ends,
                rng.range(0.0, 1.0),
                rng.range(0.0, 0.6),
                rng.range(0.0, 0.4),
            );
        }
    }

    /// Test (7): the analytic Jacobian equals central differences of f (step 1e-5) to 1e-7,
    /// relative to `1 + ‖column‖`, on 500 seeded random configurations.
    #[test]
    fn jacobian_matches_central_differences() {
        let mut rng = SplitMix(7);
        let step = 1e-5;
        let mut worst = 0.0f64;
        for case in 0..500 {
            let (patch, ends, t, a, b) = random_configuration(&mut rng);
            let r = patch.residual(&ends, t, a, b).expect("residual defined");
            let f = |t: f64, a: f64, b: f64| patch.residual(&ends, t, a, b).unwrap().f;
            let fd = [
                (f(t + step, a, b) - f(t - step, a, b)) / (2.0 * step),
                (f(t, a + step, b) - f(t, a - step, b)) / (2.0 * step),
                (f(t, a, b + step) - f(t, a, b - step)) / (2.0 * step),
            ];
            for (analytic, numeric) in [r.jt, r.ja, r.jb].iter().zip(fd) {
                let err = (*analytic - numeric).length() / (1.0 + analytic.length());
                worst = worst.max(err);
                assert!(
                    err < 1e-7,
                    "case {case}: J column {analytic} vs FD {numeric} (err {err:e}); patch {patch:?}, ends {ends:?}, t={t}, a={a}, b={b}"
                );
            }
        }
        println!("worst |J - J_fd|/(1+|J|) = {worst:e}");
    }

    /// The scaled residual's Jacobian (`Residual::scaled_apply`) equals central differences of
    /// `‖h‖·f` (step 1e-5) to 1e-7 relative to `1 + ‖column‖`, on 500 seeded random
    /// configurations, a fifth of them with η = 1 + 1e-6 (where ‖h‖ is small but, away from a
    /// zero, not tiny).
    #[test]
    fn scaled_jacobian_matches_central_differences() {
        let mut rng = SplitMix(8);
        let step = 1e-5;
        let mut worst = 0.0f64;
        for case in 0..500 {
            let (patch, mut ends, t, a, b) = random_configuration(&mut rng);
            if case % 5 == 0 {
                ends.eta = 1.0 + 1e-6;
            }
            let r = patch.residual(&ends, t, a, b).expect("residual defined");
            let g = |t: f64, a: f64, b: f64| patch.residual(&ends, t, a, b).unwrap().scaled();
            let fd = [
                (g(t + step, a, b) - g(t - step, a, b)) / (2.0 * step),
                (g(t, a + step, b) - g(t, a - step, b)) / (2.0 * step),
                (g(t, a, b + step) - g(t, a, b - step)) / (2.0 * step),
            ];
            let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            for (axis, numeric) in axes.iter().zip(fd) {
                let analytic = r.scaled_apply(*axis);
                let err = (analytic - numeric).length() / (1.0 + analytic.length());
                worst = worst.max(err);
                assert!(
                    err < 1e-7,
                    "case {case}: J_g column {analytic} vs FD {numeric} (err {err:e}); ends {ends:?}"
                );
            }
        }
        println!("worst |J_g - J_g,fd|/(1+|J_g|) = {worst:e}");
    }

    /// Test (8), first half: the row tangent lies in the kernel of J at a solution,
    /// `‖J g‖/(‖J‖‖g‖) < 1e-12`, and its orientation agrees with the closed form.
    #[test]
    fn row_tangent_is_in_the_kernel() {
        let (patch, ends) = curved_patch();
        let settings = crate::scatter::triangle::solve::NewtonSettings::new(
            1e-14,
            crate::scatter::triangle::ends::DepthRange::new(0.0, 0.0),
        );
        let (path, _) =
            crate::scatter::triangle::solve::solve_at(&patch, &ends, 0.0, (0.3, 0.3), &settings);
        let path = path.expect("reference path");
        let r = patch.residual(&ends, 0.0, path.a, path.b).unwrap();
        let g = r.tangent().expect("rank 2").to_array();
        let jg = r.apply(g).length();
        let scale = (r.jt.length() + r.ja.length() + r.jb.length()) * DVec3::from_array(g).length();
        assert!(jg / scale < 1e-12, "‖Jg‖ relative {}", jg / scale);
        let closed = DVec3::from_array(r.oriented_tangent().to_array());
        let cos =
            closed.dot(DVec3::from_array(g)) / (closed.length() * DVec3::from_array(g).length());
        assert!(
            cos > 1.0 - 1e-9,
            "row and closed-form tangents disagree: cos {cos}"
        );
    }

    #[test]
    fn degenerate_triangles_are_rejected() {
        let n = [DVec3::Z; 3];
        let sliver = [DVec3::ZERO, DVec3::X, DVec3::new(2.0, 1e-9, 0.0)];
        assert!(TrianglePatch::new(sliver, n).is_none());
        let point = [DVec3::ONE; 3];
        assert!(TrianglePatch::new(point, n).is_none());
        let good = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(TrianglePatch::new(good, [DVec3::ZERO, DVec3::Z, DVec3::Z]).is_none());
        assert!(TrianglePatch::new(good, [DVec3::NAN, DVec3::Z, DVec3::Z]).is_none());
        let patch = TrianglePatch::new(good, n).unwrap();
        assert!(patch.flat);
        // Winding opposite to the normals: the geometric normal still faces the normals' side.
        let flipped = TrianglePatch::new([DVec3::ZERO, DVec3::Y, DVec3::X], n).unwrap();
        assert_eq!(flipped.normal_g, DVec3::Z);
        assert!(flipped.flat);
        // The dual basis recovers barycentric coordinates on both windings.
        let x = flipped.point(0.3, 0.2);
        let (a, b) = flipped.barycentric(x);
        assert!((a - 0.3).abs() < 1e-15 && (b - 0.2).abs() < 1e-15);
    }
}
