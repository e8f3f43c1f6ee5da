//! The user's `spindle` command.
//!
//! `spindle render SCENE.json -o OUT.exr` renders a scene on this machine and writes an OpenEXR
//! file (layers `total`, `surface`, `single_scatter`) plus a PNG preview beside it.

mod load;
mod local;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use spindle_common::tile::TileRect;
use spindle_worker::render::{Scene, render_pixel};

#[derive(Parser)]
#[command(
    name = "spindle",
    version,
    about = "Single scattering in refractive objects, rendered on a farm or here."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an OpenEXR file (and a PNG preview beside it).
    Render(RenderArgs),
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file (JSON); OBJ paths in it are relative to it.
    scene: PathBuf,
    /// The OpenEXR file to write; the preview goes to the same path with `.png`.
    #[arg(short, long)]
    output: PathBuf,
    /// Camera samples per pixel (overrides `film.spp`).
    #[arg(long)]
    spp: Option<u32>,
    /// Random seed (overrides `film.seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Render only this rectangle `x,y,w,h` of the image (the rest stays black).
    #[arg(long, value_parser = parse_crop)]
    crop: Option<TileRect>,
    /// Render only pixel `x,y` and print its value (for replaying one pixel).
    #[arg(long, value_parser = parse_pixel)]
    pixel: Option<(u32, u32)>,
    /// Print the render statistics.
    #[arg(long)]
    stats: bool,
    /// Farm workers to render with; 0 renders in this process with all cores.
    #[arg(long, default_value_t = 0)]
    workers: u32,
}

fn parse_numbers<const N: usize>(text: &str) -> Result<[u32; N], String> {
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != N {
        return Err(format!(
            "expected {N} comma-separated numbers, got {text:?}"
        ));
    }
    let mut out = [0u32; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p.trim().parse().map_err(|e| format!("{p:?}: {e}"))?;
    }
    Ok(out)
}

fn parse_crop(text: &str) -> Result<TileRect, String> {
    let [x, y, width, height] = parse_numbers::<4>(text)?;
    if width == 0 || height == 0 {
        return Err("crop width and height must be > 0".into());
    }
    Ok(TileRect {
        x,
        y,
        width,
        height,
    })
}

fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let [x, y] = parse_numbers::<2>(text)?;
    Ok((x, y))
}

fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    match Cli::parse().command {
        Command::Render(args) => render(args),
    }
}

fn render(args: RenderArgs) -> Result<()> {
    if args.workers != 0 {
        bail!(
            "--workers {}: the local farm is not part of this build yet; use --workers 0",
            args.workers
        );
    }
    let started = Instant::now();
    let mut files = load::load_scene(&args.scene)?;
    if let Some(spp) = args.spp {
        files.desc.film.spp = spp;
    }
    if let Some(seed) = args.seed {
        files.desc.film.seed = seed;
    }
    let scene = Scene::build(&files.desc, &files.assets)
        .with_context(|| format!("invalid scene {}", args.scene.display()))?;
    let summary = scene.summary();
    let built = started.elapsed();
    for warning in scene.warnings() {
        eprintln!("warning: {warning}");
    }

    let full = TileRect {
        x: 0,
        y: 0,
        width: summary.width,
        height: summary.height,
    };
    let region = match (args.pixel, args.crop) {
        (Some((x, y)), _) => TileRect {
            x,
            y,
            width: 1,
            height: 1,
        },
        (None, Some(crop)) => crop,
        (None, None) => full,
    };
    if region.x as u64 + region.width as u64 > full.width as u64
        || region.y as u64 + region.height as u64 > full.height as u64
    {
        bail!(
            "the region {},{} {}x{} is outside the {}x{} image",
            region.x,
            region.y,
            region.width,
            region.height,
            full.width,
            full.height
        );
    }

    if let Some((x, y)) = args.pixel {
        let value = render_pixel(&scene, x, y);
        let r = value.radiance;
        println!("pixel {x},{y}:");
        println!(
            "  total          {:?}",
            (r.surface + r.single_scatter).to_array()
        );
        println!("  surface        {:?}", r.surface.to_array());
        println!("  single_scatter {:?}", r.single_scatter.to_array());
    }

    let rows: u64 = spindle_common::tile::split_centre_first(region.width, region.height, 32)
        .iter()
        .map(|t| t.height as u64)
        .sum();
    let progress = ProgressBar::new(rows);
    if std::io::stderr().is_terminal() {
        progress.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}% eta {eta}")
                .expect("a valid template")
                .progress_chars("=> "),
        );
    } else {
        progress.set_draw_target(ProgressDrawTarget::hidden());
    }
    let render_started = Instant::now();
    let (mut image, stats) = local::render_in_process(&scene, region, &progress)?;
    progress.finish_and_clear();
    let rendered = render_started.elapsed();

    let a = &mut image.attributes;
    a.insert("spindle.scene".into(), args.scene.display().to_string());
    a.insert("spindle.spp".into(), summary.spp.to_string());
    a.insert("spindle.seed".into(), scene.film().seed.to_string());
    a.insert("spindle.triangles".into(), summary.triangles.to_string());
    a.insert("spindle.objects".into(), summary.objects.to_string());
    a.insert("spindle.lights".into(), summary.lights.to_string());
    a.insert(
        "spindle.region".into(),
        format!(
            "{},{},{},{}",
            region.x, region.y, region.width, region.height
        ),
    );
    a.insert(
        "spindle.integrator".into(),
        serde_json::to_string(scene.integrator()).context("integrator settings")?,
    );
    for (name, value) in stats.entries() {
        a.insert(format!("spindle.stats.{name}"), value.to_string());
    }
    if !summary.warnings.is_empty() {
        a.insert("spindle.warnings".into(), summary.warnings.join("; "));
    }

    image
        .write_exr(&args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    let preview = args.output.with_extension("png");
    image
        .write_png_preview(&preview)
        .with_context(|| format!("cannot write {}", preview.display()))?;

    println!(
        "rendered {} ({}x{}{}, {} spp, {} triangles in {} objects, {} lights, {} warnings) in {:.2} s \
         (scene build {:.2} s)",
        display(&args.output),
        full.width,
        full.height,
        if region == full {
            String::new()
        } else {
            format!(
                ", region {},{} {}x{}",
                region.x, region.y, region.width, region.height
            )
        },
        summary.spp,
        summary.triangles,
        summary.objects,
        summary.lights,
        summary.warnings.len(),
        rendered.as_secs_f64(),
        built.as_secs_f64(),
    );
    println!("preview {}", display(&preview));
    if args.stats {
        for (name, value) in stats.entries() {
            println!("  {name:<24} {value}");
        }
    }
    Ok(())
}

fn display(path: &Path) -> String {
    path.display().to_string()
}
