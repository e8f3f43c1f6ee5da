//! Noise of area lights against point lights (issue 16): how many samples a sphere light costs
//! for the same per-pixel error as the point light of the same power.
//!
//! The scene is the issue's: a glass icosphere of 5,120 triangles (radius 1, η 1.5, σ_t 1,
//! albedo 0.9, isotropic) seen from distance 5, lit from behind at distance 4 by a point light
//! of intensity `I`, or by a sphere light of radius `r` and radiance `I / (π r²)` (the same
//! power and, far away, the same intensity). Each is rendered at a few sample counts and
//! compared, over the `single_scatter` layer, with a converged render of the *same* scene made
//! from independent samples (another seed). The reference is the mean of two halves rendered
//! with different seeds; half the distance between the halves estimates its own noise, which
//! is removed in quadrature from each error (`corrected`), so a noisy reference does not flatter
//! or penalise a light. Errors are relative RMSE (`metric::relative_rmse`). Renders use every
//! core; the seconds are this run's wall time, for ratios within the run only.
//!
//! Two more figures per light: the samples (and seconds) to reach [`TARGET`] relative error,
//! read off the measured curve (`metric::time_to_reach`), and the `stderr` layer's own estimate
//! of the image's error — `sqrt(Σ stderr² / Σ total²)`, the number a farm job's progress shows
//! (`common::noise`) — beside the measured relative RMSE of the `total` layer.

use std::time::Instant;

use anyhow::{Context, Result};
use spindle_common::scene as desc;
use spindle_common::tile::TilePixels;
use spindle_render::{Assets, Scene, render_tile};

use crate::BenchArgs;
use crate::metric::{relative_rmse, time_to_reach};
use crate::report::{Report, Table, keep_scene, sig};
use crate::runner::full_frame;
use spindle_common::noise::NoiseSums;

/// The lights compared: a label, and the light (all of intensity [`INTENSITY`] from afar).
fn lights() -> Vec<(&'static str, desc::Light)> {
    let sphere = |radius: f64| desc::Light::Sphere {
        center: LIGHT_AT,
        radius,
        radiance: [INTENSITY / (std::f64::consts::PI * radius * radius); 3],
    };
    vec![
        (
            "point",
            desc::Light::Point {
                position: LIGHT_AT,
                intensity: [INTENSITY; 3],
            },
        ),
        ("sphere r=0.1", sphere(0.1)),
        ("sphere r=0.5", sphere(0.5)),
    ]
}

const INTENSITY: f64 = 100.0;
/// The error the "to reach" columns ask for: 2 % relative RMSE of `single_scatter`.
const TARGET: f64 = 0.02;
/// Distance 4 from the sphere's centre, behind it and a little above the camera's axis.
const LIGHT_AT: [f64; 3] = [0.0, 1.1878, -3.8196];

fn scene(light: desc::Light, size: u32, spp: u32, seed: u64) -> desc::SceneDescription {
    desc::SceneDescription {
        camera: desc::Camera {
            position: [0.0, 0.0, 5.0],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 30.0,
        },
        film: desc::Film {
            width: size,
            height: size,
            spp,
            seed,
            target_error: None,
            time_budget_s: None,
        },
        lights: vec![light],
        objects: vec![desc::Object {
            shape: desc::Shape::Icosphere {
                radius: 1.0,
                subdivisions: 4,
            },
            transform: desc::Transform::default(),
            material: desc::Material::Dielectric {
                eta: 1.5,
                medium: desc::Medium {
                    sigma_t: [1.0; 3],
                    albedo: [0.9; 3],
                    phase: desc::Phase::Isotropic,
                },
            },
        }],
        background: [0.0; 3],
        integrator: desc::Integrator::default(),
    }
}

fn render(desc: &desc::SceneDescription) -> Result<(TilePixels, f64)> {
    let scene = Scene::build(desc, &Assets::new()).context("the lights study's scene")?;
    let started = Instant::now();
    let pixels = render_tile(&scene, full_frame(&scene));
    Ok((pixels, started.elapsed().as_secs_f64()))
}

