//! Multiple scattering (issue 33): what its settings cost and buy, and what it beats.
//!
//! The scene: a glass ball (icosphere of 1,280 triangles, radius 1, η 1.5, a grey isotropic
//! medium) under a small sphere light, seen whole. Every figure is of the `multiple_scatter`
//! layer, over one thread (`Runner`'s private pool is not used: each estimate is timed on the
//! calling thread, sample by sample, so both estimators pay the same way).
//!
//! 1. **Cost control.** For albedo 0.5, 0.9 and 0.99 and σ_t 1 and 10, each setting (the
//!    secondary segments' method, the order cut, paths per camera segment) against a reference
//!    (interval, orders to 1024, 4 paths, more samples): the bias of the image mean (with its
//!    standard error), the per-pixel relative standard error at the study's samples, and the
//!    seconds per camera sample. `efficiency` = 1 / (relative error² × seconds): how much
//!    per-pixel accuracy a second buys; the setting to start from is the one with the highest
//!    efficiency whose bias is within its noise.
//! 2. **What it beats.** The time each estimator needs for a 5 % per-pixel relative standard
//!    error, from its measured per-sample variance and cost (`samples = (σ/μ / 0.05)²`, averaged
//!    over the pixels the light reaches), with albedo 0.95: spindle's estimator against the
//!    volumetric path tracer that finds the light only by phase sampling
//!    (`multiple_scatter::phase_sampling`), on the ball and, when `../shared/meshes` has it, the
//!    bunny.

use std::time::Instant;

use anyhow::{Context, Result};
use spindle_common::scene as desc;
use spindle_common::stats::RenderStats;
use spindle_render::multiple_scatter::phase_sampling;
use spindle_render::sampler::Sampler;
use spindle_render::transport::radiance;
use spindle_render::{Assets, Scene};

use crate::BenchArgs;
use crate::report::{Report, Table, sig};
use crate::scenes::Model;

/// The per-pixel relative error the "time to reach" column asks for.
const TARGET: f64 = 0.05;

/// The study's scene: `model` of a grey medium under a sphere light of radius `light_radius`.
fn scene(
    model: &Model,
    sigma_t: f64,
    albedo: f64,
    size: u32,
    multiple: desc::MultipleScatter,
    light_radius: f64,
) -> desc::SceneDescription {
    desc::SceneDescription {
        camera: desc::Camera {
            position: [0.0, 0.3, 4.2],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 32.0,
        },
        film: crate::scenes::film(size, 1),
        lights: vec![desc::Light::Sphere {
            center: [2.0, 3.0, 2.5],
            radius: light_radius,
            radiance: [40.0 / (std::f64::consts::PI * light_radius * light_radius); 3],
        }],
        objects: vec![desc::Object {
            shape: model.shape.clone(),
            transform: model.transform.clone(),
            material: desc::Material::Dielectric {
                eta: 1.5,
                medium: desc::Medium {
                    sigma_t: [sigma_t; 3],
                    albedo: [albedo; 3],
                    phase: desc::Phase::Isotropic,
                },
            },
        }],
        background: [0.0; 3],
        integrator: desc::Integrator {
            multiple_scatter: multiple,
            ..desc::Integrator::default()
        },
        animation: None,
    }
}

/// Per-pixel sums of one estimator over `spp` samples, and the seconds it took.
struct Estimate {
    seconds: f64,
    samples: u64,
    /// Per pixel: (mean, variance of one sample) of the red channel.
    pixels: Vec<(f64, f64)>,
    stats: RenderStats,
}

impl Estimate {
    fn image_mean(&self) -> (f64, f64) {
        let n = self.pixels.len() as f64;
        let spp = self.samples as f64 / n;
        let mean = self.pixels.iter().map(|p| p.0).sum::<f64>() / n;
        let err = (self.pixels.iter().map(|p| p.1 / spp).sum::<f64>()).sqrt() / n;
        (mean, err)
    }

    /// Seconds per camera sample.
    fn cost(&self) -> f64 {
        self.seconds / self.samples as f64
    }

