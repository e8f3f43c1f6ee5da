//! `spindle render SCENE.json -o OUT.exr [--workers N]`: render a scene on this machine and
//! write the OpenEXR image (layers `total` with alpha, `surface`, `single_scatter`, `multiple_scatter`, `stderr`) and a PNG preview
//! beside it (`OUT.png`), or with `-o OUT.png` the PNG preview alone.
//!
//! By default through an embedded local farm ([`crate::local_farm`]: a coordinator and N
//! workers in this process, the same path a job takes on many machines); `--workers 0` renders
//! in this process without the farm ([`spindle_render::render_frame`]), the single-process
//! reference, which also offers `--pixel`. Both write the same pixels and the same header
//! attributes (`spindle_common::header::describe`: but `renderTime`, which differs run to run),
//! for the whole film or for a `--crop` window (the EXR's data window, inside the
//! film's display window).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use spindle_common::header::{self, RenderFacts};
use spindle_common::image::Image;
use spindle_common::protocol::{DEFAULT_TILE_SIZE, check_crop};
use spindle_common::scene::{FrameRange, SceneDescription};
use spindle_common::scene_override::{Override, apply_overrides};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use spindle_common::tile::{LAYERS, Layer};
use spindle_render::{Scene, provenance, render_pixel};

use spindle_common::scene_files::read_meshes;

use crate::frames;
use crate::interrupt::{Interrupted, Signals, tiles_written};
use crate::local_farm::{Outcome, SoFar};
use crate::meter::{Meter, Show};

/// `spindle render` options.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// The scene file: spindle's JSON (OBJ paths in it are relative to it) or glTF 2.0
    /// (`.gltf`, `.glb`; converted as scenes/README.md, "glTF scenes", says).
    pub scene: PathBuf,
    /// For a glTF scene: the camera to render through, by the name of its node or of the
    /// camera (default: the first camera in the scene's node order).
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
    /// The image to write: `OUT.exr` (OpenEXR, with the tone-mapped PNG preview beside it as
    /// `OUT.png`) or `OUT.png` (the preview alone). Optional with `--pixel`.
    /// With several frames, the last run of `#` in the file name is the frame number,
    /// zero-padded to its length (`shot.####.exr`).
    #[arg(short, long, required_unless_present = "pixel")]
    pub output: Option<PathBuf>,
    /// The frames to render, `FIRST-LAST` or `N`, one after another, each the scene at that
    /// frame (its `animation` resolved), each to its own `-o` file (default: the scene's
    /// `animation.frames`, else frame 1).
    #[arg(long, value_name = "FIRST-LAST", value_parser = crate::frames::parse_frames)]
    pub frames: Option<FrameRange>,
    /// The frame this render is of, set by [`run`] for each frame of the sequence.
    #[arg(skip)]
    pub frame: Option<u32>,
    /// Whether a glTF file's import warnings were printed already (by an earlier frame).
    #[arg(skip)]
    pub warned: bool,
    /// Local farm workers (default: one per two cores, at least two); 0 renders in this
    /// process without the farm.
    #[arg(long)]
    pub workers: Option<usize>,
    /// Render threads, at least 1: with `--workers 0` the render's own thread pool, on the
    /// local farm the threads of each worker. Default: every core (with `--workers 0`,
    /// `RAYON_NUM_THREADS` when set; on the local farm shared among the workers). The pixels
    /// do not depend on it.
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Print nothing but errors, as pbrt's `--quiet`: no plan, progress, warnings or
    /// "rendered" line (the scene's warnings stay in the EXR header). What was asked for by
    /// name is still printed: `--stats`, and `--pixel`'s value.
    #[arg(short, long)]
    pub quiet: bool,
    /// Set a scene field without editing the file: `--set objects[0].material.eta=1.33`
    /// (the path as validation messages write it; the value as JSON, or else a string).
    /// Repeatable; checked as the scene file is.
    #[arg(long = "set", short = 'D', value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Camera samples per pixel (overrides `film.spp`).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Ignore `film.time_budget_s`: render to `film.spp` (or `film.target_error`) in one pass.
    /// A budgeted render is reproduced bit for bit by `--workers 0 --no-time-budget --spp N`,
    /// N its EXR's `spindle.spp`.
    #[arg(long)]
    pub no_time_budget: bool,
    /// Write the EXR in 16-bit half floats (sets `film.half`): half the size, about three
    /// significant digits.
    #[arg(long)]
    pub half: bool,
    /// Random seed (overrides `film.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Render only the window `x,y,w,h` of the film (column, row of its top-left pixel, width,
    /// height), on the local farm or with `--workers 0`: the EXR holds the window as its data
    /// window inside the film's display window (as pbrt-v4 writes a crop), the PNG preview the
    /// window alone. Pixels equal those of a full render.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    pub crop: Option<TileRect>,
    /// Render only pixel `x,y` and print its value, for replaying one pixel (needs
    /// `--workers 0`; with `-o` the one-pixel image is written too, a 1x1 data window in the
    /// film's display window).
    #[arg(long, value_parser = parse_pixel)]
    pub pixel: Option<(u32, u32)>,
    /// Tile edge in pixels on the local farm.
    #[arg(long, default_value_t = DEFAULT_TILE_SIZE)]
    pub tile_size: u32,
    /// Print the render statistics and the mean of each layer (total, surface, single_scatter,
    /// multiple_scatter, stderr, alpha).
    #[arg(long)]
    pub stats: bool,
    /// Also write `OUT.stderr.png`: each pixel's relative standard error (stderr / total),
    /// black at 0 and white at 10 % or more, to see where the image is still noisy. Refused at
    /// 1 spp, where no pixel has two samples to estimate its error from.
    #[arg(long)]
    pub error_png: bool,
    /// Render even when a dielectric's medium gets no light (every light reaches it only
    /// through a second refractive interface, which is not modelled): it comes out black.
    #[arg(long)]
    pub allow_blocked: bool,
}

