//! Independent ground truth for the scattering tests (physics.md §1.4, §1.5, §5): the exact flat
//! refraction point by safeguarded Newton/bisection on Snell's law, finite-difference distance
//! factors by tracing perturbed rays, a seeded random generator, and the reference configurations.
//!
//! Nothing here calls the code under test; it is written from the physics, not from the solver.

use glam::DVec3;

use crate::scatter::triangle::ends::PathEnds;
use crate::scatter::triangle::patch::TrianglePatch;

/// A tiny seeded generator (SplitMix64) for reproducible property tests.
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform number in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let unit = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * unit
    }
}

/// The §1.5 curved triangle with V = (−0.2, 0.05, −0.6) as the segment origin (t = 0) and
/// L = (0.8, 0.6, 1.5), η = 1.5.
pub fn curved_patch() -> (TrianglePatch, PathEnds) {
    let patch = TrianglePatch::new(
        [
            DVec3::new(-1.5, -1.2, 0.0),
            DVec3::new(1.8, -1.0, 0.1),
            DVec3::new(-0.9, 1.7, -0.05),
        ],
        [
            DVec3::new(-0.35, -0.2, 1.0).normalize(),
            DVec3::new(0.4, -0.25, 1.0).normalize(),
            DVec3::new(-0.1, 0.45, 1.0).normalize(),
        ],
    )
    .expect("reference triangle");
    let ends = PathEnds {
        origin: DVec3::new(-0.2, 0.05, -0.6),
        dir: DVec3::X,
        light: DVec3::new(0.8, 0.6, 1.5),
        eta: 1.5,
    };
    (patch, ends)
}

/// The exact refraction point on the plane through `origin` with unit normal `normal` (toward the
/// light) for V below and L above (physics.md §5): Snell's law in the plane of incidence,
/// `F(x) = η x/√(x²+h_V²) − (ℓ−x)/√((ℓ−x)²+h_L²) = 0`, F strictly increasing on [0, ℓ], solved by
/// Newton steps kept inside a shrinking bisection bracket.
pub fn flat_refraction_point(origin: DVec3, normal: DVec3, v: DVec3, l: DVec3, eta: f64) -> DVec3 {
    let h_v = (origin - v).dot(normal);
    let h_l = (l - origin).dot(normal);
    assert!(
        h_v > 0.0 && h_l > 0.0,
        "V must be below and L above the plane"
    );
    let v_foot = v + h_v * normal;
    let l_foot = l - h_l * normal;
    let ell = (l_foot - v_foot).length();
    if ell == 0.0 {
        return v_foot;
    }
    let e = (l_foot - v_foot) / ell;
    let f = |x: f64| {
        eta * x / (x * x + h_v * h_v).sqrt() - (ell - x) / ((ell - x).powi(2) + h_l * h_l).sqrt()
    };
    let df = |x: f64| {
        eta * h_v * h_v / (x * x + h_v * h_v).powf(1.5)
            + h_l * h_l / ((ell - x).powi(2) + h_l * h_l).powf(1.5)
    };
    let (mut lo, mut hi) = (0.0, ell);
    let mut x = ell * h_v / (h_v + h_l);
    for _ in 0..300 {
        let fx = f(x);
        if fx == 0.0 {
            break;
        }
        if fx < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - fx / df(x);
        x = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 4.0 * f64::EPSILON * ell || (x == lo || x == hi) {
            break;
        }
    }
    v_foot + x * e
}

/// Traces `V + s·dir` to the triangle's plane (unclipped, normals extrapolated) and refracts out of
/// the medium; returns the hit point and the refracted direction.
fn trace_out(patch: &TrianglePatch, v: DVec3, dir: DVec3, eta: f64) -> (DVec3, DVec3) {
    let ng = (patch.e1.cross(patch.e2)).normalize();
    let s = (patch.p0 - v).dot(ng) / dir.dot(ng);
    let p = v + s * dir;
    let rel = p - patch.p0;
    let (a, b) = (rel.dot(patch.g1), rel.dot(patch.g2));
    let n = (patch.n0 + a * patch.dn1 + b * patch.dn2).normalize();
    let c = dir.dot(n);
    let omega = eta * dir - (eta * c - (1.0 - eta * eta * (1.0 - c * c)).sqrt()) * n;
    (p, omega)
}

/// Traces a ray from the light along `dir` to the triangle's plane and refracts into the medium.
fn trace_in(patch: &TrianglePatch, l: DVec3, dir: DVec3, eta: f64) -> (DVec3, DVec3) {
    let ng = (patch.e1.cross(patch.e2)).normalize();
    let s = (patch.p0 - l).dot(ng) / dir.dot(ng);
    let p = l + s * dir;
    let rel = p - patch.p0;
    let (a, b) = (rel.dot(patch.g1), rel.dot(patch.g2));
    let n = (patch.n0 + a * patch.dn1 + b * patch.dn2).normalize();
    let c = -dir.dot(n);
    let t = dir / eta + (c / eta - (1.0 - (1.0 - c * c) / (eta * eta)).sqrt()) * n;
    (p, t)
}

/// Central-difference step in direction space (f64, physics.md §1.4).
const FD_STEP: f64 = 1e-5;

