//! Study 3: how the cost of a camera ray that reaches the object grows with the triangle count.
//!
//! Icospheres and bumpy spheres from about 1e3 to 1e6 triangles, plus the shared meshes, rendered
//! with the interval method (K = 1, default tolerance) over the centre of the film. Each model
//! renders tiles until a time budget is spent; the time is divided by the camera rays of those
//! tiles that hit the object (counted by tracing each pixel centre against the scene's BVH).
//! Besides seconds, the renderer's own counters per ray (triangles tested, Newton iterations)
//! are fitted too: they are the same bits on every run, so their slope is free of the machine's
//! noise. The paper reports O(n^0.75); the lower bound is O(n^0.5); the target is ≤ n^0.65.

use anyhow::Result;
use spindle_common::scene::ScatterMethod;
use spindle_common::tile::TileRect;
use spindle_render::Scene;

use crate::BenchArgs;
use crate::metric::loglog_fit;
use crate::plot::{self, Labels, Mark, Series};
use crate::report::{Report, Table, keep_scene, secs, sig};
use crate::runner::Runner;
use crate::scenes::{Model, SHARED_MESHES, build, film, settings, shared_meshes};

const FILM: u32 = 128;
/// The rendered square in the middle of the film, inside the spheres' silhouettes.
const REGION: u32 = 64;
const TILE: u32 = 8;

struct Row {
    model: Model,
    seconds_per_ray: f64,
    triangles_per_ray: f64,
    newton_per_ray: f64,
    rays: u64,
}

/// Camera rays through the pixel centres of `tiles` that hit the scene, times spp.
fn rays_reaching(scene: &Scene, tiles: &[TileRect]) -> u64 {
    let mut hits = 0u64;
    for t in tiles {
        for y in t.y..t.y + t.height {
            for x in t.x..t.x + t.width {
                let ray = scene.camera().ray(x as f64 + 0.5, y as f64 + 0.5);
                if scene.bvh().closest_hit(&ray).is_some() {
                    hits += 1;
                }
            }
        }
    }
    hits * scene.film().spp as u64
}

/// Runs study 3.
pub fn run(report: &mut Report, runner: &Runner, args: &BenchArgs) -> Result<()> {
    let (subdivisions, budget) = if args.quick {
        (3..=6, 0.4)
    } else {
        (3..=8, 2.5)
    };
    report.line("");
    report.line("== 3. scaling with the mesh ==");
    report.line(format!(
        "setup: interval K=1, default tolerance; {FILM}x{FILM} film, 1 spp, centre {REGION}x{REGION} \
         in {TILE}x{TILE} tiles until {budget} s per model; time / camera rays hitting the object"
    ));
    let mut models: Vec<Model> = Vec::new();
    for s in subdivisions.clone() {
        models.push(Model::sphere(s));
    }
    for s in subdivisions {
        models.push(Model::bumpy(s));
    }
    if !args.quick {
        let (found, skipped) = shared_meshes(&args.meshes, &SHARED_MESHES);
        for reason in skipped {
            report.line(reason);
        }
        models.extend(found);
    }
    let offset = (FILM - REGION) / 2;
    let region = TileRect {
        x: offset,
        y: offset,
        width: REGION,
        height: REGION,
    };
    let mut rows = Vec::new();
    for model in models {
        let scene = build(&model, film(FILM, 1), settings(ScatterMethod::Interval))?;
        if model.family == "sphere" && model.triangles == 20 * 4usize.pow(5) {
            keep_scene(
                report,
                "scaling-sphere-20480.json",
                &model.scene(film(FILM, 1), settings(ScatterMethod::Interval)),
            )?;
        }
        let done = runner.render_budgeted(&scene, region, TILE, budget);
        let rays = rays_reaching(&scene, &done.tiles);
        if rays == 0 {
            report.line(format!(
                "{}: no camera ray reached the object; left out",
                model.name
            ));
            continue;
        }
        let per = |v: u64| v as f64 / rays as f64;
        rows.push(Row {
            seconds_per_ray: done.seconds / rays as f64,
            triangles_per_ray: per(done.stats.triangles_tested),
            newton_per_ray: per(done.stats.newton_iterations),
            rays,
            model,
        });
    }

    let mut table = Table::new(&[
        "model",
        "family",
        "triangles",
        "rays",
        "seconds_per_ray",
        "triangles_tested_per_ray",
        "newton_iterations_per_ray",
    ]);
    for r in &rows {
        table.push(vec![
            r.model.name.clone(),
            r.model.family.into(),
            r.model.triangles.to_string(),
            r.rays.to_string(),
            secs(r.seconds_per_ray),
            sig(r.triangles_per_ray),
            sig(r.newton_per_ray),
        ]);
    }
    report.table("scaling", &table)?;

    // Fitted slopes, per family and over everything.
    let mut fits = Table::new(&[
        "points",
        "slope_seconds",
        "slope_triangles_tested",
        "slope_newton",
    ]);
    let mut series = Vec::new();
    for family in ["sphere", "bumpy", "mesh", "all"] {
        let chosen: Vec<&Row> = rows
            .iter()
            .filter(|r| family == "all" || r.model.family == family)
            .collect();
        let pick = |f: fn(&Row) -> f64| -> Vec<(f64, f64)> {
            chosen
                .iter()
                .map(|r| (r.model.triangles as f64, f(r)))
                .collect()
        };
        let seconds = pick(|r| r.seconds_per_ray);
        let fit = loglog_fit(&seconds);
        let slope =
            |points: Vec<(f64, f64)>| loglog_fit(&points).map_or("n/a".into(), |f| sig(f.0));
        fits.push(vec![
            family.into(),
            fit.map_or("n/a".into(), |f| sig(f.0)),
            slope(pick(|r| r.triangles_per_ray)),
            slope(pick(|r| r.newton_per_ray)),
        ]);
        if family == "all" || seconds.is_empty() {
            if let (Some((s, c)), "all") = (fit, family) {
                let (lo, hi) = seconds.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
                    (lo.min(p.0), hi.max(p.0))
                });
                series.push(Series {
                    name: format!("fit over all: n^{s:.2}"),
                    points: vec![(lo, c.exp() * lo.powf(s)), (hi, c.exp() * hi.powf(s))],
                    mark: Mark::Dashed,
                });
            }
            continue;
        }
        series.push(Series {
            name: format!(
                "{family}{}",
                fit.map_or(String::new(), |f| format!(" (slope {:.2})", f.0))
            ),
            points: seconds,
            mark: if family == "mesh" {
                Mark::Points
            } else {
                Mark::Line
            },
        });
    }
    report.line(
        "log-log slopes of cost per ray against triangles (target <= 0.65; paper 0.75; bound 0.5):",
    );
    report.table("scaling_slopes", &fits)?;
    let png = report.out().join("scaling.png");
    plot::loglog(
        &png,
        &Labels {
            title: "time per camera ray reaching the object (interval, K=1)",
            x: "triangles",
            y: "seconds per ray (one thread)",
        },
        &series,
    )?;
    report.line(format!("  -> {}", png.display()));
    Ok(())
}
