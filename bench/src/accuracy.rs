//! Study 1 and 2: speed against accuracy, and the equal-quality time ratio.
//!
//! Per scene, a converged reference image of the `single_scatter` layer, then sweeps of the
//! interval method (K samples per interval × Newton tolerance), point sampling (M samples per
//! segment) and the straight-line approximation, each timed and compared with the reference by
//! relative RMSE ([`metric::relative_rmse`]). The reference is the interval method at its
//! strictest settings (K = 32, tolerance 1e-12), checked against the brute-force `reference`
//! method on the centre pixels where that is affordable (it tries every triangle from 16 Newton
//! starts at 64 points per segment: a 20×20 film of a 1,280-triangle sphere took over 6 minutes).
//!
//! From the curves: the time point sampling needs to reach the interval method's K = 1 error
//! (the paper reports ≈ 18×), and the target, interval K = 1 reaching point sampling's
//! M = 512 error at least 30× faster.

use anyhow::Result;
use spindle_common::scene::{ScatterMethod, SingleScatter};
use spindle_common::tile::TileRect;

use crate::BenchArgs;
use crate::metric::{Reached, relative_rmse, time_to_reach};
use crate::plot::{self, Labels, Mark, Series};
use crate::report::{Report, Table, keep_scene, secs, sig};
use crate::runner::{Runner, full_frame};
use crate::scenes::{Model, SHARED_MESHES, build, film, settings, shared_meshes};

/// The Newton tolerance the renderer uses by default (the "K = 1" point of the paper).
const DEFAULT_TOLERANCE: f64 = 1e-10;
/// Strictest interval settings, the stand-in reference.
const STRICT_K: u32 = 32;
const STRICT_TOLERANCE: f64 = 1e-12;
/// The brute-force reference is rendered only up to this many triangles (it tests them all, from
/// 16 Newton starts each, at 64 points per segment: 4x4 pixels of a 5,120-triangle bumpy sphere
/// take minutes) ...
const BRUTE_FORCE_LIMIT: usize = 2_000;
/// ... and only on the centre `BRUTE_FORCE_CROP²` pixels, where it checks the strict interval
/// image; the sweeps are measured against the strict interval image over the whole film.
const BRUTE_FORCE_CROP: u32 = 4;

/// One point of a sweep.
struct Measured {
    /// `interval K=1`, `point sampling`, ...: the curve it belongs to.
    curve: String,
    /// The swept value (tolerance, M), as printed.
    setting: String,
    seconds: f64,
    error: Option<f64>,
}

struct Plan {
    ks: Vec<u32>,
    tolerances: Vec<f64>,
    samples: Vec<u32>,
    size: u32,
}

fn plan(quick: bool) -> Plan {
    if quick {
        Plan {
            ks: vec![1, 4],
            tolerances: vec![1e-3, 1e-6, DEFAULT_TOLERANCE],
            samples: vec![4, 16, 64, 256, 512],
            size: 20,
        }
    } else {
        // The whole grid, on the quick plan's film and scenes: at 40x40 pixels, best of
        // two, it was estimated at over two hours, mostly point sampling at M = 512 and 1024.
        Plan {
            ks: vec![1, 2, 4, 8],
            tolerances: vec![1e-3, 1e-4, 1e-6, 1e-8, DEFAULT_TOLERANCE, 1e-12],
            samples: vec![4, 8, 16, 32, 64, 128, 256, 512, 1024],
            size: 20,
        }
    }
}