impl RenderArgs {
    /// The image to write (`-o`, which only `--pixel` may leave out).
    fn output(&self) -> Result<&Path> {
        self.output.as_deref().ok_or_else(|| {
            anyhow::anyhow!("-o OUT.exr is required (only --pixel may leave it out)")
        })
    }

    /// Where progress goes.
    fn show(&self) -> Show {
        Show::on_stderr(self.quiet)
    }

    /// Prints a line of the command's report on stdout, unless `--quiet`.
    fn say(&self, line: std::fmt::Arguments) {
        if !self.quiet {
            println!("{line}");
        }
    }

    /// Applies `--set`, then resolves the frame being rendered (a still of the scene at it),
    /// then applies `--spp`, `--seed`, `--half` and `--no-time-budget`, and refuses
    /// `--error-png` at 1 spp.
    fn edit(&self, scene: &mut SceneDescription) -> Result<()> {
        *scene = apply_overrides(scene, &self.set).map_err(|e| anyhow!("--set {e}"))?;
        if let Some(frame) = self.frame {
            *scene = scene.at_frame(frame);
        }
        if let Some(spp) = self.spp {
            scene.film.spp = spp;
        }
        if self.no_time_budget {
            scene.film.time_budget_s = None;
        }
        if let Some(seed) = self.seed {
            scene.film.seed = seed;
        }
        if self.half {
            scene.film.half = true;
        }
        if self.error_png && scene.film.spp < 2 {
            bail!(
                "--error-png: film.spp is {}, and with one sample a pixel's error cannot be \
                 estimated (its stderr is 0, which is not \"no error\"); render with --spp 2 \
                 or more",
                scene.film.spp
            );
        }
        Ok(())
    }
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

/// Parses `--crop x,y,w,h` (`render` and `submit`); whether it fits the film is checked once
/// the scene is read ([`check_crop`]).
pub fn parse_crop(text: &str) -> Result<TileRect, String> {
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

/// Parses `--threads N`, N ≥ 1 (clap names the flag in the error).
fn parse_threads(text: &str) -> Result<usize, String> {
    let n: usize = text.trim().parse().map_err(|e| format!("{text:?}: {e}"))?;
    if n == 0 {
        return Err("must be at least 1".into());
    }
    Ok(n)
}

/// Runs `work` on a rayon pool of its own of `threads` threads, or on the global pool (every
/// core, or `RAYON_NUM_THREADS`) for `None`. A pool of its own rather than the global one's
/// size: nothing else in the process is affected.
fn on_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    let Some(n) = threads else {
        return Ok(work());
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("render-{i}"))
        .build()
        .with_context(|| format!("--threads {n}: cannot start the render threads"))?;
    Ok(pool.install(work))
}

/// `N thread(s)`.
fn threads_text(n: usize) -> String {
    crate::status::count(n as u64, "thread")
}

pub async fn run(args: &RenderArgs) -> Result<()> {
    let (range, asked) = match args.frames {
        Some(range) => (range, format!("--frames {}", frames::describe(range))),
        None => {
            // The scene's own range: read here once (quietly: each frame reads it again).
            let mut files = crate::scene_input::load(&args.scene, args.camera.as_deref(), false)?;
            files.desc =
                apply_overrides(&files.desc, &args.set).map_err(|e| anyhow!("--set {e}"))?;
            let range = files.desc.frame_range();
            let asked = format!("the scene's animation.frames {}", frames::describe(range));
            (range, asked)
        }
    };
    if let Some(output) = &args.output {
        frames::check_output("-o", output, range, &asked)?;
        check_output(&frames::frame_path(output, range.start))?;
    }
    let signals = Signals::listen()?;
    // The frames one after another, each a still of the scene at that frame (on the local
    // farm, a farm of its own each: the coordinator knows no frames yet).
    for frame in range.frames() {
        let mut one = args.clone();
        one.frame = Some(frame);
        one.output = args.output.as_ref().map(|o| frames::frame_path(o, frame));
        one.warned = frame > range.start;
        render_frame_of(&one, &signals).await?;
    }
    Ok(())
}

/// Renders one frame (`args.frame`) to `args.output`.
async fn render_frame_of(args: &RenderArgs, signals: &Signals) -> Result<()> {
    let workers = args
        .workers
        .unwrap_or_else(crate::local_farm::default_workers);
    if workers == 0 {
        return tokio::task::block_in_place(|| {
            on_threads(args.threads, || in_process(args, signals))
        })?;
    }
    if args.pixel.is_some() {
        bail!("--pixel renders in this process: add --workers 0");
    }
    on_local_farm(args, workers, signals).await
}

/// What `-o` asks for, by its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum OutputKind {
    /// `.exr`: the OpenEXR image, and the PNG preview beside it.
    Exr,
    /// `.png`: the PNG preview alone.
    Png,
}

