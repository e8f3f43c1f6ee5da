//! The damped pseudo-inverse Newton solver for `f(t, a, b) = 0` ([H15] eqs. 8–9, physics.md §2.2),
//! the validity checks that turn a zero of f into a [`RefractionPath`], and the initial guesses.
//!
//! Every solve in the interval method fixes one degree of freedom of `(t, a, b)`: t at a sample
//! point, a barycentric coordinate on an edge, or the position along the tangent while tracing
//! the curve. All of these are affine 2-D slices of parameter space ([`Slice`]), so one damped
//! Newton serves them all: the 3×2 sub-Jacobian is `J·[du dv]` and the step is
//! `δ = −(J₂ᵀJ₂)⁻¹ J₂ᵀ f`, taken on the scaled residual `‖h‖·f` (same zeros, well conditioned as
//! η → 1; see [`Residual::scaled`]).

use glam::DVec3;
use spindle_common::stats::RenderStats;

use crate::fresnel;
use crate::scatter::triangle::curve::CurvePoint;
use crate::scatter::triangle::distance::distance_factor;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::patch::{Residual, TrianglePatch};
use crate::scatter::triangle::small_list::SmallList;

/// Barycentric slack of the inside-triangle test, so a path exactly on a shared edge is kept.
pub const INSIDE_TOLERANCE: f64 = 1e-9;

/// Paths leaving at grazing angles (`c_L` below this) are skipped: there `D → ∞` and `T_P → 0`
/// (physics.md §2.5 item 4), so their contribution vanishes and D is ill-conditioned.
pub const MIN_COS_LIGHT: f64 = 1e-9;

/// A solve that can no longer decrease ‖g‖ = ‖h‖·‖f‖ by any damped step is at the floating-point floor and
/// is accepted as converged if ‖f‖ is below this bound. The floor rises for configurations far
/// from the origin relative to their size and as η → 1 (physics.md §2.5 items 2 and 6), where a
/// requested tolerance tighter than the floor cannot be met.
const STAGNATION_ACCEPT: f64 = 1e-6;

/// The initial bound on a step's barycentric size (physics.md §2.2 pitfalls: undamped steps run off
/// to infinity, where ‖f‖ → √2).
const STEP_MAX_START: f64 = 0.5;
/// The largest the step bound may grow to after good steps.
const STEP_MAX_CAP: f64 = 1.5;
/// Plain and halved Gauss–Newton attempts of one step before Levenberg–Marquardt damping.
const GAUSS_NEWTON_ATTEMPTS: u32 = 3;
/// Attempts of one step (Gauss–Newton, then damping λ = tr(J₂ᵀJ₂)·10^(k−5), k = 0..) before the
/// solve gives up on decreasing ‖f‖.
const MAX_ATTEMPTS: u32 = 12;
/// Barycentric coordinates outside (−1, 2) abort the solve: the curve is not near this triangle.
const BARYCENTRIC_ESCAPE: (f64, f64) = (-1.0, 2.0);

/// Stopping rules of the Newton solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Stop when ‖f‖ (dimensionless: a difference of unit vectors) is at most this.
    pub tolerance: f64,
    /// At most this many evaluations of f (backtracking included).
    pub max_evaluations: u32,
    /// The range of t the solve may visit; a step is shortened to go at most 3/4 of the way to
    /// a bound it would cross.
    pub t_range: DepthRange,
}

impl NewtonSettings {
    /// Settings for a solve at tolerance `tolerance` with t confined to `t_range`.
    pub fn new(tolerance: f64, t_range: DepthRange) -> Self {
        NewtonSettings {
            tolerance,
            max_evaluations: 60,
            t_range,
        }
    }
}

/// An affine 2-D slice of parameter space, `x(u, v) = origin + u·du + v·dv`, `x = (t, a, b)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slice {
    /// The point at `(u, v) = (0, 0)`.
    pub origin: [f64; 3],
    /// The direction of u.
    pub du: [f64; 3],
    /// The direction of v.
    pub dv: [f64; 3],
}

impl Slice {
    /// t fixed; `(u, v) = (a, b)`.
    pub fn fixed_t(t: f64) -> Slice {
        Slice {
            origin: [t, 0.0, 0.0],
            du: [0.0, 1.0, 0.0],
            dv: [0.0, 0.0, 1.0],
        }
    }

