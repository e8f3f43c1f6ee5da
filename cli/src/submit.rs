//! `spindle submit SCENE.json|SCENE.glb [--wait]`: send a scene and its meshes to a coordinator.
//!
//! The scene is built here first, exactly as `spindle render --workers 0` builds it (meshes
//! included), so a scene no worker could build is refused with the same message before
//! anything is uploaded.
//!
//! Meshes are content-addressed: each OBJ file is hashed (blake3), the coordinator is asked
//! which hashes it lacks, and only those are uploaded. The job itself is posted with an
//! idempotency key, so the automatic retry of a submission whose answer was lost cannot create
//! a second job.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use spindle_common::protocol::{DEFAULT_TILE_SIZE, JobInfo, SubmitJob, asset_hash, parse_label};
use spindle_common::scene::{FrameRange, SceneDescription};
use spindle_common::scene_override::{Override, apply_overrides};

use crate::api::Api;
use crate::progress::{Wait, wait_for};
use crate::secret::random_hex;
use spindle_common::scene_files::read_meshes;

/// `spindle submit` options.
#[derive(Debug, clap::Args)]
pub struct SubmitArgs {
    /// The scene file: spindle's JSON (OBJ paths in it are relative to it) or glTF 2.0
    /// (`.gltf`, `.glb`), converted here: the coordinator receives a spindle scene.
    pub scene: std::path::PathBuf,
    /// For a glTF scene: the camera to render through, by the name of its node or of the
    /// camera (default: the first camera in the scene's node order).
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
    /// The frame to render, of an animated scene: the job renders the scene at that frame, made
    /// by each worker (default: the scene's `animation.frames`, which must then be one frame).
    /// One frame a job for now: `spindle render --frames FIRST-LAST` renders a sequence on
    /// this machine.
    #[arg(long, value_name = "N", value_parser = crate::frames::parse_frames)]
    pub frames: Option<FrameRange>,
    /// Wait for the job to finish, showing its progress.
    #[arg(long)]
    pub wait: bool,
    /// Tile edge in pixels.
    #[arg(long, default_value_t = DEFAULT_TILE_SIZE)]
    pub tile_size: u32,
    /// Higher runs first; equal priorities run in submission order.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub priority: i32,
    /// Lease the job only to workers with this `key=value` label (`spindle-worker --label`);
    /// repeatable: a worker needs every one.
    #[arg(long = "require", value_name = "KEY=VALUE", value_parser = parse_label)]
    pub requires: Vec<(String, String)>,
    /// The job's name (default: the scene file's name without `.json`).
    #[arg(long)]
    pub name: Option<String>,
    /// Who submits it, a label shown in `spindle jobs` (default: $USER, or when it is unset
    /// the account's name from the system).
    #[arg(long)]
    pub submitter: Option<String>,
    /// Set a scene field without editing the file: `--set objects[0].material.eta=1.33`
    /// (the path as validation messages write it; the value as JSON, or else a string).
    /// Repeatable; checked as the scene file is.
    #[arg(long = "set", short = 'D', value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Camera samples per pixel (overrides `film.spp`).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed (overrides `film.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Render only the window `x,y,w,h` of the film (column, row of its top-left pixel, width,
    /// height); the job's EXR holds it as its data window inside the film's display window,
    /// with the pixels `spindle render --workers 0 --crop` writes.
    #[arg(long, value_name = "X,Y,W,H", value_parser = crate::render::parse_crop)]
    pub crop: Option<spindle_common::tile::TileRect>,
    /// With --wait: download the final EXR here when the job is done.
    #[arg(short, long, requires = "wait")]
    pub output: Option<std::path::PathBuf>,
    /// Submit even when a dielectric's medium gets no light (every light reaches it only
    /// through a second refractive interface, which is not modelled): it comes out black.
    #[arg(long)]
    pub allow_blocked: bool,
}

/// Runs `spindle submit`: prints the job id on stdout; with `--wait`, fails unless the job ends
/// `done`.
pub async fn run(api: &Api, args: &SubmitArgs) -> Result<()> {
    let options = JobOptions {
        tile_size: args.tile_size,
        priority: args.priority,
        requires: args.requires.iter().cloned().collect(),
        name: args.name.clone().or_else(|| {
            args.scene
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
        }),
        submitter: args
            .submitter
            .clone()
            .or_else(|| std::env::var("USER").ok().filter(|s| !s.is_empty()))
            .or_else(|| whoami::username().ok())
            .filter(|s| !s.is_empty()),
        crop: args.crop,
        frames: args.frames,
    };
    let edit = |scene: &mut SceneDescription| -> Result<()> {
        *scene = apply_overrides(scene, &args.set).map_err(|e| anyhow::anyhow!("--set {e}"))?;
        if let Some(spp) = args.spp {
            scene.film.spp = spp;
        }
        if let Some(seed) = args.seed {
            scene.film.seed = seed;
        }
        Ok(())
    };
    let check = Check::Build {
        allow_blocked: args.allow_blocked,
    };
    let job = submit_scene_file(
        api,
        &args.scene,
        args.camera.as_deref(),
        Some(&edit),
        check,
        &options,
    )
    .await?;
    println!("{}", job.id);
    if args.wait {
        let end = wait_for(api, job.id, Wait::default()).await?;
        crate::progress::require_done(&end)?;
        if let Some(output) = &args.output {
            crate::fetch::download(api, job.id, Some(output), false).await?;
        }
    }
    Ok(())
}

