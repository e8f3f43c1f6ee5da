//! The radiance one refraction path V → P → L scatters toward the camera at V (physics.md §1.1,
//! eq. 2; [H15] eq. 10), per RGB channel.
//!
//! η² bookkeeping (physics.md §1.1 item 4): spindle's camera throughput is in radiance mode, so it
//! already carries `(1 − F_r(V_min))/η²` from the camera ray's entry into the medium. This function
//! therefore includes the η² of the irradiance inside the medium (physics.md eq. 1) and does NOT
//! include `T(V_min)`: the two cancel the throughput's 1/η² exactly as [H15] eq. 10 assumes.

use crate::Rgb;
use crate::medium::Medium;
use crate::scatter::triangle::ends::PathEnds;
use crate::scatter::triangle::solve::RefractionPath;

/// `C = σ_s · p(ω_V·(−r̂)) · T_P · I · η² · e^{−σ_t (t + d_V)} / D` for one path at camera
/// parameter `path.t`: the radiance toward the camera at V per unit length of the segment, from a
/// point light of intensity `intensity` (W/sr per channel) at `ends.light`, times the sample
/// weight `e^{ln_weight}` per channel (folded into the attenuation's exponent, so that a dense medium's tiny
/// attenuation and large weight never underflow or overflow apart). Includes η² and excludes
/// `T(V_min)` (see the module doc); visibility is the caller's.
#[inline]
pub fn path_contribution(
    path: &RefractionPath,
    ends: &PathEnds,
    medium: &Medium,
    intensity: Rgb,
    ln_weight: Rgb,
) -> Rgb {
    let phase = medium.phase.eval(-path.omega_v.dot(ends.dir));
    let attenuation = (ln_weight - (path.t + path.d_v) * medium.sigma_t).exp();
    let scalar = phase * path.fresnel_t * ends.eta * ends.eta / path.d_factor;
    medium.sigma_s * intensity * attenuation * scalar
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scatter::triangle::ends::DepthRange;
    use crate::scatter::triangle::ground_truth::gauss_legendre;
    use crate::scatter::triangle::patch::TrianglePatch;
    use crate::scatter::triangle::solve::{NewtonSettings, solve_at, straight_line_guess};
    use glam::DVec3;

    /// The physics.md §1.5 end-to-end flat-plane integral: segment (0.3, −0.2, −0.05) →
    /// (0.1, 0.1, −3.0), light (1.7, 0.9, 1.3), η = 1.5, σ_s = 0.5, σ_t = 0.7, HG g = 0.3, I = 1,
    /// plane z = 0. The note's integral is the end-to-end formula without η², so we divide our
    /// contribution (which carries η², see the module doc) by η². Ground truth 6.6755876e-4
    /// (Richardson 6.67558756e-4); our 8 panels × 32-point Gauss–Legendre must match to 1e-7
    /// relative, and the n = 8000 midpoint rule to 1e-9 of the note's 6.675587476e-4.
    #[test]
    fn flat_plane_segment_integral() {
        let patch = TrianglePatch::new(
            [
                DVec3::new(-50.0, -50.0, 0.0),
                DVec3::new(100.0, -50.0, 0.0),
                DVec3::new(-50.0, 100.0, 0.0),
            ],
            [DVec3::Z; 3],
        )
        .unwrap();
        let (ends, length, medium) =
            crate::scatter::triangle::ground_truth::flat_plane_integral_setup();
        let settings = NewtonSettings::new(1e-14, DepthRange::new(0.0, length));
        let integrand = |t: f64| {
            let guess = straight_line_guess(&patch, &ends, t).unwrap();
            let path = solve_at(&patch, &ends, t, guess, &settings)
                .0
                .expect("flat path exists");
            path_contribution(&path, &ends, &medium, DVec3::ONE, DVec3::ZERO).x
                / (ends.eta * ends.eta)
        };
        let rule = gauss_legendre(32);
        let panels = 8;
        let width = length / panels as f64;
        let mut total = 0.0;
        for k in 0..panels {
            let mid = (k as f64 + 0.5) * width;
            total += rule
                .iter()
                .map(|(x, w)| w * 0.5 * width * integrand(mid + 0.5 * width * x))
                .sum::<f64>();
        }
        println!("flat-plane integral (GL 8x32) = {total:.12e}");
        assert!(
            (total / 6.6755876e-4 - 1.0).abs() < 1e-7,
            "integral {total:e}"
        );

        let n = 8000;
        let h = length / n as f64;
        let midpoint: f64 = (0..n).map(|i| integrand((i as f64 + 0.5) * h)).sum::<f64>() * h;
        println!("flat-plane integral (midpoint 8000) = {midpoint:.12e}");
        assert!(
            (midpoint / 6.675587476e-4 - 1.0).abs() < 1e-9,
            "midpoint {midpoint:e}"
        );
    }
}