    /// The point of parameter space at `(u, v)`.
    #[inline]
    pub fn at(&self, u: f64, v: f64) -> CurvePoint {
        CurvePoint::from_array([0, 1, 2].map(|i| self.origin[i] + u * self.du[i] + v * self.dv[i]))
    }
}

/// A zero of f found by [`newton`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Converged {
    /// The slice coordinates of the zero.
    pub uv: (f64, f64),
    /// The zero in parameter space.
    pub x: CurvePoint,
    /// f and J there.
    pub residual: Residual,
}

/// Damped Gauss–Newton (pseudo-inverse) on one slice, from `start`. Returns the zero if found and
/// the number of evaluations of f spent (for the statistics).
///
/// The steps and their acceptance use the scaled residual `g = ‖h‖·f` and its Jacobian
/// ([`Residual::scaled`]); convergence is still `‖f‖ ≤ tolerance`. On f itself, at η = 1 + 1e-6
/// a fixed-t solve from a seed 1e-3 away creeps and does not converge in 60 evaluations; on g it
/// converges as at any η, and for η ≥ 1.33 it takes slightly fewer evaluations than on f.
///
/// Damping: the barycentric part of a step is clamped to a bound that starts at 0.5, grows ×1.2
/// per accepted step up to 1.5 and halves when backtracking was needed; a step that does not
/// decrease ‖g‖ is halved twice, then Levenberg–Marquardt damped with growing λ. The solve aborts
/// when a or b leaves (−1, 2), when `J₂ᵀJ₂` is singular, or after `max_evaluations`.
///
/// Compiled for the baseline x86-64 and for AVX2, chosen at run time like the edge scans'
/// `skew_signs`: the same operations in the same order, so the same bits on every machine.
#[multiversion::multiversion(targets("x86_64+avx+avx2"))]
pub fn newton(
    patch: &TrianglePatch,
    ends: &PathEnds,
    slice: &Slice,
    start: (f64, f64),
    settings: &NewtonSettings,
) -> (Option<Converged>, u32) {
    let (mut u, mut v) = start;
    let mut evaluations = 1;
    // A residual is some 300 bytes, so it is moved only when a step is accepted (moving it costs
    // a good part of an evaluation).
    let eval = |x: CurvePoint| {
        if !(x.a > BARYCENTRIC_ESCAPE.0
            && x.a < BARYCENTRIC_ESCAPE.1
            && x.b > BARYCENTRIC_ESCAPE.0
            && x.b < BARYCENTRIC_ESCAPE.1)
        {
            return None;
        }
        patch.residual(ends, x.t, x.a, x.b)
    };
    let mut x = slice.at(u, v);
    let Some(mut r) = eval(x) else {
        return (None, evaluations);
    };
    let mut norm = r.f.length();
    let mut merit = r.scaled().length();
    let mut step_max = STEP_MAX_START;
    loop {
        if norm <= settings.tolerance {
            return (
                Some(Converged {
                    uv: (u, v),
                    x,
                    residual: r,
                }),
                evaluations,
            );
        }
        if evaluations >= settings.max_evaluations {
            return (None, evaluations);
        }

        // The pseudo-inverse step δ = −(J₂ᵀJ₂)⁻¹ J₂ᵀ g ([H15] eq. 9, on g = ‖h‖·f); when it and
        // its halvings fail to decrease ‖g‖ (far from the solution J₂ is nearly rank 1 and the step follows
        // the weak direction), Levenberg–Marquardt damping turns it toward steepest descent.
        let g = r.scaled();
        let ju = r.scaled_apply(slice.du);
        let jv = r.scaled_apply(slice.dv);
        let (auu, auv, avv) = (ju.dot(ju), ju.dot(jv), jv.dot(jv));
        let (gu, gv) = (ju.dot(g), jv.dot(g));
        let trace = auu + avv;
        if !trace.is_finite() || trace <= 0.0 {
            return (None, evaluations);
        }
        let mut accepted = None;
        let mut attempt = 0;
        while attempt <= MAX_ATTEMPTS && evaluations < settings.max_evaluations {
            let (lambda, shrink) = if attempt < GAUSS_NEWTON_ATTEMPTS {
                (0.0, 0.5f64.powi(attempt as i32))
            } else {
                (
                    trace * 10f64.powi(attempt as i32 - GAUSS_NEWTON_ATTEMPTS as i32 - 5),
                    1.0,
                )
            };
            attempt += 1;
            let (a11, a22) = (auu + lambda, avv + lambda);
            let det = a11 * a22 - auv * auv;
            if !det.is_finite() || det <= 1e-24 * a11 * a22 {
                continue;
            }
            let mut du = -(a22 * gu - auv * gv) / det * shrink;
            let mut dv = -(a11 * gv - auv * gu) / det * shrink;

            // Clamp the barycentric size of the step, and keep t inside its range.
            let step = slice_step(slice, du, dv);
            let bary = step[1].abs().max(step[2].abs());
            let mut scale: f64 = if bary > step_max {
                step_max / bary
            } else {
                1.0
            };
            let t_next = x.t + scale * step[0];
            if t_next > settings.t_range.hi && step[0] > 0.0 {
                scale = scale.min(0.75 * (settings.t_range.hi - x.t).max(0.0) / step[0]);
            } else if t_next < settings.t_range.lo && step[0] < 0.0 {
                scale = scale.min(0.75 * (settings.t_range.lo - x.t).min(0.0) / step[0]);
            }
            du *= scale;
            dv *= scale;

            evaluations += 1;
            let x_new = slice.at(u + du, v + dv);
            if let Some(r_new) = eval(x_new) {
                let merit_new = r_new.scaled().length();
                if merit_new < merit {
                    x = x_new;
                    r = r_new;
                    accepted = Some((merit_new, du, dv));
                    break;
                }
            }
        }
        match accepted {
            Some((merit_new, du, dv)) => {
                u += du;
                v += dv;
                norm = r.f.length();
                merit = merit_new;
                step_max = if attempt == 1 {
                    (step_max * 1.2).min(STEP_MAX_CAP)
                } else {
                    step_max * 0.5
                };
            }
            // No attempt decreased ‖g‖: the floating-point floor, if ‖f‖ is already small.
            None if attempt > MAX_ATTEMPTS && norm <= STAGNATION_ACCEPT => {
                return (
                    Some(Converged {
                        uv: (u, v),
                        x,
                        residual: r,
                    }),
                    evaluations,
                );
            }
            None => return (None, evaluations),
        }
    }
}