pub fn run(report: &mut Report, args: &BenchArgs) -> Result<()> {
    let (size, reference_spp, counts): (u32, u32, &[u32]) = if args.quick {
        (16, 64, &[4, 16])
    } else {
        (32, 256, &[4, 16, 64])
    };
    report.line(format!(
        "\n== area lights against point lights: {size}x{size}, glass icosphere 5120, light at \
         distance 4; reference {reference_spp} spp in two halves of other seeds =="
    ));
    let mut table = Table::new(&[
        "light",
        "spp",
        "relative_rmse",
        "corrected",
        "reference_noise",
        "seconds",
        "total_corrected",
        "stderr_estimate",
    ]);
    let mut reach = Table::new(&["light", "spp_to_2pct", "seconds_to_2pct", "extrapolated"]);
    for (label, light) in lights() {
        let half = |seed| render(&scene(light.clone(), size, reference_spp / 2, seed));
        let (a, _) = half(1001)?;
        let (b, _) = half(2002)?;
        let reference: Vec<f32> = a
            .single_scatter
            .iter()
            .zip(&b.single_scatter)
            .map(|(x, y)| 0.5 * (x + y))
            .collect();
        // ‖a − b‖ / 2 is the noise of their mean (relative to ‖b‖, about the reference's norm).
        let reference_noise = relative_rmse(&a.single_scatter, &b.single_scatter).map(|e| 0.5 * e);
        let reference_total: Vec<f32> = a
            .total
            .iter()
            .zip(&b.total)
            .map(|(x, y)| 0.5 * (x + y))
            .collect();
        let reference_total_noise = relative_rmse(&a.total, &b.total).map(|e| 0.5 * e);
        let (mut by_spp, mut by_seconds) = (Vec::new(), Vec::new());
        keep_scene(
            report,
            &format!("lights-{}.json", label.replace([' ', '='], "-")),
            &scene(light.clone(), size, counts[counts.len() / 2], 7),
        )?;
        for &spp in counts {
            let (image, seconds) = render(&scene(light.clone(), size, spp, 7))?;
            let error = relative_rmse(&image.single_scatter, &reference);
            let corrected = quadrature(error, reference_noise);
            let total_corrected = quadrature(
                relative_rmse(&image.total, &reference_total),
                reference_total_noise,
            );
            let estimate = NoiseSums::of_tile(&image).relative_error();
            if let Some(e) = corrected {
                by_spp.push((f64::from(spp), e));
                by_seconds.push((seconds, e));
            }
            table.push(vec![
                label.into(),
                spp.to_string(),
                error.map_or("-".into(), sig),
                corrected.map_or("-".into(), sig),
                reference_noise.map_or("-".into(), sig),
                format!("{seconds:.1}"),
                total_corrected.map_or("-".into(), sig),
                estimate.map_or("-".into(), sig),
            ]);
        }
        let spp_to = time_to_reach(&by_spp, TARGET);
        let seconds_to = time_to_reach(&by_seconds, TARGET);
        reach.push(vec![
            label.into(),
            spp_to.map_or("-".into(), |r| format!("{:.0}", r.time)),
            seconds_to.map_or("-".into(), |r| format!("{:.2}", r.time)),
            match (spp_to, seconds_to) {
                (Some(a), Some(b)) => (a.extrapolated || b.extrapolated).to_string(),
                _ => "-".into(),
            },
        ]);
    }
    report.table("lights", &table)?;
    report.line(format!(
        "samples and seconds to {}% relative RMSE of single_scatter (corrected), log-log \
         interpolation of the rows above",
        TARGET * 100.0
    ));
    report.table("lights-to-2pct", &reach)
}

/// `e` with the reference's own noise `n` removed in quadrature.
fn quadrature(e: Option<f64>, n: Option<f64>) -> Option<f64> {
    match (e, n) {
        (Some(e), Some(n)) => Some((e * e - n * n).max(0.0).sqrt()),
        _ => None,
    }
}
