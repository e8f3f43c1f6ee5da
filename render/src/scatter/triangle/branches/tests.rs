//! Tests of the per-triangle intervals against ground truth: the §1.5 flat integral, exact
//! flat refraction points, and brute-force solutions on curved and folding triangles.

use glam::DVec3;
use spindle_common::stats::RenderStats;

use super::*;
use crate::Rgb;
use crate::medium::{Medium, PhaseFunction};
use crate::scatter::triangle::contribution::path_contribution;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scatter::triangle::ground_truth::{
    SplitMix, flat_plane_integral_setup, flat_refraction_point,
};
use crate::scatter::triangle::patch::TrianglePatch;
use crate::scatter::triangle::solve::RefractionPath;
use crate::scatter::triangle::solve::solve_all_at;

/// The interval's contribution `(t_max − t_min)/K · Σ_i C(t_i)` ([H15] eq. 19) per RGB
/// channel with K midpoint samples, every sample visible, for a point light of unit
/// intensity; C from [`path_contribution`] (η² included, `T(V_min)` excluded).
fn interval_contribution(
    patch: &TrianglePatch,
    ends: &PathEnds,
    interval: &Interval,
    k: u32,
    medium: &Medium,
    tolerance: f64,
    stats: &mut RenderStats,
) -> Rgb {
    let mut total = Rgb::ZERO;
    let rule = SampleRule::midpoint(k);
    for_each_sample(
        patch,
        ends,
        interval,
        &rule,
        tolerance,
        stats,
        |path, ln_weight| {
            total += path_contribution(path, ends, medium, DVec3::ONE, ln_weight);
        },
    );
    total
}

/// Sums the contributions of every interval with K midpoint samples, divided by η² to compare
/// with the end-to-end formula of physics.md §1.5 (see `contribution`).
fn integrate(
    patch: &TrianglePatch,
    ends: &PathEnds,
    length: f64,
    medium: &Medium,
    k: u32,
) -> (f64, RenderStats) {
    let mut stats = RenderStats::default();
    let intervals =
        triangle_intervals(patch, ends, DepthRange::new(0.0, length), 1e-13, &mut stats);
    let mut total = 0.0;
    for interval in intervals.iter() {
        let rgb = interval_contribution(patch, ends, interval, k, medium, 1e-13, &mut stats);
        total += rgb.x / (ends.eta * ends.eta);
    }
    (total, stats)
}

/// Test (10), second half: a large flat triangle covering the plane gives one interval over
/// the whole segment, and its K-sample midpoint sums converge to the §1.5 integral
/// 6.6755876e-4 with the midpoint rule's O(K⁻²) error: error ratio ≈ 4 per doubling of K from
/// K = 8, 3e-6 relative at K = 512, and Richardson extrapolation of K = 256, 512 within 1e-7.
#[test]
fn flat_interval_integral_converges() {
    let patch = TrianglePatch::new(
        [
            DVec3::new(-50.0, -50.0, 0.0),
            DVec3::new(100.0, -50.0, 0.0),
            DVec3::new(-50.0, 100.0, 0.0),
        ],
        [DVec3::Z; 3],
    )
    .unwrap();
    let (ends, length, medium) = flat_plane_integral_setup();
    let truth = 6.6755876e-4;
    let mut previous_error = f64::INFINITY;
    let mut previous_value = 0.0;
    for k in [1, 2, 4, 8, 16, 32, 64, 128, 256, 512] {
        let (value, stats) = integrate(&patch, &ends, length, &medium, k);
        assert_eq!(stats.intervals, 1);
        let error = (value / truth - 1.0).abs();
        println!("K = {k}: {value:.10e} (rel. error {error:.2e})");
        if (8..=128).contains(&k) {
            let ratio = previous_error / error;
            assert!(ratio > 3.5 && ratio < 4.5, "K={k}: error ratio {ratio}");
        }
        if k == 256 {
            previous_value = value;
        }
        if k == 512 {
            assert!(error < 4e-6, "K=512 error {error}");
            let richardson = (4.0 * value - previous_value) / 3.0;
            let extrapolated = (richardson / truth - 1.0).abs();
            println!("Richardson (256, 512): {richardson:.10e} (rel. error {extrapolated:.2e})");
            assert!(extrapolated < 1e-7, "Richardson error {extrapolated}");
        }
        previous_error = error;
    }
}