impl OutputKind {
    fn of(output: &Path) -> Result<OutputKind> {
        let extension = output.extension().and_then(|e| e.to_str());
        match extension.map(str::to_ascii_lowercase).as_deref() {
            Some("exr") => Ok(OutputKind::Exr),
            Some("png") => Ok(OutputKind::Png),
            _ => bail!(
                "-o {}: must end in .exr (the OpenEXR image, with its PNG preview written beside \
                 it) or .png (the tone-mapped preview alone)",
                output.display()
            ),
        }
    }
}

/// Refuses, before any rendering, an output the image could not be written to as asked: not
/// an `.exr` or a `.png`, or in a directory that does not exist.
fn check_output(output: &Path) -> Result<()> {
    OutputKind::of(output)?;
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "-o {}: the directory {} does not exist",
            output.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Refuses, before any rendering, a scene in which a medium gets no light and so would render
/// black, unless `--allow-blocked` says to go on.
pub fn refuse_unlit_media(
    scene: &Scene,
    path: &std::path::Path,
    allow_blocked: bool,
) -> Result<()> {
    let unlit = scene.unlit_media();
    if unlit.is_empty() || allow_blocked {
        return Ok(());
    }
    bail!(
        "{}: {}; add --allow-blocked to render it anyway (see scenes/README.md, \
         \"What single scattering models\")",
        path.display(),
        unlit.join("; ")
    )
}

/// `--workers N`: through the embedded farm.
async fn on_local_farm(args: &RenderArgs, workers: usize, signals: &Signals) -> Result<()> {
    let started = Instant::now();
    // Read and check the scene here first, so a mistake is reported before any farm starts.
    let warn = !args.quiet && !args.warned;
    let mut files = crate::scene_input::load(&args.scene, args.camera.as_deref(), warn)?;
    args.edit(&mut files.desc)?;
    read_meshes(&args.scene, &files.desc, &mut files.assets)?;
    let mut desc = files.desc.clone();
    let files_spp = desc.film.spp;
    if let Some(crop) = &args.crop {
        check_crop(crop, desc.film.width, desc.film.height).map_err(|e| anyhow!("--{e}"))?;
    }
    // The workers build the scene again; here it is built once to say the single-scattering plan.
    let scene = on_threads(args.threads, || Scene::build(&files.desc, &files.assets))?
        .with_context(|| format!("invalid scene {}", args.scene.display()))?;
    if !args.quiet {
        for warning in scene.warnings() {
            eprintln!("warning: {warning}");
        }
    }
    refuse_unlit_media(&scene, &args.scene, args.allow_blocked)?;
    let provenance = provenance(&scene);
    drop(scene);
    print_plan(args, &provenance.plan);
    drop(files);
    let farm = crate::local_farm::LocalFarm {
        workers,
        threads: args.threads,
        show: args.show(),
    };
    let scene_file = args.scene.display().to_string();
    let window = args.crop.unwrap_or(TileRect {
        x: 0,
        y: 0,
        width: desc.film.width,
        height: desc.film.height,
    });
    // Describes and writes the tiles that are in, on a signal.
    let write_so_far = |so_far: SoFar| -> Result<String> {
        let mut image = so_far.image;
        header::describe(
            &mut image,
            &RenderFacts {
                scene: &desc,
                window,
                stats: &so_far.stats,
                provenance: Some(&provenance),
                passes: None,
                render_seconds: Some(started.elapsed().as_secs_f64()),
                scene_file: Some(&scene_file),
                workers: Some(workers),
            },
        );
        let done = (so_far.tiles_done, so_far.tiles_total);
        mark_partial(&mut image, Some(done));
        tokio::task::block_in_place(|| write_outputs(&image, args))?;
        Ok(tiles_written(done.0, done.1, args.output()?))
    };
    let mut snapshot = |so_far: SoFar| match write_so_far(so_far) {
        Ok(what) => eprintln!("spindle: SIGHUP: {what}; rendering goes on"),
        Err(e) => eprintln!("spindle: SIGHUP: {e:#}"),
    };
    let outcome = crate::local_farm::render(farm, signals, &mut snapshot, |api| async move {
        let edit = |s: &mut SceneDescription| args.edit(s);
        crate::submit::submit_scene_file(
            &api,
            &args.scene,
            args.camera.as_deref(),
            Some(&edit),
            crate::submit::Check::AlreadyBuilt,
            &crate::submit::JobOptions {
                tile_size: args.tile_size,
                crop: args.crop,
                ..Default::default()
            },
        )
        .await
    })
    .await?;
    let result = match outcome {
        Outcome::Done(result) => result,
        Outcome::Stopped(signal, so_far) => {
            return Err(Interrupted {
                signal,
                what: write_so_far(so_far)?,
            }
            .into());
        }
    };
    let mut image = Image::from_exr_bytes(&result.exr)
        .context("the local coordinator sent an unreadable EXR")?;
    let stats = result.job.stats;
    let per_worker: Vec<String> = result.tiles_per_worker.iter().map(u64::to_string).collect();
    let passes = result.job.passes;
    if let Some(p) = passes {
        // The header says what the image is: the render of `spp` = the samples reached.
        desc.film.spp = p.spp;
    }
    header::describe(
        &mut image,
        &RenderFacts {
            scene: &desc,
            window,
            stats: &stats,
            provenance: Some(&provenance),
            passes: passes.map(|p| (p.pass, p.budget_s)),
            render_seconds: Some(started.elapsed().as_secs_f64()),
            scene_file: Some(&scene_file),
            workers: Some(workers),
        },
    );
    let preview = write_outputs(&image, args)?;
    args.say(format_args!(
        "rendered {} ({}x{}{}, {} spp) on a local farm of {workers} workers × {} in {:.2} s \
         ({} of {} px: {} per worker)",
        args.output()?.display(),
        desc.film.width,
        desc.film.height,
        describe_crop(args.crop),
        desc.film.spp,
        threads_text(result.threads_per_worker),
        started.elapsed().as_secs_f64(),
        crate::status::count(result.job.tiles_total, "tile"),
        args.tile_size,
        per_worker.join("+"),
    ));
    if let Some(preview) = preview {
        args.say(format_args!("preview {}", preview.display()));
    }
    if let Some(p) = passes {
        args.say(format_args!(
            "{} of {} spp in {} passes; the same bits: --workers 0 --no-time-budget --spp {}",
            p.spp, files_spp, p.pass, p.spp
        ));
    }
    print_stats(args, &stats, &image);
    Ok(())
}

/// `--workers 0`: in this process, with rayon over the current pool (`--threads`).
fn in_process(args: &RenderArgs, signals: &Signals) -> Result<()> {
    let started = Instant::now();
    let warn = !args.quiet && !args.warned;
    let mut files = crate::scene_input::load(&args.scene, args.camera.as_deref(), warn)?;
    args.edit(&mut files.desc)?;
    read_meshes(&args.scene, &files.desc, &mut files.assets)?;
    let scene = Scene::build(&files.desc, &files.assets)
        .with_context(|| format!("invalid scene {}", args.scene.display()))?;
    let summary = scene.summary();
    let built = started.elapsed();
    if !args.quiet {
        for warning in scene.warnings() {
            eprintln!("warning: {warning}");
        }
    }
    refuse_unlit_media(&scene, &args.scene, args.allow_blocked)?;
    let provenance = provenance(&scene);
    print_plan(args, &provenance.plan);

    let full = TileRect {
        x: 0,
        y: 0,
        width: summary.width,
        height: summary.height,
    };
    if let Some(crop) = &args.crop {
        check_crop(crop, full.width, full.height).map_err(|e| anyhow!("--{e}"))?;
    }
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
    if let Some((x, y)) = args.pixel
        && (x >= full.width || y >= full.height)
    {
        bail!(
            "--pixel {x},{y} is outside the {}x{} image",
            full.width,
            full.height
        );
    }

    if let Some((x, y)) = args.pixel {
        let value = render_pixel(&scene, x, y);
        let r = value.radiance;
        println!("pixel {x},{y}:");
        println!("  total            {:?}", r.total().to_array());
        println!("  surface          {:?}", r.surface.to_array());
        println!("  single_scatter   {:?}", r.single_scatter.to_array());
        println!("  multiple_scatter {:?}", r.multiple_scatter.to_array());
        println!("  alpha            {:?}", value.alpha);
        if args.output.is_none() {
            return Ok(());
        }
    }

    let rows: u64 = spindle_common::tile::split_centre_first(region.width, region.height, 32)
        .iter()
        .map(|t| t.height as u64)
        .sum();
    let render_started = Instant::now();
    let budget = files
        .desc
        .film
        .time_budget_s
        .filter(|_| args.pixel.is_none());
    let scene_file = args.scene.display().to_string();
    // Describes and writes an image of `desc` rendered so far (`partial`: tiles done of all).
    let write_image = |image: &mut Image,
                       stats: &RenderStats,
                       desc: &SceneDescription,
                       passes: Option<(u32, f64)>,
                       partial: Option<(usize, usize)>| {
        header::describe(
            image,
            &RenderFacts {
                scene: desc,
                window: region,
                stats,
                provenance: Some(&provenance),
                passes,
                render_seconds: Some(started.elapsed().as_secs_f64()),
                scene_file: Some(&scene_file),
                workers: None,
            },
        );
        mark_partial(image, partial);
        write_outputs(image, args)
    };
    let (mut image, stats, passes) = match budget {
        None => {
            let progress = Meter::new(args.show(), rows, "render", "rows");
            let mut hangups = signals.asked().hangups;
            let frame = spindle_render::render_frame_until(
                &scene,
                region,
                &|rows| progress.inc(rows),
                &mut |so_far| {
                    let asked = signals.asked();
                    if asked.hangups > hangups {
                        hangups = asked.hangups;
                        let mut image = so_far.image.clone();
                        let done = (so_far.tiles_done, so_far.tiles_total);
                        match write_image(&mut image, &so_far.stats, &files.desc, None, Some(done))
                        {
                            Ok(_) => eprintln!(
                                "spindle: SIGHUP: {}; rendering goes on",
                                tiles_written(
                                    done.0,
                                    done.1,
                                    args.output.as_deref().unwrap_or(Path::new("-"))
                                )
                            ),
                            Err(e) => eprintln!("spindle: SIGHUP: {e:#}"),
                        }
                    }
                    asked.stop.is_none()
                },
            )?;
            progress.finish();
            if let Some(stop) = signals.asked().stop
                && frame.tiles_done < frame.tiles_total
            {
                let mut image = frame.image;
                let done = (frame.tiles_done, frame.tiles_total);
                write_image(&mut image, &frame.stats, &files.desc, None, Some(done))?;
                return Err(Interrupted {
                    signal: stop,
                    what: tiles_written(done.0, done.1, args.output()?),
                }
                .into());
            }
            (frame.image, frame.stats, None)
        }
        Some(budget) => {
            let (image, stats, report) =
                render_in_passes(&scene, region, budget, render_started, args.quiet, signals)?;
            (image, stats, Some(report))
        }
    };
    let rendered = render_started.elapsed();
    if let Some(report) = passes {
        // The header says what the image is: the render of `spp` = the samples reached.
        files.desc.film.spp = report.spp;
    }
    let preview = write_image(
        &mut image,
        &stats,
        &files.desc,
        passes.zip(budget).map(|(report, b)| (report.passes, b)),
        None,
    )?;
    if let (Some(stop), Some(report)) = (signals.asked().stop, passes)
        && report.pixels_sampling > 0
    {
        return Err(Interrupted {
            signal: stop,
            what: format!(
                "wrote the last complete pass ({} passes, {} spp) to {}",
                report.passes,
                report.spp,
                args.output()?.display()
            ),
        }
        .into());
    }

    args.say(format_args!(
        "rendered {} ({}x{}{}, {} spp, {} triangles in {} objects, {} lights, {} warnings) in {:.2} s \
         on {} (scene build {:.2} s)",
        args.output()?.display(),
        full.width,
        full.height,
        describe_crop((region != full).then_some(region)),
        files.desc.film.spp,
        summary.triangles,
        summary.objects,
        summary.lights,
        summary.warnings.len(),
        rendered.as_secs_f64(),
        threads_text(rayon::current_num_threads()),
        built.as_secs_f64(),
    ));
    if let Some(preview) = preview {
        args.say(format_args!("preview {}", preview.display()));
    }
    if let Some(report) = passes {
        args.say(format_args!(
            "{} of {} spp in {} passes; the same bits: --workers 0 --no-time-budget --spp {}",
            report.spp,
            scene.film().spp,
            report.passes,
            report.spp
        ));
    }
    print_stats(args, &stats, &image);
    Ok(())
}

/// `film.time_budget_s`: progressive passes while the next one, taking as long as the last,
/// would end within `budget` seconds of `started` (the first pass always runs); each pass is
/// reported on stderr unless `quiet`.
fn render_in_passes(
    scene: &Scene,
    region: TileRect,
    budget: f64,
    started: Instant,
    quiet: bool,
    signals: &Signals,
) -> Result<(Image, RenderStats, spindle_render::PassReport)> {
    let mut last_end = 0.0;
    let result = spindle_render::render_frame_passes(scene, region, &mut |report| {
        let now = started.elapsed().as_secs_f64();
        let pass_seconds = now - last_end;
        last_end = now;
        if !quiet {
            eprintln!(
                "pass {}: {} spp, {} pixels still sampling, {now:.1} s of {budget} s",
                report.passes, report.spp, report.pixels_sampling
            );
        }
        now + pass_seconds <= budget && signals.asked().stop.is_none()
    })?;
    Ok(result)
}

/// Says in the header of an image rendered in part how much of it is in: `spindle.tiles_done`
/// = `12 of 40` (the others transparent black).
fn mark_partial(image: &mut Image, partial: Option<(usize, usize)>) {
    if let Some((done, total)) = partial {
        image
            .attributes
            .insert("spindle.tiles_done".into(), format!("{done} of {total}"));
    }
}

/// `, region x,y WxH` for a window smaller than the film, else nothing.
fn describe_crop(region: Option<TileRect>) -> String {
    match region {
        Some(r) => format!(", region {},{} {}x{}", r.x, r.y, r.width, r.height),
        None => String::new(),
    }
}

/// Says which single-scattering model runs for each object (the `auto` method's choice).
fn print_plan(args: &RenderArgs, plan: &[String]) {
    for line in plan {
        args.say(format_args!("single scattering: {line}"));
    }
}

/// Writes what `-o` asks for: the EXR and the PNG preview beside it, or the PNG preview
/// alone (and with `--error-png` the relative-error PNG); returns the path of a preview
/// written beside the output.
fn write_outputs(image: &Image, args: &RenderArgs) -> Result<Option<PathBuf>> {
    let output = args.output()?;
    if args.error_png {
        let path = output.with_extension("stderr.png");
        image
            .write_png_relative_error(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        args.say(format_args!("relative error {}", path.display()));
    }
    let preview = match OutputKind::of(output)? {
        OutputKind::Png => {
            image
                .write_png_preview(output)
                .with_context(|| format!("cannot write {}", output.display()))?;
            return Ok(None);
        }
        OutputKind::Exr => output.with_extension("png"),
    };
    image
        .write_exr(output)
        .with_context(|| format!("cannot write {}", output.display()))?;
    image
        .write_png_preview(&preview)
        .with_context(|| format!("cannot write {}", preview.display()))?;
    Ok(Some(preview))
}

/// With `--stats`: the counters, then the mean of each layer over the pixels and channels.
fn print_stats(args: &RenderArgs, stats: &RenderStats, image: &Image) {
    if args.stats {
        for (name, value) in stats.entries() {
            println!("  {name:<24} {value}");
        }
        for (Layer { name, .. }, layer) in LAYERS.iter().zip(image.layers()) {
            let mean = layer.iter().map(|&v| f64::from(v)).sum::<f64>() / layer.len().max(1) as f64;
            println!("  mean {name:<19} {mean:.6e}");
        }
    }
}
