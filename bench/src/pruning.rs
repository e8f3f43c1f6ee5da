//! Study 4: what each pruning stage of the hierarchical descent culls, and what it saves.
//!
//! One scene (a bumpy sphere, so normals vary and the cone test has work to do) rendered with
//! the interval method five times: every stage on, each of the spindle, cone and plane stages
//! off alone, all off. The renderer's counters give each stage's cull fraction; the time with a stage off is
//! what it saves. Pruning is conservative, so the images should agree: the relative RMSE against
//! the all-on image is printed as a check.

use anyhow::Result;
use spindle_common::scene::{Pruning, ScatterMethod, SingleScatter};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;

use crate::BenchArgs;
use crate::metric::relative_rmse;
use crate::report::{Report, Table, keep_scene, secs, sig};
use crate::runner::Runner;
use crate::scenes::{Model, build, film};

const FILM: u32 = 128;

fn fraction(part: u64, whole: u64) -> String {
    if whole == 0 {
        "n/a".into()
    } else {
        sig(part as f64 / whole as f64)
    }
}

/// Runs study 4.
pub fn run(report: &mut Report, runner: &Runner, args: &BenchArgs) -> Result<()> {
    let (model, region_size) = if args.quick {
        (Model::bumpy(5), 8)
    } else {
        (Model::bumpy(6), 24)
    };
    let offset = (FILM - region_size) / 2;
    let region = TileRect {
        x: offset,
        y: offset,
        width: region_size,
        height: region_size,
    };
    report.line("");
    report.line("== 4. pruning ==");
    report.line(format!(
        "setup: {} ({} triangles), interval K=1, default tolerance, {FILM}x{FILM} film, 1 spp, centre {region_size}x{region_size} pixels",
        model.name, model.triangles
    ));
    let configs = [
        ("all on", true, true, true),
        ("spindle off", false, true, true),
        ("cone off", true, false, true),
        ("plane off", true, true, false),
        ("all off", false, false, false),
    ];
    let mut table = Table::new(&[
        "config",
        "seconds",
        "time_vs_all_on",
        "bvh_nodes_visited",
        "nodes_culled_spindle",
        "spindle_cull_fraction",
        "nodes_culled_cone",
        "node_cone_cull_fraction",
        "triangles_tested",
        "triangles_culled_plane",
        "plane_cull_fraction",
        "triangles_culled_cone",
        "cone_cull_fraction",
        "newton_iterations",
        "rel_rmse_vs_all_on",
    ]);
    let mut base: Option<(f64, Vec<f32>)> = None;
    for (name, spindle, cone, plane) in configs {
        let single = SingleScatter {
            method: ScatterMethod::Interval,
            pruning: Pruning {
                spindle,
                cone,
                plane,
            },
            ..SingleScatter::default()
        };
        if name == "all on" {
            keep_scene(
                report,
                "pruning.json",
                &model.scene(film(FILM, 1), single.clone()),
            )?;
        }
        let scene = build(&model, film(FILM, 1), single)?;
        let timed = runner.render(&scene, region);
        let s: RenderStats = timed.pixels.stats;
        let image = timed.pixels.single_scatter;
        let (base_s, base_image) = base.get_or_insert_with(|| (timed.seconds, image.clone()));
        table.push(vec![
            name.into(),
            secs(timed.seconds),
            sig(timed.seconds / *base_s),
            s.bvh_nodes_visited.to_string(),
            s.nodes_culled_spindle.to_string(),
            fraction(s.nodes_culled_spindle, s.bvh_nodes_visited),
            s.nodes_culled_cone.to_string(),
            fraction(s.nodes_culled_cone, s.bvh_nodes_visited),
            s.triangles_tested.to_string(),
            s.triangles_culled_plane.to_string(),
            fraction(s.triangles_culled_plane, s.triangles_tested),
            s.triangles_culled_cone.to_string(),
            fraction(s.triangles_culled_cone, s.triangles_tested),
            s.newton_iterations.to_string(),
            relative_rmse(&image, base_image).map_or("n/a".into(), sig),
        ]);
    }
    report.line(
        "cull fractions: spindle and node cone = nodes culled / nodes visited; plane and cone = triangles culled / triangles tested",
    );
    report.table("pruning", &table)
}