/// The backward distance factor by finite differences (physics.md §1.4): perturb the direction at
/// V toward the refraction point `p`, trace and refract, and measure the displacement in the plane
/// through L perpendicular to ω_L.
pub fn backward_fd_distance(patch: &TrianglePatch, v: DVec3, l: DVec3, eta: f64, p: DVec3) -> f64 {
    let d0 = (p - v).normalize();
    let omega_l0 = (l - p).normalize();
    let (u1, u2) = d0.any_orthonormal_pair();
    let at_light = |dir: DVec3| {
        let (q, omega) = trace_out(patch, v, dir.normalize(), eta);
        let s2 = (l - q).dot(omega_l0) / omega.dot(omega_l0);
        q + s2 * omega
    };
    let x1 = (at_light(d0 + FD_STEP * u1) - at_light(d0 - FD_STEP * u1)) / (2.0 * FD_STEP);
    let x2 = (at_light(d0 + FD_STEP * u2) - at_light(d0 - FD_STEP * u2)) / (2.0 * FD_STEP);
    x1.cross(x2).length()
}

/// The forward (physical) factor `η² dA_V⊥/dω_L` by finite differences (physics.md §1.4 item 4):
/// perturb the direction at L, refract into the medium, and measure at the plane through V
/// perpendicular to ω_V.
pub fn forward_fd_distance(patch: &TrianglePatch, v: DVec3, l: DVec3, eta: f64, p: DVec3) -> f64 {
    let w0 = (p - l).normalize();
    let omega_v0 = (v - p).normalize();
    let (u1, u2) = w0.any_orthonormal_pair();
    let at_camera = |dir: DVec3| {
        let (q, t) = trace_in(patch, l, dir.normalize(), eta);
        let s2 = (v - q).dot(omega_v0) / t.dot(omega_v0);
        q + s2 * t
    };
    let y1 = (at_camera(w0 + FD_STEP * u1) - at_camera(w0 - FD_STEP * u1)) / (2.0 * FD_STEP);
    let y2 = (at_camera(w0 + FD_STEP * u2) - at_camera(w0 - FD_STEP * u2)) / (2.0 * FD_STEP);
    eta * eta * y1.cross(y2).length()
}

/// Nodes and weights of n-point Gauss–Legendre quadrature on [−1, 1] (Newton on the Legendre
/// recurrence), for smooth ground-truth integrals.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut rule = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        rule.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    rule
}

/// Seeded flat-plane configurations `(V, L, η)` for the plane z = 0: the §1.5 case, then `n`
/// random ones with V below the plane (|x|, |y| ≤ 1, z ∈ [−2, −0.05]), L above it (|x|, |y| ≤
/// `light_spread`, z ∈ [0.05, 3]) and η ∈ [1.001, 4].
pub fn flat_cases(seed: u64, n: usize, light_spread: f64) -> Vec<(DVec3, DVec3, f64)> {
    let mut rng = SplitMix(seed);
    let mut cases = vec![(DVec3::new(0.3, -0.2, -0.8), DVec3::new(1.7, 0.9, 1.3), 1.5)];
    for _ in 0..n {
        cases.push((
            DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-2.0, -0.05),
            ),
            DVec3::new(
                rng.range(-light_spread, light_spread),
                rng.range(-light_spread, light_spread),
                rng.range(0.05, 3.0),
            ),
            rng.range(1.001, 4.0),
        ));
    }
    cases
}

/// The physics.md §1.5 end-to-end flat-plane configuration: the camera segment
/// (0.3, −0.2, −0.05) → (0.1, 0.1, −3.0) as path ends with its length, the light at
/// (1.7, 0.9, 1.3), η = 1.5, and the medium σ_s = 0.5, σ_t = 0.7, HG g = 0.3.
pub fn flat_plane_integral_setup() -> (PathEnds, f64, crate::medium::Medium) {
    let start = DVec3::new(0.3, -0.2, -0.05);
    let end = DVec3::new(0.1, 0.1, -3.0);
    let length = (end - start).length();
    let ends = PathEnds {
        origin: start,
        dir: (end - start) / length,
        light: DVec3::new(1.7, 0.9, 1.3),
        eta: 1.5,
    };
    let medium = crate::medium::Medium {
        sigma_s: DVec3::splat(0.5),
        sigma_t: DVec3::splat(0.7),
        phase: crate::medium::PhaseFunction::HenyeyGreenstein { g: 0.3 },
    };
    (ends, length, medium)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Gauss–Legendre rule integrates polynomials of degree 2n−1 exactly.
    #[test]
    fn gauss_legendre_is_exact_for_polynomials() {
        let rule = gauss_legendre(20);
        let integral: f64 = rule.iter().map(|(x, w)| w * x.powi(38)).sum();
        assert!((integral - 2.0 / 39.0).abs() < 1e-14, "{integral}");
        let total: f64 = rule.iter().map(|(_, w)| w).sum();
        assert!((total - 2.0).abs() < 1e-14);
    }

    /// The flat refraction point obeys Snell's law to round-off.
    #[test]
    fn flat_point_obeys_snell() {
        let (v, l, eta) = (DVec3::new(0.3, -0.2, -0.8), DVec3::new(1.7, 0.9, 1.3), 1.5);
        let p = flat_refraction_point(DVec3::ZERO, DVec3::Z, v, l, eta);
        let sin_v = (v - p).normalize().cross(DVec3::Z).length();
        let sin_l = (l - p).normalize().cross(DVec3::Z).length();
        assert!((eta * sin_v - sin_l).abs() < 1e-15);
        assert!((p - DVec3::new(0.643387768259381, 0.069804675060942, 0.0)).length() < 1e-14);
    }
}
