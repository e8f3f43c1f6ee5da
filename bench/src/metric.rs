//! The error and fitting arithmetic of the benchmarks, kept apart so it can be checked by hand.
//!
//! Relative RMSE is the error measure of the speed–accuracy study: the root-mean-square
//! difference of an image from the reference, divided by the root-mean-square of the reference,
//! over every pixel and channel (‖x − r‖₂ / ‖r‖₂). It is scale-free, so scenes of different
//! brightness compare, and it does not blow up on the black pixels around an object the way a
//! per-pixel relative error would.

/// `‖x − r‖₂ / ‖r‖₂` over all values; `None` when the lengths differ or the reference is black
/// (no scale to be relative to).
pub fn relative_rmse(image: &[f32], reference: &[f32]) -> Option<f64> {
    if image.len() != reference.len() || reference.is_empty() {
        return None;
    }
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (&x, &r) in image.iter().zip(reference) {
        let d = x as f64 - r as f64;
        diff += d * d;
        norm += r as f64 * r as f64;
    }
    if norm == 0.0 || !norm.is_finite() || !diff.is_finite() {
        return None;
    }
    Some((diff / norm).sqrt())
}

/// Least-squares line through `(ln x, ln y)`: returns `(slope, intercept)`, so
/// `y ≈ exp(intercept) · x^slope`. `None` with fewer than two distinct positive x.
pub fn loglog_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    linear_fit(&logs)
}

/// Least-squares line `y ≈ intercept + slope · x`: returns `(slope, intercept)`; `None` with
/// fewer than two distinct x.
pub fn linear_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some((slope, mean_y - slope * mean_x))
}

/// The time a method needs to reach `target` error, read off its `(time, error)` curve: the
/// cheapest measured point at or below the target, refined by log-log interpolation with the
/// next cheaper point above it. Beyond the measured range the last two points are extrapolated
/// and the answer is flagged. `None` when the curve has no usable points or never decreases
/// toward the target.
pub fn time_to_reach(curve: &[(f64, f64)], target: f64) -> Option<Reached> {
    let mut points: Vec<(f64, f64)> = curve
        .iter()
        .copied()
        .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    if points.is_empty() || target <= 0.0 {
        return None;
    }
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The Pareto front: each point must be more accurate than every cheaper one.
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    let interpolate = |a: (f64, f64), b: (f64, f64)| -> Option<f64> {
        let (la, lb) = ((a.1).ln(), (b.1).ln());
        if la == lb {
            return None;
        }
        let s = (target.ln() - la) / (lb - la);
        Some((a.0.ln() + s * (b.0.ln() - a.0.ln())).exp())
    };
    if let Some(i) = front.iter().position(|p| p.1 <= target) {
        if i == 0 {
            return Some(Reached {
                time: front[0].0,
                extrapolated: false,
            });
        }
        return interpolate(front[i - 1], front[i]).map(|time| Reached {
            time,
            extrapolated: false,
        });
    }
    let n = front.len();
    if n < 2 {
        return None;
    }
    interpolate(front[n - 2], front[n - 1]).map(|time| Reached {
        time,
        extrapolated: true,
    })
}

/// A time read off a curve by [`time_to_reach`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reached {
    pub time: f64,
    /// The target lies beyond the measured points (the curve was extended).
    pub extrapolated: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_rmse_matches_hand_computed_values() {
        // x − r = (1, −1, 0, 2): Σd² = 6; Σr² = 1 + 4 + 9 + 16 = 30; √(6/30) = √0.2.
        let r = [1.0, 2.0, 3.0, 4.0];
        let x = [2.0, 1.0, 3.0, 6.0];
        let e = relative_rmse(&x, &r).unwrap();
        assert!((e - 0.2f64.sqrt()).abs() < 1e-12, "{e}");
        // Identical images have no error; a black image is 100 % off.
        assert_eq!(relative_rmse(&r, &r), Some(0.0));
        assert_eq!(relative_rmse(&[0.0; 4], &r), Some(1.0));
        // Scaling both images leaves the relative error unchanged.
        let (x2, r2): (Vec<f32>, Vec<f32>) =
            x.iter().zip(&r).map(|(a, b)| (a * 8.0, b * 8.0)).unzip();
        assert!((relative_rmse(&x2, &r2).unwrap() - e).abs() < 1e-12);
    }

    #[test]
    fn relative_rmse_refuses_what_has_no_answer() {
        assert_eq!(relative_rmse(&[1.0], &[1.0, 2.0]), None);
        assert_eq!(relative_rmse(&[1.0, 2.0], &[0.0, 0.0]), None);
        assert_eq!(relative_rmse(&[], &[]), None);
        assert_eq!(relative_rmse(&[f32::NAN], &[1.0]), None);
    }

    #[test]
    fn loglog_fit_recovers_a_power_law() {
        // y = 3 · x^0.75 exactly.
        let points: Vec<(f64, f64)> = [1e3, 1e4, 1e5, 1e6]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(0.75)))
            .collect();
        let (slope, intercept) = loglog_fit(&points).unwrap();
        assert!((slope - 0.75).abs() < 1e-12, "{slope}");
        assert!((intercept - 3.0f64.ln()).abs() < 1e-9, "{intercept}");
        assert_eq!(loglog_fit(&[(1.0, 1.0)]), None);
        assert_eq!(linear_fit(&[(2.0, 1.0), (2.0, 5.0)]), None);
    }

    #[test]
    fn linear_fit_matches_hand_computed_values() {
        // Points (0,1), (1,3), (2,4): x̄ = 1, ȳ = 8/3, Sxx = 2, Sxy = (−1)(−5/3) + 0 + (1)(4/3) = 3.
        let (slope, intercept) = linear_fit(&[(0.0, 1.0), (1.0, 3.0), (2.0, 4.0)]).unwrap();
        assert!((slope - 1.5).abs() < 1e-12);
        assert!((intercept - (8.0 / 3.0 - 1.5)).abs() < 1e-12);
    }

    #[test]
    fn time_to_reach_interpolates_on_the_front() {
        // error ∝ 1/time between (1 s, 0.1) and (100 s, 0.001): reaching 0.01 takes 10 s.
        let curve = [(100.0, 0.001), (1.0, 0.1), (5.0, 0.5)];
        let r = time_to_reach(&curve, 0.01).unwrap();
        assert!((r.time - 10.0).abs() < 1e-9, "{r:?}");
        assert!(!r.extrapolated);
        // Already met by the cheapest point.
        assert_eq!(time_to_reach(&curve, 0.2).unwrap().time, 1.0);
        // Beyond the last point: extended along the last segment, and flagged.
        let r = time_to_reach(&curve, 0.0001).unwrap();
        assert!((r.time - 1000.0).abs() < 1e-6, "{r:?}");
        assert!(r.extrapolated);
        assert_eq!(time_to_reach(&[(1.0, 0.1)], 0.01), None);
        assert_eq!(time_to_reach(&[], 0.01), None);
    }
}