/// The parameter-space displacement of a slice step `(du, dv)`.
#[inline]
fn slice_step(slice: &Slice, du: f64, dv: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| du * slice.du[i] + dv * slice.dv[i])
}

/// A valid refraction path V → P → L through one triangle, with what its contribution needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefractionPath {
    /// The camera-segment parameter of V.
    pub t: f64,
    /// The refraction point P.
    pub p: DVec3,
    /// Barycentric a of P.
    pub a: f64,
    /// Barycentric b of P.
    pub b: f64,
    /// `‖V − P‖`.
    pub d_v: f64,
    /// `‖L − P‖`.
    pub d_l: f64,
    /// `(V − P)/d_V`: the direction light travels at V, into the medium.
    pub omega_v: DVec3,
    /// `(L − P)/d_L`.
    pub omega_l: DVec3,
    /// `|ω_V·N̂s|`.
    pub cos_v: f64,
    /// `ω_L·N̂s > 0`.
    pub cos_l: f64,
    /// The distance factor D ([H15] eq. 12, physics.md §1.2–1.3), backward form, m²/sr.
    pub d_factor: f64,
    /// The Fresnel transmittance `T_P = 1 − F_r(cos_l; η)`.
    pub fresnel_t: f64,
    /// `N̂s·(J_a×J_b)`: its sign labels the branch of the curve (it flips at a fold).
    pub branch: f64,
}

impl RefractionPath {
    /// Checks that a zero of f at `(t, a, b)` is a physical refraction path and completes it:
    /// P inside the triangle (with [`INSIDE_TOLERANCE`]), L in front of and V behind both the
    /// shading and the geometric tangent planes (physics.md §2.5 item 3: f = 0 also holds for
    /// spurious "both inside" configurations), and a non-grazing exit (`c_L > MIN_COS_LIGHT`).
    pub fn from_zero(
        patch: &TrianglePatch,
        ends: &PathEnds,
        t: f64,
        a: f64,
        b: f64,
        r: &Residual,
    ) -> Option<RefractionPath> {
        if !patch.contains(a, b, INSIDE_TOLERANCE) {
            return None;
        }
        if !is_physical(patch, r) {
            return None;
        }
        let cos_l = r.omega_l.dot(r.normal_s);
        let cos_v = -r.omega_v.dot(r.normal_s);
        let d_factor = distance_factor(patch, ends.eta, r);
        if !d_factor.is_finite() || d_factor <= 0.0 {
            return None;
        }
        Some(RefractionPath {
            t,
            p: r.p,
            a,
            b,
            d_v: r.d_v,
            d_l: r.d_l,
            omega_v: r.omega_v,
            omega_l: r.omega_l,
            cos_v,
            cos_l,
            d_factor,
            fresnel_t: 1.0 - fresnel::reflectance(cos_l, ends.eta),
            branch: r.oriented_tangent().t,
        })
    }
}