/// On small flat triangles the intervals are exactly the set of t whose exact refraction
/// point (physics.md §5) lies inside the triangle: checked on a grid of 400 t per segment,
/// for 30 seeded segments and triangles, away from the ends by the grid spacing.
#[test]
fn flat_intervals_match_exact_refraction_points() {
    let mut rng = SplitMix(21);
    let mut nonempty = 0;
    let mut work = 0;
    for case in 0..30 {
        let p = [
            DVec3::new(rng.range(-1.0, 0.0), rng.range(-1.0, 0.0), 0.0),
            DVec3::new(rng.range(0.2, 1.0), rng.range(-1.0, 0.0), 0.0),
            DVec3::new(rng.range(-0.5, 0.5), rng.range(0.2, 1.0), 0.0),
        ];
        let patch = TrianglePatch::new(p, [DVec3::Z; 3]).unwrap();
        let origin = DVec3::new(
            rng.range(-1.5, 1.5),
            rng.range(-1.5, 1.5),
            rng.range(-1.5, -0.1),
        );
        let target = DVec3::new(
            rng.range(-1.5, 1.5),
            rng.range(-1.5, 1.5),
            rng.range(-1.5, -0.1),
        );
        let length = (target - origin).length();
        let ends = PathEnds {
            origin,
            dir: (target - origin) / length,
            light: DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(0.3, 2.0),
            ),
            eta: rng.range(1.2, 2.0),
        };
        let mut stats = RenderStats::default();
        let intervals = triangle_intervals(
            &patch,
            &ends,
            DepthRange::new(0.0, length),
            1e-13,
            &mut stats,
        );
        work += stats.newton_iterations;
        assert_eq!(stats.folds, 0, "flat triangles have no folds");
        if !intervals.is_empty() {
            nonempty += 1;
        }
        let n = 400;
        for i in 0..n {
            let t = (i as f64 + 0.5) * length / n as f64;
            let v = ends.camera_point(t);
            let exact = flat_refraction_point(DVec3::ZERO, DVec3::Z, v, ends.light, ends.eta);
            let (a, b) = patch.barycentric(exact);
            let inside = patch.contains(a, b, 0.0);
            let covered = intervals
                .iter()
                .filter(|iv| t >= iv.t_min && t <= iv.t_max)
                .count();
            let near_end = intervals.iter().any(|iv| {
                (t - iv.t_min).abs() < length / n as f64 || (t - iv.t_max).abs() < length / n as f64
            });
            if !near_end {
                assert_eq!(
                    covered, inside as usize,
                    "case {case}, t = {t}: covered {covered}, inside {inside}; {intervals:?}"
                );
            }
        }
    }
    println!(
        "{nonempty} of 30 flat cases had an interval; f evaluations per triangle search: {:.0}",
        work as f64 / 30.0
    );
    assert!(nonempty >= 8);
}

/// Every valid refraction point inside the triangle at t, by brute force: Newton from 136
/// starts over the triangle ([`solve_all_at`] with 16 per side).
fn all_solutions(patch: &TrianglePatch, ends: &PathEnds, t: f64) -> Vec<RefractionPath> {
    let mut stats = RenderStats::default();
    solve_all_at::<16>(patch, ends, t, 16, 1e-13, &mut stats)
        .iter()
        .copied()
        .collect()
}

/// A strongly focusing triangle: vertex normals tilted like those of a convex lens of
/// curvature κ, `n ∝ (κx, κy, 1)`, in the plane z = 0.
fn lens(kappa: f64) -> TrianglePatch {
    let p = [
        DVec3::new(-1.5, -1.0, 0.0),
        DVec3::new(1.5, -1.0, 0.0),
        DVec3::new(0.0, 1.6, 0.0),
    ];
    let n = p.map(|q| DVec3::new(kappa * q.x, kappa * q.y, 1.0).normalize());
    TrianglePatch::new(p, n).unwrap()
}