/// The one frame a job renders: `--frames N`, else the scene's `animation.frames` (frame 1
/// without one); refused when that is more than one frame.
fn one_frame(asked: Option<FrameRange>, scene: &SceneDescription) -> Result<u32> {
    let (range, by) = match asked {
        Some(range) => (range, "--frames"),
        None => (scene.frame_range(), "the scene's animation.frames"),
    };
    if range.len() > 1 {
        anyhow::bail!(
            "{by} {}: a job renders one frame for now: submit one (--frames {}), or render the \
             sequence on this machine with spindle render --frames",
            crate::frames::describe(range),
            range.start
        );
    }
    Ok(range.start)
}

/// Whether [`submit_scene_file`] builds the scene before sending it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// Build it with the renderer, as `render --workers 0` does, and refuse if it does not build
    /// or, unless `allow_blocked`, if a medium in it gets no light.
    Build { allow_blocked: bool },
    /// The caller has just built this very scene.
    AlreadyBuilt,
}

/// How a job is to be run, besides its scene.
#[derive(Debug, Clone, Default)]
pub struct JobOptions {
    pub tile_size: u32,
    pub priority: i32,
    pub requires: BTreeMap<String, String>,
    pub name: Option<String>,
    pub submitter: Option<String>,
    /// Only this window of the film ([`SubmitJob::crop`]).
    pub crop: Option<spindle_common::tile::TileRect>,
    /// The frame asked for (`--frames N`): the job renders it ([`SubmitJob::frame`]); absent,
    /// the scene's own when it has `animation`.
    pub frames: Option<FrameRange>,
}

/// A change made to a scene before it is sent (the local farm's `--spp`, `--seed`, `--set`),
/// which may refuse it.
pub type SceneEdit<'a> = dyn Fn(&mut SceneDescription) -> Result<()> + 'a;

/// Reads the scene file and its meshes (a glTF file converted, through `camera` when named),
/// uploads the meshes the coordinator lacks, and submits the job. `edit` may change the scene
/// before it is sent (the local farm's `--spp`/`--seed`).
pub async fn submit_scene_file(
    api: &Api,
    scene_path: &Path,
    camera: Option<&str>,
    edit: Option<&SceneEdit<'_>>,
    check: Check,
    options: &JobOptions,
) -> Result<JobInfo> {
    // After `Check::AlreadyBuilt` the caller has read the scene and said its warnings.
    let warn = matches!(check, Check::Build { .. });
    let mut files = crate::scene_input::load(scene_path, camera, warn)?;
    if let Some(edit) = edit {
        edit(&mut files.desc)?;
        read_meshes(scene_path, &files.desc, &mut files.assets)?;
    }
    // The coordinator checks the crop too (a 400 naming `crop`); here it is refused before
    // any mesh is uploaded.
    if let Some(crop) = &options.crop {
        let film = &files.desc.film;
        spindle_common::protocol::check_crop(crop, film.width, film.height)
            .map_err(|e| anyhow::anyhow!("--{e}"))?;
    }
    // The frame the job renders; the workers make its still (`JobSpec::still`).
    let frame = if files.desc.animation.is_some() || options.frames.is_some() {
        Some(one_frame(options.frames, &files.desc)?)
    } else {
        None
    };
    if let Check::Build { allow_blocked } = check {
        let still = match frame {
            Some(frame) => files.desc.at_frame(frame),
            None => files.desc.clone(),
        };
        let scene = spindle_render::Scene::build(&still, &files.assets)
            .with_context(|| format!("invalid scene {}", scene_path.display()))?;
        for warning in scene.warnings() {
            eprintln!("warning: {warning}");
        }
        crate::render::refuse_unlit_media(&scene, scene_path, allow_blocked)?;
    }
    // Hash every mesh and upload the ones the coordinator has not seen.
    let mut table = BTreeMap::new();
    let mut by_hash: BTreeMap<String, &[u8]> = BTreeMap::new();
    for (path, bytes) in &files.assets {
        let hash = asset_hash(bytes);
        table.insert(path.clone(), hash.clone());
        by_hash.insert(hash, bytes);
    }
    if !by_hash.is_empty() {
        let missing = api
            .missing_assets(by_hash.keys().cloned().collect())
            .await
            .context("asking the coordinator which meshes it lacks")?;
        for hash in missing {
            let Some(bytes) = by_hash.get(hash.as_str()) else {
                anyhow::bail!(
                    "the coordinator asked for asset {hash}, which this scene does not have"
                );
            };
            let path = table
                .iter()
                .find(|(_, h)| **h == hash)
                .map_or("?", |(p, _)| p.as_str());
            api.put_asset(&hash, bytes)
                .await
                .with_context(|| format!("uploading {path} ({} bytes)", bytes.len()))?;
            tracing::info!(%path, %hash, bytes = bytes.len(), "uploaded mesh");
        }
    }
    let job = SubmitJob {
        scene: files.desc,
        assets: table,
        tile_size: options.tile_size,
        priority: options.priority,
        requires: options.requires.clone(),
        name: options.name.clone(),
        submitter: options.submitter.clone(),
        crop: options.crop,
        frame,
    };
    let key = random_hex()?;
    api.submit(&job, &key)
        .await
        .with_context(|| format!("submitting {}", scene_path.display()))
}