/// Whether a zero of f is a physical refraction (ignoring the triangle's extent): L in front of and
/// V behind both the shading and the geometric tangent planes (physics.md §2.5 item 3), and a
/// non-grazing exit, `c_L > MIN_COS_LIGHT`.
pub fn is_physical(patch: &TrianglePatch, r: &Residual) -> bool {
    r.omega_l.dot(r.normal_s) > MIN_COS_LIGHT
        && r.omega_v.dot(r.normal_s) < 0.0
        && r.omega_l.dot(patch.normal_g) > 0.0
        && r.omega_v.dot(patch.normal_g) < 0.0
}

/// Solves for the refraction path at the fixed camera point `V(t)`, starting from `guess = (a, b)`.
/// Returns the valid path, if any, and the evaluations of f spent.
pub fn solve_at(
    patch: &TrianglePatch,
    ends: &PathEnds,
    t: f64,
    guess: (f64, f64),
    settings: &NewtonSettings,
) -> (Option<RefractionPath>, u32) {
    let (zero, evaluations) = newton(patch, ends, &Slice::fixed_t(t), guess, settings);
    let path =
        zero.and_then(|z| RefractionPath::from_zero(patch, ends, t, z.x.a, z.x.b, &z.residual));
    (path, evaluations)
}

/// Every valid refraction point inside the triangle at `V(t)`, by brute force: Newton from a
/// triangular grid of `n(n+1)/2` starts over the triangle (`n` per side), deduplicated to 1e-8 in
/// barycentric units, at most `N` (extra ones are dropped, and counted in
/// `stats.capacity_drops`). For the reference estimator and for
/// tests: it finds every branch the grid resolves, at about `n²/2` solves per call. Newton work
/// and failures go to `stats`.
pub fn solve_all_at<const N: usize>(
    patch: &TrianglePatch,
    ends: &PathEnds,
    t: f64,
    n: usize,
    tolerance: f64,
    stats: &mut RenderStats,
) -> SmallList<RefractionPath, N> {
    let settings = NewtonSettings::new(tolerance, DepthRange { lo: t, hi: t });
    let mut found: SmallList<RefractionPath, N> = SmallList::default();
    for i in 0..n {
        for j in 0..(n - i) {
            let start = ((i as f64 + 0.3) / n as f64, (j as f64 + 0.3) / n as f64);
            let (path, spent) = solve_at(patch, ends, t, start, &settings);
            stats.newton_iterations += spent as u64;
            let Some(p) = path else { continue };
            if patch.contains(p.a, p.b, 0.0)
                && !found
                    .iter()
                    .any(|q| (q.a - p.a).abs() < 1e-8 && (q.b - p.b).abs() < 1e-8)
            {
                found.push_or_count(p, &mut stats.capacity_drops);
            }
        }
    }
    found
}

/// The default starting point of a fixed-t solve: where the straight line V → L crosses the
/// triangle's plane, which is exact at η = 1 and close for mildly refracting paths. None if the
/// line is parallel to the plane.
pub fn straight_line_guess(patch: &TrianglePatch, ends: &PathEnds, t: f64) -> Option<(f64, f64)> {
    let v = ends.camera_point(t);
    let dv = patch.plane_distance(v);
    let dl = patch.plane_distance(ends.light);
    let denom = dl - dv;
    if denom.is_nan() || denom == 0.0 {
        return None;
    }
    let s = (-dv / denom).clamp(0.0, 1.0);
    let x = v + s * (ends.light - v);
    let (a, b) = patch.barycentric(x);
    (a.is_finite() && b.is_finite()).then_some((a, b))
}