/// Folds: a camera segment beyond the focus of a strongly focusing triangle crosses the volume
/// caustic, where the curve turns back in t inside the triangle. Two configurations: κ = 2.5
/// (arcs bounded by edges, one fold) and κ = 2 (arcs bounded where the light grazes the shading
/// normal, touching no edge, two folds). Checked against brute force (all solutions from 136
/// Newton starts): on 600 t of the segment the number of intervals covering t equals the number
/// of solutions (away from interval ends by the grid spacing), and the integral of the
/// contribution over the intervals (K = 4000 midpoint) matches the brute-force integral
/// (midpoint over 3000 t, summing every solution) to 1 % (both converge slowly at the
/// integrable 1/√ spikes of the caustic).
#[test]
fn folds_are_split_and_every_branch_is_integrated() {
    let medium = Medium {
        sigma_s: DVec3::splat(0.5),
        sigma_t: DVec3::splat(0.2),
        phase: PhaseFunction::Isotropic,
    };
    for (kappa, depth, min_folds) in [(2.5, -3.0, 1), (2.0, -3.0, 2)] {
        let patch = lens(kappa);
        let length = 3.0;
        let ends = PathEnds {
            origin: DVec3::new(-1.5, 0.05, depth),
            dir: DVec3::X,
            light: DVec3::new(0.1, 0.0, 4.0),
            eta: 1.5,
        };
        let mut stats = RenderStats::default();
        let intervals = triangle_intervals(
            &patch,
            &ends,
            DepthRange::new(0.0, length),
            1e-13,
            &mut stats,
        );
        println!(
            "κ = {kappa}: {} intervals, {} folds",
            intervals.len(),
            stats.folds
        );
        for iv in intervals.iter() {
            println!(
                "  [{:.6}, {:.6}] branch {:?}",
                iv.t_min, iv.t_max, iv.branch
            );
        }
        assert!(
            stats.folds >= min_folds,
            "κ = {kappa}: {} folds",
            stats.folds
        );

        // At every t of a uniform grid, the interval method's solutions (one fixed-t solve
        // per covering interval, from its seed) equal the brute force's: same count, same
        // summed contribution.
        let n = 600;
        let h = length / n as f64;
        let (mut by_intervals, mut by_brute, mut mismatches) = (0.0, 0.0, 0);
        for i in 0..n {
            let t = (i as f64 + 0.5) * h;
            let (mut count, mut sum) = (0, 0.0);
            for iv in intervals.iter().filter(|iv| t >= iv.t_min && t <= iv.t_max) {
                let rule = SampleRule {
                    k: 1,
                    offset: |_| (t - iv.t_min) / (iv.t_max - iv.t_min),
                    sigma_t: DVec3::ZERO,
                };
                for_each_sample(&patch, &ends, iv, &rule, 1e-13, &mut stats, |path, _| {
                    count += 1;
                    sum += path_contribution(path, &ends, &medium, DVec3::ONE, DVec3::ZERO).x;
                });
            }
            let brute = all_solutions(&patch, &ends, t);
            let brute_sum: f64 = brute
                .iter()
                .map(|p| path_contribution(p, &ends, &medium, DVec3::ONE, DVec3::ZERO).x)
                .sum();
            if count != brute.len() {
                mismatches += 1;
                println!(
                    "  t = {t:.4}: intervals {count} ({sum:e}), brute force {} ({brute_sum:e})",
                    brute.len()
                );
            }
            by_intervals += h * sum;
            by_brute += h * brute_sum;
        }
        println!(
            "κ = {kappa}: on the grid, intervals {by_intervals:.10e}, brute force {by_brute:.10e}, {mismatches} mismatches"
        );
        assert_eq!(mismatches, 0, "κ = {kappa}");
        assert!((by_intervals / by_brute - 1.0).abs() < 1e-9);

        // The fold-resolved integral, for the record.
        let mut fine = 0.0;
        for iv in intervals.iter() {
            let rule = SampleRule::midpoint(4000);
            for_each_sample(
                &patch,
                &ends,
                iv,
                &rule,
                1e-13,
                &mut stats,
                |path, ln_weight| {
                    fine += path_contribution(path, &ends, &medium, DVec3::ONE, ln_weight).x;
                },
            );
        }
        println!(
            "κ = {kappa}: intervals with K = 4000: {fine:.8e}; Newton failures in all sampling {}",
            stats.newton_failures
        );
        assert_eq!(stats.newton_failures, 0, "κ = {kappa}");
    }
}

/// At the midpoints of `n` equal steps of `[0, length]` farther than `margin` from every
/// interval end, the number of intervals covering t equals the number of solutions found by
/// brute force. Returns how many t were checked and how many of them have a solution.
fn assert_intervals_cover_solutions(
    patch: &TrianglePatch,
    ends: &PathEnds,
    intervals: &Intervals,
    length: f64,
    n: usize,
    margin: f64,
    what: &str,
) -> (usize, usize) {
    let h = length / n as f64;
    let (mut checked, mut with_solutions) = (0, 0);
    for i in 0..n {
        let t = (i as f64 + 0.5) * h;
        let near_end = intervals
            .iter()
            .any(|iv| (t - iv.t_min).abs() < margin || (t - iv.t_max).abs() < margin);
        if near_end {
            continue;
        }
        let covering = intervals
            .iter()
            .filter(|iv| t >= iv.t_min && t <= iv.t_max)
            .count();
        let brute = all_solutions(patch, ends, t).len();
        assert_eq!(covering, brute, "{what}, t = {t}: {intervals:?}");
        checked += 1;
        with_solutions += usize::from(brute > 0);
    }
    (checked, with_solutions)
}