/// Runs studies 1 and 2 over the benchmark scenes.
pub fn run(report: &mut Report, runner: &Runner, args: &BenchArgs) -> Result<()> {
    let plan = plan(args.quick);
    report.line("");
    report.line("== 1. speed vs accuracy (single_scatter layer), 2. equal quality ==");
    // The same procedural scenes in both plans: the sphere stays under the brute-force check's
    // triangle limit.
    // Dense media too (σ_t × 100 and × 10,000): the interval samples follow the attenuation.
    let mut models = vec![
        Model::sphere(3),
        Model::sphere(3).dense(100.0),
        Model::sphere(3).dense(10_000.0),
        Model::bumpy(4),
    ];
    // The shared meshes in both plans (in the quick one, about a minute per mesh at 20x20
    // pixels, most of it point sampling at M = 512).
    let (found, skipped) = shared_meshes(&args.meshes, &SHARED_MESHES);
    for reason in skipped {
        report.line(reason);
    }
    models.extend(found);
    report.line(format!(
        "setup: {}x{} film, 1 spp, point light, eta 1.5, sigma_t (0.5, 1, 2) (x 100 and x 10000 for the dense scenes), albedo 0.9; \
         interval K {:?} x tolerance {:?}; point sampling M {:?}; straight line; \
         reference: interval K={STRICT_K} tol {STRICT_TOLERANCE:e}, checked against brute force on the centre pixels (<= {BRUTE_FORCE_LIMIT} triangles)",
        plan.size, plan.size, plan.ks, plan.tolerances, plan.samples
    ));
    let mut equal = Table::new(&[
        "scene",
        "triangles",
        "interval_k1_error",
        "interval_k1_s",
        "ps_time_to_k1_error_s",
        "ps_over_interval_k1",
        "ps_m512_error",
        "ps_m512_s",
        "interval_time_to_m512_error_s",
        "ps_m512_over_interval",
        "target_30x_met",
    ]);
    for model in &models {
        scene_study(report, runner, &plan, model, &mut equal)?;
    }
    report.line("");
    report.line("equal quality (times are total render times of the same film, one thread; ~ = extrapolated):");
    report.table("equal_quality", &equal)?;
    Ok(())
}

