//! The distance factor D of a refraction path: the cross-section at L of the ray pencil leaving V,
//! per unit solid angle at V ([H15] eq. 12, physics.md §1.2–1.3). It replaces the squared distance
//! of the inverse-square law; `1/D` carries all the focusing of the refracting surface.
//!
//! Three forms, all the *backward* quantity (perturb at V, measure at L) that [WZHB09] and [H15]
//! use:
//! * [`distance_flat`], the closed form (3) for flat triangles (N̂s = N̂g), WITH the η on `d_L`
//!   that the printed [H15] eq. 11 lacks (physics.md §1.2: the note wins);
//! * `distance_ray_differential` (tests only), the ray-differential form (4) with the shading-normal
//!   derivative (Igehy's transfer and refraction differentials);
//! * [`distance_jacobian`], the Jacobian form (5): one cross product once Newton has converged.
//!
//! [`distance_factor`] picks (3) for flat triangles and (5) otherwise; the tests show (5) equals (4)
//! and finite differences.

#[cfg(test)]
use glam::DVec3;

use crate::scatter::triangle::patch::{Residual, TrianglePatch};

/// D for a flat triangle, physics.md eq. (3):
/// `(d_V + η d_L)·(d_V cosθ_L/cosθ_V + η d_L cosθ_V/cosθ_L)`, cosines against the normal.
#[inline]
pub fn distance_flat(d_v: f64, d_l: f64, cos_v: f64, cos_l: f64, eta: f64) -> f64 {
    (d_v + eta * d_l) * (d_v * cos_l / cos_v + eta * d_l * cos_v / cos_l)
}

/// D from ray differentials, physics.md eq. (4) and the recipe of §1.3, at a zero of f.
#[cfg(test)]
pub fn distance_ray_differential(patch: &TrianglePatch, eta: f64, r: &Residual) -> f64 {
    let d = -r.omega_v;
    let n = r.normal_s;
    let ng = patch.normal_g;
    let c_v = d.dot(n);
    let c_l = r.omega_l.dot(n);
    let mu = eta * c_v - c_l;
    let d_dot_ng = d.dot(ng);
    let transfer = |u: DVec3| -> DVec3 {
        // (a) Transfer the direction change to the triangle's plane.
        let dp = r.d_v * (u - (u.dot(ng) / d_dot_ng) * d);
        // (b) Barycentric change, (c) shading-normal derivative.
        let (da, db) = (dp.dot(patch.g1), dp.dot(patch.g2));
        let dn = patch.dn1 * da + patch.dn2 * db;
        let d_normal = (dn - n * n.dot(dn)) / r.normal_len;
        // (d) Refraction differential (Igehy 1999).
        let dc_v = u.dot(n) + d.dot(d_normal);
        let dmu = -(eta * mu / c_l) * dc_v;
        let d_omega_l = eta * u - dmu * n - mu * d_normal;
        // (e) Transfer to L.
        dp + r.d_l * d_omega_l
    };
    let (u1, u2) = d.any_orthonormal_pair();
    r.omega_l.dot(transfer(u1).cross(transfer(u2))).abs()
}

/// D from the Newton Jacobian, physics.md eq. (5), at a zero of f:
/// `d_V² d_L² ‖η ω_V + ω_L‖² |N̂s·(J_a×J_b)| / (‖E1×E2‖ |ω_V·N̂g| |ω_L·N̂s|)`.
#[inline]
pub fn distance_jacobian(patch: &TrianglePatch, r: &Residual) -> f64 {
    let numerator = r.d_v
        * r.d_v
        * r.d_l
        * r.d_l
        * r.h.length_squared()
        * r.normal_s.dot(r.ja.cross(r.jb)).abs();
    let denominator =
        patch.double_area * r.omega_v.dot(patch.normal_g).abs() * r.omega_l.dot(r.normal_s).abs();
    numerator / denominator
}