/// A long arc: on a small triangle of the bumpy-sphere example (size 0.07) the camera segment
/// runs nearly along the refracted light, so the curve spans t ∈ [0, 1.01], 14 triangle sizes,
/// and tracing it takes about 95 steps, about as many as the 96 points an arc holds: the arc
/// is thinned, not cut short. Checked against brute force (all
/// solutions from 136 Newton starts) on 400 t: the number of intervals covering t equals the
/// number of solutions away from interval ends, and nothing is dropped.
#[test]
fn long_arcs_are_traced_whole() {
    let p0 = DVec3::new(-0.3726392827737513, 1.0574013139550191, -0.962220619514952);
    let e1 = DVec3::new(
        0.0008103100026836674,
        -0.07184916867728341,
        0.00117317524282734,
    );
    let e2 = DVec3::new(
        -0.06901367212571258,
        -0.029830365423866967,
        0.015092801269555811,
    );
    let n0 = DVec3::new(
        -0.15636525681524466,
        0.024853068527526116,
        -0.987386566368952,
    );
    let dn1 = DVec3::new(
        -0.012146921015825013,
        -0.08486633549459792,
        0.003515612579498395,
    );
    let dn2 = DVec3::new(
        -0.12459703291182006,
        -0.04782785920073724,
        0.0279427948300216,
    );
    let patch = TrianglePatch::new([p0, p0 + e1, p0 + e2], [n0, n0 + dn1, n0 + dn2]).unwrap();
    let ends = PathEnds {
        origin: DVec3::new(
            -0.40060511745610083,
            1.0140384222579477,
            -0.9555193279969362,
        ),
        dir: DVec3::new(0.4772277786308559, -0.07663035475610763, 0.8754321424490944),
        light: DVec3::new(-2.258081222990139, 1.4585953021607494, -3.408587427081157),
        eta: 1.4,
    };
    let length = 1.9926609981151144;
    let mut stats = RenderStats::default();
    let intervals = triangle_intervals(
        &patch,
        &ends,
        DepthRange::new(0.0, length),
        1e-10,
        &mut stats,
    );
    for iv in intervals.iter() {
        println!(
            "  [{:.6}, {:.6}] branch {:?}",
            iv.t_min, iv.t_max, iv.branch
        );
    }
    assert_eq!(stats.capacity_drops, 0);
    let covered: f64 = intervals.iter().map(|iv| iv.t_max - iv.t_min).sum();
    assert!(covered > 1.0, "covered {covered}");
    let n = 400;
    let h = length / n as f64;
    let (_, with_solutions) =
        assert_intervals_cover_solutions(&patch, &ends, &intervals, length, n, h, "long arc");
    println!("{with_solutions} of {n} t have a solution; covered {covered:.6}");
}

/// Long continuation steps lose and duplicate nothing: on 60 seeded curved triangles (vertex
/// normals tilted up to ±0.6), half of them with the camera segment running close to the
/// light's direction through the triangle (long arcs in t, taken in steps beyond
/// `STEP_MAX`), the number of intervals covering t equals the number of solutions found by
/// brute force (136 Newton starts) at 40 t of each segment away from interval ends.
#[test]
fn intervals_cover_every_solution_on_curved_triangles() {
    let mut rng = SplitMix(71);
    let (mut checked, mut with_solutions, mut searched) = (0, 0, 0);
    for case in 0..60 {
        let n = [0, 1, 2]
            .map(|_| DVec3::new(rng.range(-0.6, 0.6), rng.range(-0.6, 0.6), 1.0).normalize());
        let p = [
            DVec3::new(-0.6, -0.5, 0.0),
            DVec3::new(0.7, -0.4, 0.05),
            DVec3::new(-0.2, 0.6, -0.03),
        ];
        let patch = TrianglePatch::new(p, n).unwrap();
        let light = DVec3::new(
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
            rng.range(0.3, 3.0),
        );
        let centre = (p[0] + p[1] + p[2]) / 3.0;
        let (origin, target) = if case % 2 == 0 {
            let along = (centre - light).normalize();
            let jitter = DVec3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), 0.0);
            (
                centre + 0.01 * along + jitter,
                centre + 3.0 * along + jitter,
            )
        } else {
            let mut point = || {
                DVec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.5, -0.2),
                )
            };
            (point(), point())
        };
        let length = (target - origin).length();
        let ends = PathEnds {
            origin,
            dir: (target - origin) / length,
            light,
            eta: 1.5,
        };
        let mut stats = RenderStats::default();
        let intervals = triangle_intervals(
            &patch,
            &ends,
            DepthRange::new(0.0, length),
            1e-10,
            &mut stats,
        );
        assert_eq!(stats.capacity_drops, 0, "case {case}");
        let steps = stats.newton_iterations;
        searched += u64::from(steps > 0);
        let m = 40;
        let margin = 1e-3 * length / m as f64;
        let what = format!("case {case}");
        let (n, solved) =
            assert_intervals_cover_solutions(&patch, &ends, &intervals, length, m, margin, &what);
        checked += n;
        with_solutions += solved;
    }
    println!("{checked} t checked, {with_solutions} with solutions ({searched} cases searched)");
    assert!(with_solutions > 300, "{with_solutions}");
}