fn scene_study(
    report: &mut Report,
    runner: &Runner,
    plan: &Plan,
    model: &Model,
    equal: &mut Table,
) -> Result<()> {
    let film = film(plan.size, 1);
    let render = |single: SingleScatter| -> Result<(f64, Vec<f32>)> {
        let scene = build(model, film.clone(), single)?;
        let timed = runner.render(&scene, full_frame(&scene));
        Ok((timed.seconds, timed.pixels.single_scatter))
    };
    report.line("");
    report.line(format!("-- {} ({} triangles)", model.name, model.triangles));
    keep_scene(
        report,
        &format!("accuracy-{}.json", model.name),
        &model.scene(film.clone(), settings(ScatterMethod::Interval)),
    )?;

    // The references.
    let strict = SingleScatter {
        method: ScatterMethod::Interval,
        k: STRICT_K,
        newton_tolerance: STRICT_TOLERANCE,
        ..SingleScatter::default()
    };
    let (strict_s, strict_image) = render(strict)?;
    let (baseline_s, _) = render(settings(ScatterMethod::None))?;
    report.line(format!(
        "strict interval (K={STRICT_K}, tol {STRICT_TOLERANCE:e}) {} s; no single scattering {} s",
        secs(strict_s),
        secs(baseline_s)
    ));
    if model.triangles <= BRUTE_FORCE_LIMIT {
        let offset = (plan.size - BRUTE_FORCE_CROP) / 2;
        let crop = TileRect {
            x: offset,
            y: offset,
            width: BRUTE_FORCE_CROP,
            height: BRUTE_FORCE_CROP,
        };
        let scene = build(model, film.clone(), settings(ScatterMethod::Reference))?;
        let brute = runner.render(&scene, crop);
        let strict_crop = crop_of(&strict_image, plan.size, crop);
        report.line(format!(
            "brute-force reference (centre {BRUTE_FORCE_CROP}x{BRUTE_FORCE_CROP} pixels) {} s; \
             strict interval vs brute force there: relative RMSE {}",
            secs(brute.seconds),
            relative_rmse(&strict_crop, &brute.pixels.single_scatter)
                .map_or("n/a (black reference)".into(), sig)
        ));
    } else {
        report.line(format!(
            "brute-force check skipped above {BRUTE_FORCE_LIMIT} triangles"
        ));
    }
    // The sweeps.
    let mut points: Vec<Measured> = Vec::new();
    let mut measure = |curve: String, setting: String, single: SingleScatter| -> Result<()> {
        let (seconds, image) = render(single)?;
        points.push(Measured {
            curve,
            setting,
            seconds,
            error: relative_rmse(&image, &strict_image),
        });
        Ok(())
    };
    for &k in &plan.ks {
        for &tolerance in &plan.tolerances {
            let single = SingleScatter {
                method: ScatterMethod::Interval,
                k,
                newton_tolerance: tolerance,
                ..SingleScatter::default()
            };
            measure(
                format!("interval K={k}"),
                format!("tol {tolerance:e}"),
                single,
            )?;
        }
    }
    for &m in &plan.samples {
        let single = SingleScatter {
            method: ScatterMethod::PointSampling,
            samples_per_segment: m,
            ..SingleScatter::default()
        };
        measure("point sampling".into(), format!("M {m}"), single)?;
    }
    measure(
        "straight line".into(),
        "-".into(),
        settings(ScatterMethod::StraightLine),
    )?;

    let mut table = Table::new(&["curve", "setting", "seconds", "net_seconds", "rel_rmse"]);
    for p in &points {
        table.push(vec![
            p.curve.clone(),
            p.setting.clone(),
            secs(p.seconds),
            secs(p.seconds - baseline_s),
            p.error.map_or("n/a".into(), sig),
        ]);
    }
    report.table(&format!("accuracy-{}", model.name), &table)?;

    // The Pareto plot: one curve per method.
    let mut curves: Vec<String> = Vec::new();
    for p in &points {
        if !curves.contains(&p.curve) {
            curves.push(p.curve.clone());
        }
    }
    let curve_points = |name: &str| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter(|p| p.curve == name)
            .filter_map(|p| p.error.map(|e| (p.seconds, e)))
            .collect()
    };
    let series: Vec<Series> = curves
        .iter()
        .map(|c| Series {
            name: c.clone(),
            points: curve_points(c),
            mark: if c == "straight line" {
                Mark::Points
            } else {
                Mark::Line
            },
        })
        .collect();
    let png = report.out().join(format!("accuracy-{}.png", model.name));
    plot::loglog(
        &png,
        &Labels {
            title: &format!(
                "{}: error vs time ({} triangles)",
                model.name, model.triangles
            ),
            x: "render time (s, one thread)",
            y: "relative RMSE of single_scatter",
        },
        &series,
    )?;
    report.line(format!("  -> {}", png.display()));

    // Equal quality.
    let find = |curve: &str, setting: &str| {
        points
            .iter()
            .find(|p| p.curve == curve && p.setting == setting)
            .and_then(|p| p.error.map(|e| (p.seconds, e)))
    };
    let k1 = find("interval K=1", &format!("tol {DEFAULT_TOLERANCE:e}"));
    let m512 = find("point sampling", "M 512");
    let ps_curve = curve_points("point sampling");
    let interval_front: Vec<(f64, f64)> = curves
        .iter()
        .filter(|c| c.starts_with("interval"))
        .flat_map(|c| curve_points(c))
        .collect();
    let show = |r: Option<Reached>| match r {
        Some(r) if r.extrapolated => format!("~{}", secs(r.time)),
        Some(r) => secs(r.time),
        None => "n/a".into(),
    };
    let ratio = |num: Option<f64>, den: Option<f64>| match (num, den) {
        (Some(n), Some(d)) if d > 0.0 => sig(n / d),
        _ => "n/a".into(),
    };
    let ps_to_k1 = k1.and_then(|(_, e)| time_to_reach(&ps_curve, e));
    let interval_to_m512 = m512.and_then(|(_, e)| time_to_reach(&interval_front, e));
    let target = match (m512, interval_to_m512) {
        (Some((t, _)), Some(r)) => {
            if t / r.time >= 30.0 {
                "yes"
            } else {
                "no"
            }
        }
        _ => "n/a",
    };
    equal.push(vec![
        model.name.clone(),
        model.triangles.to_string(),
        k1.map_or("n/a".into(), |p| sig(p.1)),
        k1.map_or("n/a".into(), |p| secs(p.0)),
        show(ps_to_k1),
        ratio(ps_to_k1.map(|r| r.time), k1.map(|p| p.0)),
        m512.map_or("n/a".into(), |p| sig(p.1)),
        m512.map_or("n/a".into(), |p| secs(p.0)),
        show(interval_to_m512),
        ratio(m512.map(|p| p.0), interval_to_m512.map(|r| r.time)),
        target.into(),
    ]);
    Ok(())
}

/// The RGB values of `rect` out of a full `width`-wide RGB image.
fn crop_of(image: &[f32], width: u32, rect: TileRect) -> Vec<f32> {
    let mut out = Vec::with_capacity(rect.pixel_count() * 3);
    for y in rect.y..rect.y + rect.height {
        let start = 3 * (y * width + rect.x) as usize;
        out.extend_from_slice(&image[start..start + 3 * rect.width as usize]);
    }
    out
}