/// The best cheap starting point of a fixed-t solve: the exact refraction point through the
/// triangle's (flat) plane, found in the plane of incidence by Newton steps kept inside a
/// bisection bracket on Snell's law `η x/√(x²+h_V²) = (ℓ−x)/√((ℓ−x)²+h_L²)`, which is strictly
/// monotone (physics.md §5). Exact for flat triangles and close for curved ones, it starts the
/// Newton solve away from the region where Ĥ·N̂ > 0, from which descent on ‖f‖ runs off to infinity
/// (physics.md §2.2 pitfalls). None unless V is behind and L in front of the plane, and None
/// where the guess would lie beyond [`BARYCENTRIC_ESCAPE`], where [`newton`] stops at once.
pub fn plane_refraction_guess(
    patch: &TrianglePatch,
    ends: &PathEnds,
    t: f64,
) -> Option<(f64, f64)> {
    let v = ends.camera_point(t);
    let n = patch.normal_g;
    let h_v = -patch.plane_distance(v);
    let h_l = patch.plane_distance(ends.light);
    if !(h_v > 0.0 && h_l > 0.0) {
        return None;
    }
    let v_foot = v + h_v * n;
    let across = (ends.light - h_l * n) - v_foot;
    // The guess lies between the feet of V and L on the plane: where both are beyond the same
    // side of the escape box (by a margin far above rounding), so is the guess. Most range-end
    // solves of the interval search are of this kind, and the Snell solve below is their cost.
    let (foot_v, foot_l) = (
        patch.barycentric(v_foot),
        patch.barycentric(v_foot + across),
    );
    let (low, high) = (BARYCENTRIC_ESCAPE.0 - 0.5, BARYCENTRIC_ESCAPE.1 + 0.5);
    let beyond = |x: f64, y: f64| (x < low && y < low) || (x > high && y > high);
    if beyond(foot_v.0, foot_l.0) || beyond(foot_v.1, foot_l.1) {
        return None;
    }
    let ell = across.length();
    let x = if ell > 0.0 {
        let eta = ends.eta;
        let snell = |x: f64| {
            let (sv, sl) = (
                (x * x + h_v * h_v).sqrt(),
                ((ell - x).powi(2) + h_l * h_l).sqrt(),
            );
            let value = eta * x / sv - (ell - x) / sl;
            let slope = eta * h_v * h_v / (sv * sv * sv) + h_l * h_l / (sl * sl * sl);
            (value, slope)
        };
        let (mut lo, mut hi) = (0.0, ell);
        let mut x = ell * h_v / (h_v + h_l);
        for _ in 0..64 {
            let (value, slope) = snell(x);
            if value == 0.0 {
                break;
            }
            if value < 0.0 {
                lo = x;
            } else {
                hi = x;
            }
            let newton = x - value / slope;
            let next = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if (next - x).abs() <= 1e-15 * ell {
                x = next;
                break;
            }
            x = next;
        }
        x
    } else {
        0.0
    };
    let point = if ell > 0.0 {
        v_foot + (x / ell) * across
    } else {
        v_foot
    };
    let (a, b) = patch.barycentric(point);
    (a.is_finite() && b.is_finite()).then_some((a, b))
}

/// Where the camera line pierces the triangle's plane, and the solution curve's tangent there
/// (physics.md §2.2). At the piercing point `t_p` the curve passes through `P = V(t_p)`; near it
/// `V − P` is parallel to the refracted light direction w at that point, so
/// `dP/dt = r̂ − (r̂·N̂g)/(w·N̂g)·w`. Returns the point `(t_p, a_p, b_p)` and the tangent
/// `(1, da/dt, db/dt)`, or None if the
/// line is parallel to the plane or the light is behind the shading normal there.
pub fn plane_piercing(patch: &TrianglePatch, ends: &PathEnds) -> Option<(CurvePoint, CurvePoint)> {
    let r_dot_n = ends.dir.dot(patch.normal_g);
    if r_dot_n.is_nan() || r_dot_n.abs() <= 1e-12 {
        return None;
    }
    let t_p = -patch.plane_distance(ends.origin) / r_dot_n;
    let v = ends.camera_point(t_p);
    let (a, b) = patch.barycentric(v);
    let n = patch.normal(a, b).try_normalize()?;
    let incoming = (v - ends.light).try_normalize()?;
    if incoming.dot(n).is_nan() || incoming.dot(n) >= 0.0 {
        return None;
    }
    let w = fresnel::refract(incoming, n, ends.eta)?;
    let w_dot_n = w.dot(patch.normal_g);
    if w_dot_n.is_nan() || w_dot_n >= -1e-12 {
        return None;
    }
    let dp_dt = ends.dir - (r_dot_n / w_dot_n) * w;
    Some((
        CurvePoint::new(t_p, a, b),
        CurvePoint::new(1.0, dp_dt.dot(patch.g1), dp_dt.dot(patch.g2)),
    ))
}

#[cfg(test)]
mod tests;