/// D for the hot path: the closed form (3) on flat triangles, the Jacobian form (5) otherwise.
#[inline]
pub fn distance_factor(patch: &TrianglePatch, eta: f64, r: &Residual) -> f64 {
    if patch.flat {
        let n = patch.normal_g;
        distance_flat(
            r.d_v,
            r.d_l,
            r.omega_v.dot(n).abs(),
            r.omega_l.dot(n).abs(),
            eta,
        )
    } else {
        distance_jacobian(patch, r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scatter::triangle::ends::{DepthRange, PathEnds};
    use crate::scatter::triangle::ground_truth::{
        SplitMix, backward_fd_distance, curved_patch, flat_cases, forward_fd_distance,
    };
    use crate::scatter::triangle::solve::{
        NewtonSettings, RefractionPath, solve_at, straight_line_guess,
    };

    fn rel(x: f64, y: f64) -> f64 {
        (x / y - 1.0).abs()
    }

    fn solve(patch: &TrianglePatch, ends: &PathEnds) -> (RefractionPath, Residual) {
        let settings = NewtonSettings::new(1e-14, DepthRange::new(0.0, 0.0));
        let guess = straight_line_guess(patch, ends, 0.0).unwrap();
        let path = solve_at(patch, ends, 0.0, guess, &settings)
            .0
            .expect("path");
        let r = patch.residual(ends, 0.0, path.a, path.b).unwrap();
        (path, r)
    }

    fn big_flat() -> TrianglePatch {
        TrianglePatch::new(
            [
                DVec3::new(-20.0, -20.0, 0.0),
                DVec3::new(40.0, -20.0, 0.0),
                DVec3::new(-20.0, 40.0, 0.0),
            ],
            [DVec3::Z; 3],
        )
        .unwrap()
    }

    /// Test (2): on flat triangles the ray-differential D (4), the Jacobian D (5) and the closed
    /// form (3) agree to 1e-12 relative (300 seeded configurations); the §1.5 value is
    /// 15.83847645183; the printed [H15] eq. 11 (no η on d_L) is off by more than 5 %.
    #[test]
    fn flat_forms_agree() {
        let patch = big_flat();
        let cases = flat_cases(2, 300, 3.0);
        for (case, &(v, l, eta)) in cases.iter().enumerate() {
            let ends = PathEnds {
                origin: v,
                dir: DVec3::X,
                light: l,
                eta,
            };
            let (path, r) = solve(&patch, &ends);
            let closed = distance_flat(path.d_v, path.d_l, path.cos_v, path.cos_l, eta);
            let differential = distance_ray_differential(&patch, eta, &r);
            let jacobian = distance_jacobian(&patch, &r);
            assert!(
                rel(differential, closed) < 1e-12,
                "case {case}: (4) {differential} vs (3) {closed}"
            );
            assert!(
                rel(jacobian, closed) < 1e-12,
                "case {case}: (5) {jacobian} vs (3) {closed}"
            );
            if case == 0 {
                assert!(rel(closed, 15.83847645183) < 1e-11, "D {closed}");
                let printed = (path.d_v + eta * path.d_l)
                    * (path.cos_l / path.cos_v * path.d_v + path.cos_v / path.cos_l * path.d_l);
                assert!(
                    rel(printed, closed) > 0.05,
                    "printed eq. 11 {printed} vs {closed}"
                );
            }
        }
    }

    /// Test (3): at normal incidence D = (d_V + η d_L)² to 1e-13 relative, in all three forms.
    #[test]
    fn normal_incidence() {
        let patch = big_flat();
        for eta in [1.001, 1.33, 1.5, 2.42, 4.0] {
            let ends = PathEnds {
                origin: DVec3::new(0.2, 0.1, -0.7),
                dir: DVec3::X,
                light: DVec3::new(0.2, 0.1, 2.3),
                eta,
            };
            let (path, r) = solve(&patch, &ends);
            let expected = (0.7 + eta * 2.3f64).powi(2);
            assert!(
                rel(path.d_factor, expected) < 1e-13,
                "η={eta}: {} vs {expected}",
                path.d_factor
            );
            assert!(rel(distance_ray_differential(&patch, eta, &r), expected) < 1e-13);
            assert!(rel(distance_jacobian(&patch, &r), expected) < 1e-13);
        }
    }

    /// Test (4): η = 1 + 1e-6 gives D ≈ ‖L − V‖² to 1e-5 relative, on a flat and on a curved
    /// triangle's flat-normal twin (the closed and the Jacobian forms).
    #[test]
    fn index_matched_limit() {
        let patch = big_flat();
        let v = DVec3::new(0.3, -0.2, -0.8);
        let l = DVec3::new(1.7, 0.9, 1.3);
        let ends = PathEnds {
            origin: v,
            dir: DVec3::X,
            light: l,
            eta: 1.0 + 1e-6,
        };
        let (path, r) = solve(&patch, &ends);
        let expected = (l - v).length_squared();
        assert!(
            rel(path.d_factor, expected) < 1e-5,
            "{} vs {expected}",
            path.d_factor
        );
        assert!(rel(distance_jacobian(&patch, &r), expected) < 1e-5);
        assert!(rel(distance_ray_differential(&patch, ends.eta, &r), expected) < 1e-5);
    }

    /// Test (5): on the §1.5 curved triangle, D (4) equals the backward finite difference of §1.4
    /// to 1e-7 relative, the Jacobian form (5) to 1e-10, and the reference 10.0582729142 to 1e-10.
    /// Also on 100 seeded curved configurations.
    #[test]
    fn curved_forms_agree_with_finite_differences() {
        let (patch, ends) = curved_patch();
        let (path, r) = solve(&patch, &ends);
        let differential = distance_ray_differential(&patch, ends.eta, &r);
        let fd = backward_fd_distance(&patch, ends.origin, ends.light, ends.eta, path.p);
        let jacobian = distance_jacobian(&patch, &r);
        assert!(
            rel(differential, 10.0582729142) < 1e-10,
            "(4) {differential}"
        );
        assert!(
            rel(differential, fd) < 1e-7,
            "(4) {differential} vs FD {fd}"
        );
        assert!(
            rel(jacobian, differential) < 1e-10,
            "(5) {jacobian} vs (4) {differential}"
        );
        assert!(!patch.flat && rel(path.d_factor, jacobian) == 0.0);

        let mut rng = SplitMix(5);
        let mut tested = 0;
        while tested < 100 {
            let n = [0, 1, 2]
                .map(|_| DVec3::new(rng.range(-0.4, 0.4), rng.range(-0.4, 0.4), 1.0).normalize());
            let patch = TrianglePatch::new(
                [
                    DVec3::new(-1.5, -1.2, 0.0),
                    DVec3::new(1.8, -1.0, 0.1),
                    DVec3::new(-0.9, 1.7, -0.05),
                ],
                n,
            )
            .unwrap();
            let ends = PathEnds {
                origin: DVec3::new(
                    rng.range(-0.5, 0.5),
                    rng.range(-0.5, 0.5),
                    rng.range(-1.5, -0.3),
                ),
                dir: DVec3::X,
                light: DVec3::new(
                    rng.range(-2.0, 2.0),
                    rng.range(-2.0, 2.0),
                    rng.range(0.5, 3.0),
                ),
                eta: rng.range(1.1, 2.5),
            };
            let settings = NewtonSettings::new(1e-14, DepthRange::new(0.0, 0.0));
            let Some(guess) = straight_line_guess(&patch, &ends, 0.0) else {
                continue;
            };
            let Some(path) = solve_at(&patch, &ends, 0.0, guess, &settings).0 else {
                continue;
            };
            let r = patch.residual(&ends, 0.0, path.a, path.b).unwrap();
            let differential = distance_ray_differential(&patch, ends.eta, &r);
            let fd = backward_fd_distance(&patch, ends.origin, ends.light, ends.eta, path.p);
            let jacobian = distance_jacobian(&patch, &r);
            assert!(
                rel(differential, fd) < 1e-6,
                "(4) {differential} vs FD {fd}: {patch:?} {ends:?}"
            );
            assert!(
                rel(jacobian, differential) < 1e-10,
                "(5) {jacobian} vs (4) {differential}: {patch:?} {ends:?}"
            );
            tested += 1;
        }
    }

    /// Test (6): for flat triangles the forward factor η² dA_V/dω_L (perturb at L, measure at V)
    /// equals D to 1e-7; on the curved §1.5 triangle it is 10.2357712307 and follows the
    /// shading-normal adjoint relation (6).
    #[test]
    fn forward_factor() {
        let patch = big_flat();
        let ends = PathEnds {
            origin: DVec3::new(0.3, -0.2, -0.8),
            dir: DVec3::X,
            light: DVec3::new(1.7, 0.9, 1.3),
            eta: 1.5,
        };
        let (path, _) = solve(&patch, &ends);
        let forward = forward_fd_distance(&patch, ends.origin, ends.light, ends.eta, path.p);
        assert!(
            rel(forward, path.d_factor) < 1e-7,
            "forward {forward} vs D {}",
            path.d_factor
        );

        let (patch, ends) = curved_patch();
        let (path, r) = solve(&patch, &ends);
        let forward = forward_fd_distance(&patch, ends.origin, ends.light, ends.eta, path.p);
        assert!(rel(forward, 10.2357712307) < 1e-7, "forward {forward}");
        let ng = patch.normal_g;
        let adjoint = path.d_factor * (r.omega_v.dot(ng).abs() * path.cos_l)
            / (r.omega_l.dot(ng).abs() * path.cos_v);
        assert!(
            rel(forward, adjoint) < 1e-7,
            "forward {forward} vs (6) {adjoint}"
        );
    }
}
