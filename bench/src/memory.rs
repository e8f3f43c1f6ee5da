//! Study 5: peak resident memory of a renderer process against the triangle count.
//!
//! The method needs nothing beyond the mesh and its BVH, so memory should grow linearly with
//! the triangles, from a fixed floor. Each point is a fresh child process of this binary,
//! `spindle-bench memory-probe SCENE.json` ([`probe`]), which does what `spindle render
//! --workers 0` does (read the scene and its meshes, build, render every tile in process) and
//! then prints its own high-water mark `VmHWM` from `/proc/self/status`: exact, where polling
//! another process's status could miss the peak.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};
use spindle_common::scene::ScatterMethod;

use spindle_common::scene_files::load_scene;
use spindle_render::render_frame;

use crate::BenchArgs;
use crate::metric::linear_fit;
use crate::plot::{self, Labels, Mark, Series};
use crate::report::{Report, Table, keep_scene, sig};
use crate::scenes::{Model, SHARED_MESHES, film, settings, shared_meshes};

const PEAK_KEY: &str = "peak_rss_kib";

/// This process's peak resident set size (`VmHWM`) in KiB, from `/proc/self/status`.
pub fn peak_rss_kib() -> Result<u64> {
    let status =
        std::fs::read_to_string("/proc/self/status").context("cannot read /proc/self/status")?;
    parse_vm_hwm(&status).context("no VmHWM line in /proc/self/status")
}

fn parse_vm_hwm(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let mut words = line["VmHWM:".len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") | None => Some(value),
        Some(_) => None,
    }
}

/// The child's side: render `scene` in process and print the peak memory.
pub fn probe(scene_path: &Path) -> Result<()> {
    let files = load_scene(scene_path)?;
    let scene = spindle_render::Scene::build(&files.desc, &files.assets)
        .with_context(|| format!("invalid scene {}", scene_path.display()))?;
    let film = scene.film();
    let full = spindle_common::tile::TileRect {
        x: 0,
        y: 0,
        width: film.width,
        height: film.height,
    };
    let (_image, _stats) = render_frame(&scene, full, &|_| ())?;
    println!("triangles {}", scene.triangle_count());
    println!("{PEAK_KEY} {}", peak_rss_kib()?);
    Ok(())
}

fn measure(scene_path: &Path) -> Result<u64> {
    let exe = std::env::current_exe().context("cannot find the spindle-bench executable")?;
    let output = Command::new(exe)
        .arg("memory-probe")
        .arg(scene_path)
        .output()
        .context("cannot start the memory probe")?;
    if !output.status.success() {
        bail!(
            "the memory probe of {} failed: {}",
            scene_path.display(),
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    stdout
        .lines()
        .find_map(|l| l.strip_prefix(PEAK_KEY)?.trim().parse().ok())
        .with_context(|| format!("the memory probe printed no {PEAK_KEY}: {stdout}"))
}

/// Runs study 5.
pub fn run(report: &mut Report, args: &BenchArgs) -> Result<()> {
    report.line("");
    report.line("== 5. memory ==");
    let subdivisions = if args.quick { 0..=6 } else { 0..=8 };
    report.line(format!(
        "setup: a child process per model renders a 16x16 film (1 spp, interval) in process; peak RSS = its VmHWM; \
         icospheres subdivided {subdivisions:?}{}",
        if args.quick { "" } else { " and the shared meshes" }
    ));
    let mut models: Vec<Model> = subdivisions.map(Model::sphere).collect();
    if !args.quick {
        let (found, skipped) = shared_meshes(&args.meshes, &SHARED_MESHES);
        for reason in skipped {
            report.line(reason);
        }
        models.extend(found);
    }
    let mut table = Table::new(&[
        "model",
        "triangles",
        "peak_rss_mib",
        "bytes_per_triangle_above_floor",
    ]);
    let mut points = Vec::new();
    let mut floor: Option<f64> = None;
    for model in &models {
        let desc = model.scene(film(16, 1), settings(ScatterMethod::Interval));
        let path = keep_scene(report, &format!("memory-{}.json", model.name), &desc)?;
        let kib = measure(&path)?;
        let bytes = kib as f64 * 1024.0;
        let floor = *floor.get_or_insert(bytes);
        points.push((model.triangles as f64, bytes));
        table.push(vec![
            model.name.clone(),
            model.triangles.to_string(),
            format!("{:.1}", bytes / (1024.0 * 1024.0)),
            if model.triangles > 1000 {
                format!("{:.0}", (bytes - floor) / model.triangles as f64)
            } else {
                "-".into()
            },
        ]);
    }
    report.table("memory", &table)?;
    if let Some((slope, intercept)) = linear_fit(&points) {
        report.line(format!(
            "linear fit: peak RSS ≈ {:.1} MiB + {} bytes per triangle",
            intercept / (1024.0 * 1024.0),
            sig(slope)
        ));
    }
    let png = report.out().join("memory.png");
    let mib: Vec<(f64, f64)> = points
        .iter()
        .map(|(n, b)| (*n, b / (1024.0 * 1024.0)))
        .collect();
    plot::loglog(
        &png,
        &Labels {
            title: "peak resident memory of a rendering process",
            x: "triangles",
            y: "peak RSS (MiB)",
        },
        &[Series {
            name: "icospheres and meshes".into(),
            points: mib,
            mark: Mark::Line,
        }],
    )?;
    report.line(format!("  -> {}", png.display()));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_vm_hwm_in_kib() {
        let status = "Name:\tspindle\nVmPeak:\t  20000 kB\nVmHWM:\t   12345 kB\nVmRSS:\t 1000 kB\n";
        assert_eq!(parse_vm_hwm(status), Some(12345));
        assert_eq!(parse_vm_hwm("VmRSS: 1 kB\n"), None);
        assert_eq!(parse_vm_hwm("VmHWM: 12 MB\n"), None);
    }

    #[test]
    fn this_process_has_a_peak() {
        // Linux only, like the study: a running test binary holds at least a few hundred KiB.
        if !Path::new("/proc/self/status").exists() {
            println!("skipping: no /proc on this system");
            return;
        }
        assert!(peak_rss_kib().unwrap() > 100);
    }
}