/// Extremes: η from 1 + 1e-6 to 4, scenes scaled by 1e-4 and 1e4, on 40 seeded curved
/// configurations each: no panic, every interval and sampled contribution finite and ≥ 0, and
/// at every η, 1 + 1e-6 included, the intervals scale with the scene (t bounds × s to 1e-6
/// relative).
#[test]
fn extremes_are_finite_and_scale_with_the_scene() {
    let medium = Medium {
        sigma_s: DVec3::splat(0.5),
        sigma_t: DVec3::splat(0.0),
        phase: PhaseFunction::Isotropic,
    };
    let mut rng = SplitMix(33);
    let mut nonempty = 0;
    for eta in [1.0 + 1e-6, 1.001, 1.33, 1.5, 2.42, 4.0] {
        for _ in 0..40 {
            let n = [0, 1, 2]
                .map(|_| DVec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), 1.0).normalize());
            let p = [
                DVec3::new(-0.6, -0.5, 0.0),
                DVec3::new(0.7, -0.4, 0.05),
                DVec3::new(-0.2, 0.6, -0.03),
            ];
            let origin = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.5, -0.2),
            );
            let target = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.5, -0.2),
            );
            let light = DVec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(0.01, 3.0),
            );
            let mut reference: Option<Vec<(f64, f64)>> = None;
            for scale in [1.0, 1e-4, 1e4] {
                let patch = TrianglePatch::new(p.map(|q| q * scale), n).unwrap();
                let length = (target - origin).length() * scale;
                let ends = PathEnds {
                    origin: origin * scale,
                    dir: (target - origin).normalize(),
                    light: light * scale,
                    eta,
                };
                let mut stats = RenderStats::default();
                let intervals = triangle_intervals(
                    &patch,
                    &ends,
                    DepthRange::new(0.0, length),
                    1e-12,
                    &mut stats,
                );
                let mut bounds = Vec::new();
                for iv in intervals.iter() {
                    assert!(iv.t_min.is_finite() && iv.t_max.is_finite() && iv.t_min < iv.t_max);
                    bounds.push((iv.t_min / scale, iv.t_max / scale));
                    let c = interval_contribution(&patch, &ends, iv, 3, &medium, 1e-12, &mut stats);
                    assert!(
                        c.is_finite() && c.min_element() >= 0.0,
                        "η {eta}, scale {scale}: {c}"
                    );
                }
                bounds.sort_by(|x, y| x.partial_cmp(y).unwrap());
                match &reference {
                    None => {
                        nonempty += (!bounds.is_empty()) as usize;
                        reference = Some(bounds);
                    }
                    Some(r) => {
                        assert_eq!(
                            r.len(),
                            bounds.len(),
                            "η {eta}, scale {scale}: {r:?} vs {bounds:?}"
                        );
                        for (x, y) in r.iter().zip(&bounds) {
                            let tol = 1e-6 * (1.0 + x.1.abs());
                            assert!(
                                (x.0 - y.0).abs() < tol && (x.1 - y.1).abs() < tol,
                                "η {eta}, scale {scale}: {r:?} vs {bounds:?}"
                            );
                        }
                    }
                }
            }
        }
    }
    println!("{nonempty} of 240 configurations had intervals");
    assert!(nonempty >= 40);
}