    /// The mean over the lit pixels (mean above 1 % of the brightest) of σ/μ of one sample.
    fn relative_sigma(&self) -> f64 {
        let brightest = self.pixels.iter().map(|p| p.0).fold(0.0, f64::max);
        let lit: Vec<f64> = self
            .pixels
            .iter()
            .filter(|p| p.0 > 0.01 * brightest)
            .map(|p| p.1.sqrt() / p.0)
            .collect();
        lit.iter().sum::<f64>() / lit.len().max(1) as f64
    }
}

/// Runs `sample` over every pixel of a `size`² film, `spp` samples each, on this thread.
fn estimate(
    size: u32,
    spp: u32,
    seed: u64,
    mut sample: impl FnMut(u32, u32, &mut Sampler, &mut RenderStats) -> f64,
) -> Estimate {
    let mut stats = RenderStats::default();
    let mut pixels = Vec::new();
    let started = Instant::now();
    for y in 0..size {
        for x in 0..size {
            let (mut sum, mut sum2) = (0.0, 0.0);
            for s in 0..spp {
                let mut sampler = Sampler::new(seed, x, y, s);
                let v = sample(x, y, &mut sampler, &mut stats);
                sum += v;
                sum2 += v * v;
            }
            let n = f64::from(spp);
            let mean = sum / n;
            pixels.push((mean, (sum2 / n - mean * mean).max(0.0) * n / (n - 1.0)));
        }
    }
    Estimate {
        seconds: started.elapsed().as_secs_f64(),
        samples: u64::from(size * size) * u64::from(spp),
        pixels,
        stats,
    }
}

/// spindle's `multiple_scatter` layer, one camera sample.
fn ours(scene: &Scene) -> impl FnMut(u32, u32, &mut Sampler, &mut RenderStats) -> f64 + '_ {
    move |x, y, sampler, stats| {
        let [u, v] = sampler.next_2d();
        let ray = scene.camera().ray(f64::from(x) + u, f64::from(y) + v);
        radiance(scene, &ray, sampler, stats).multiple_scatter.x
    }
}

/// The phase-sampling path tracer, one camera sample.
fn brute(scene: &Scene) -> impl FnMut(u32, u32, &mut Sampler, &mut RenderStats) -> f64 + '_ {
    move |x, y, sampler, _| {
        let [u, v] = sampler.next_2d();
        let ray = scene.camera().ray(f64::from(x) + u, f64::from(y) + v);
        phase_sampling::estimate(scene, ray, sampler).x
    }
}

fn build(desc: &desc::SceneDescription, assets: &Assets) -> Result<Scene> {
    Scene::build(desc, assets).context("the multiple-scattering study's scene")
}

pub fn run(report: &mut Report, args: &BenchArgs) -> Result<()> {
    report.line("== multiple scattering: cost control, and against phase sampling ==");
    let (size, spp, reference_spp) = if args.quick {
        (12, 8, 32)
    } else {
        (24, 16, 64)
    };
    let settings = |method, max_order, paths| desc::MultipleScatter {
        max_order,
        paths,
        method,
    };
    use desc::SecondaryMethod::{Interval, PointSampling, StraightLine};
    let mut table = Table::new(&[
        "albedo",
        "sigma_t",
        "method",
        "max_order",
        "paths",
        "bias %",
        "bias stderr %",
        "relative error per pixel",
        "ms per sample",
        "efficiency",
    ]);
    for albedo in [0.5, 0.9, 0.99] {
        for sigma_t in [1.0, 10.0] {
            let ball = Model::sphere(3);
            let reference_scene = build(
                &scene(
                    &ball,
                    sigma_t,
                    albedo,
                    size,
                    settings(Interval, 1024, 4),
                    0.3,
                ),
                &ball.assets,
            )?;
            let reference = estimate(size, reference_spp, 101, ours(&reference_scene));
            let (r_mean, r_err) = reference.image_mean();
            for (method, max_order, paths) in [
                (Interval, 64, 1),
                (Interval, 8, 1),
                (Interval, 64, 4),
                (PointSampling, 64, 1),
                (StraightLine, 64, 1),
            ] {
                let s = build(
                    &scene(
                        &ball,
                        sigma_t,
                        albedo,
                        size,
                        settings(method, max_order, paths),
                        0.3,
                    ),
                    &ball.assets,
                )?;
                let e = estimate(size, spp, 7, ours(&s));
                let (mean, err) = e.image_mean();
                let relative = e.relative_sigma() / f64::from(spp).sqrt();
                let efficiency = 1.0 / (relative * relative * e.seconds);
                let name = match method {
                    Interval => "interval",
                    PointSampling => "point_sampling",
                    StraightLine => "straight_line",
                    desc::SecondaryMethod::Auto => "auto",
                };
                table.push(vec![
                    albedo.to_string(),
                    sigma_t.to_string(),
                    name.to_string(),
                    max_order.to_string(),
                    paths.to_string(),
                    format!("{:+.2}", 100.0 * (mean / r_mean - 1.0)),
                    format!("{:.2}", 100.0 * (err * err + r_err * r_err).sqrt() / r_mean),
                    sig(relative),
                    sig(1e3 * e.cost()),
                    sig(efficiency),
                ]);
            }
        }
    }
    report.line(format!(
        "1. cost control: {size}x{size} px, {spp} spp per setting; reference interval, orders to \
         1024, 4 paths, {reference_spp} spp (bias = image mean against it; efficiency = 1 / \
         (per-pixel relative error^2 x seconds))"
    ));
    report.table("multiple_settings", &table)?;

    let mut models = vec![Model::sphere(3)];
    match Model::mesh(&args.meshes.join("bunny-4k.obj")) {
        Ok(bunny) => models.push(bunny),
        Err(e) => report.line(format!("2. bunny skipped: {e:#}")),
    }
    let mut beats = Table::new(&[
        "shape",
        "estimator",
        "ms per sample",
        "relative sigma per sample",
        "samples for 5 %",
        "seconds per pixel for 5 %",
        "speed-up",
    ]);
    let (ours_spp, brute_spp) = if args.quick { (8, 2048) } else { (16, 8192) };
    for model in &models {
        let name = &model.name;
        let s = build(
            &scene(
                model,
                3.0,
                0.95,
                size,
                settings(desc::SecondaryMethod::Auto, 64, 1),
                0.3,
            ),
            &model.assets,
        )?;
        let a = estimate(size, ours_spp, 11, ours(&s));
        let b = estimate(size, brute_spp, 13, brute(&s));
        let time = |e: &Estimate| {
            let samples = (e.relative_sigma() / TARGET).powi(2);
            (samples, samples * e.cost())
        };
        let (a_samples, a_time) = time(&a);
        let (b_samples, b_time) = time(&b);
        for (estimator, e, samples, seconds, speedup) in [
            (
                "spindle (exact connections)",
                &a,
                a_samples,
                a_time,
                b_time / a_time,
            ),
            ("phase sampling", &b, b_samples, b_time, 1.0),
        ] {
            beats.push(vec![
                name.to_string(),
                estimator.to_string(),
                sig(1e3 * e.cost()),
                sig(e.relative_sigma()),
                sig(samples),
                sig(seconds),
                sig(speedup),
            ]);
        }
        let (am, ae) = a.image_mean();
        let (bm, be) = b.image_mean();
        report.line(format!(
            "2. {name}: image means {am:.5} ± {ae:.1e} (spindle) and {bm:.5} ± {be:.1e} (phase \
             sampling); {} secondary segments per sample",
            sig(a.stats.secondary_segments as f64 / a.samples as f64)
        ));
    }
    report.line(format!(
        "2. time to {}% per-pixel relative error, albedo 0.95, sigma_t 3, a sphere light of \
         radius 0.3 (one thread; from per-sample variance and cost)",
        100.0 * TARGET
    ));
    report.table("multiple_beats", &beats)
}
