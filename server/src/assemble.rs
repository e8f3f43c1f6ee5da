//! The final image of a job, and its preview: finished tiles read back from the store and placed
//! into one image of the job's window (the film, or its crop: then the EXR's data window is
//! the crop inside the film's display window, as `render --workers 0 --crop` writes it).
//!
//! Tiles are inserted in tile index order and the EXR writer's bytes depend only on the image,
//! so the file does not depend on which worker rendered which tile or in what order tiles
//! arrived. The header carries the film's settings, the summed render statistics
//! (`spindle.stats.<counter>`), the job's provenance as its workers reported it (renderer,
//! objects, triangles, lights, warnings, the single-scattering plan), the camera matrices,
//! `software` and `renderTime` (the job's seconds from its first lease): the same names and
//! values `spindle render --workers 0` writes, through the same function,
//! `spindle_common::header::describe`.
//!
//! Assembly never fails a job whose tiles are all in: a stored tile found damaged (missing,
//! truncated, altered) goes back to the queue to be rendered again, and any other error (I/O,
//! a full disk) is retried with backoff until it passes; a restarted coordinator resumes. A
//! budgeted job's tiles are all in at the end of each of its passes: [`finish`] first ends the
//! pass (the same backoff, a bounded number of times: [`crate::ledger::passes`]), and assembles only
//! after the last. Only [`finish`] is async; the rest blocks and runs under `spawn_blocking`.

use std::time::Duration;

use spindle_common::image::Image;
use spindle_common::protocol::{JobSpec, PassInfo};
use spindle_common::provenance::Provenance;
use spindle_common::stats::RenderStats;

use spindle_common::header::RenderFacts;

use crate::AppState;
use crate::clock::now_ms;
use crate::error::Error;
use crate::ledger::pass_end::{PASS_END_ATTEMPTS, PassEnd};
use crate::tile_store::{ReadError, TileStore};

/// First and longest pause before assembly is tried again after an error that may pass.
const RETRY_FIRST: Duration = Duration::from_millis(250);
const RETRY_MAX: Duration = Duration::from_secs(30);

/// Why the final image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum AssembleError {
    /// These stored tiles (index, why) must be rendered again.
    #[error("damaged tiles: {0:?}")]
    Damaged(Vec<(u32, String)>),
    /// Anything else; it may pass.
    #[error(transparent)]
    Transient(#[from] anyhow::Error),
}

/// Reads the given finished tiles (`(index, hash)`, in index order) into an image of the job's
/// window; tiles that cannot be read back intact are left black and returned with the reason.
pub fn frame(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
) -> anyhow::Result<(Image, Vec<(u32, String)>)> {
    let film = &spec.scene.film;
    // Admission checked the crop against the film; a spec stored otherwise is an error.
    let passes = spindle_common::aov::AovSet::of(&film.passes);
    let mut image = Image::window(film.width, film.height, spec.window())?.with_passes(passes);
    let mut damaged = Vec::new();
    for (index, hash) in tiles {
        match store.read(job, *index, hash) {
            Ok(pixels) => {
                if let Err(e) = image.insert_tile(&pixels) {
                    damaged.push((*index, format!("the stored result of tile {index}: {e}")));
                }
            }
            Err(ReadError::Damaged(why)) => damaged.push((*index, why)),
            Err(ReadError::Io(e)) => anyhow::bail!(e),
        }
    }
    Ok((image, damaged))
}

/// What the header of a finished job's EXR says beyond its spec.
pub struct JobFacts<'a> {
    /// The summed render statistics of its tiles.
    pub stats: &'a RenderStats,
    /// The job's provenance, as its workers reported it.
    pub provenance: Option<&'a Provenance>,
    /// A job with a time budget: its last pass (whose cap is the spec's `spp` by then).
    pub passes: Option<&'a PassInfo>,
    /// Seconds from the job's first lease to its assembly.
    pub render_seconds: Option<f64>,
}

/// Writes the final EXR of a job whose tiles are all in, atomically; returns the SHA-256 of
/// its bytes (hex), which clients check it by.
pub fn write_final(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
    facts: &JobFacts,
) -> Result<String, AssembleError> {
    let expected = spec.tiles().len();
    if tiles.len() != expected {
        let e = anyhow::anyhow!("{} of {expected} tiles are in", tiles.len());
        return Err(AssembleError::Transient(e));
    }
    let (mut image, damaged) = frame(store, job, spec, tiles)?;
    if !damaged.is_empty() {
        return Err(AssembleError::Damaged(damaged));
    }
    // The header describes the still rendered (its camera at the job's frame).
    let still = spec.still();
    spindle_common::header::describe(
        &mut image,
        &RenderFacts {
            scene: &still,
            window: spec.window(),
            stats: facts.stats,
            provenance: facts.provenance,
            passes: facts.passes.map(|p| (p.pass, p.budget_s)),
            render_seconds: facts.render_seconds,
            scene_file: None,
            workers: None,
        },
    );
    let bytes = image.to_exr_bytes().map_err(anyhow::Error::from)?;
    std::fs::create_dir_all(store.job_dir(job)).map_err(anyhow::Error::from)?;
    spindle_common::atomic_write::write(store.image_path(job), &bytes)
        .map_err(anyhow::Error::from)?;
    Ok(sha256_hex(&bytes))
}

/// The EXR of a cancelled job's finished tiles (`tiles`: each tile's latest result), as
/// `spindle render` writes an interrupted render: the missing tiles, and any stored result found
/// damaged, transparent black (alpha 0); the header of a finished job's image with
/// `spindle.tiles_done` = `N of M`. Made on request, never stored.
pub fn partial(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
    facts: &JobFacts,
) -> anyhow::Result<Vec<u8>> {
    let (mut image, damaged) = frame(store, job, spec, tiles)?;
    for (index, why) in &damaged {
        tracing::warn!(
            job,
            tile = index,
            why,
            "a stored tile is left out of a partial image"
        );
    }
    spindle_common::header::describe(
        &mut image,
        &RenderFacts {
            scene: &spec.scene,
            window: spec.window(),
            stats: facts.stats,
            provenance: facts.provenance,
            passes: facts.passes.map(|p| (p.pass, p.budget_s)),
            render_seconds: facts.render_seconds,
            scene_file: None,
            workers: None,
        },
    );
    let done = tiles.len() - damaged.len();
    image.attributes.insert(
        "spindle.tiles_done".into(),
        format!("{done} of {}", spec.tiles().len()),
    );
    Ok(image.to_exr_bytes()?)
}

/// The SHA-256 of `bytes`, lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Ends the pass of budgeted job `id`, whose tiles are all in
/// ([`crate::ledger::Ledger::end_of_pass`]), retrying an error with backoff; after
/// [`PASS_END_ATTEMPTS`] failed, fails the job with the reason. Returns whether the job is
/// complete and may be assembled.
async fn end_pass(state: &AppState, id: u64) -> bool {
    let mut delay = RETRY_FIRST;
    let mut attempt = 0;
    loop {
        attempt += 1;
        let ended = state.with_ledger(move |l| l.end_of_pass(id)).await;
        let error = match ended {
            Ok(PassEnd::Complete) => return true,
            Ok(PassEnd::NextPass) => {
                state.work_available();
                return false;
            }
            Ok(PassEnd::Ended) | Err(Error::NotFound(_)) => return false,
            Err(e) => e,
        };
        tracing::error!(job = id, error = %error, attempt, retry_in = ?delay, "ending the pass failed");
        if attempt >= PASS_END_ATTEMPTS {
            let failed = state
                .with_ledger(move |l| l.fail_pass_end(id, &error))
                .await;
            match failed {
                Ok(()) => return false,
                // Not even the failure could be recorded: keep trying, as assembly does.
                Err(e) => tracing::error!(job = id, error = %e, "failing the job failed"),
            }
        }
        tokio::select! {
            _ = tokio::time::sleep(delay) => {}
            _ = state.shutdown_signal() => return false,
        }
        delay = (delay * 2).min(RETRY_MAX);
    }
}

/// Writes the final image of job `id`, whose tiles are all in, and records the job done;
/// damaged tiles go back to the queue instead, and other errors are retried with backoff. Ends
/// early when the job is deleted or stops meanwhile. A budgeted job's pass is ended first
/// ([`end_pass`]): the job is assembled only after its last.
pub(crate) async fn finish(state: AppState, id: u64) {
    if !end_pass(&state, id).await {
        return;
    }
    let mut delay = RETRY_FIRST;
    loop {
        let prepared = state
            .with_ledger(move |ledger| {
                Ok(ledger
                    .job(id)
                    .ok()
                    .filter(|job| !job.state.is_finished())
                    .map(|job| {
                        let passes = job.passes.as_ref().map(|p| p.info(job.spec.scene.film.spp));
                        let seconds = job.info(now_ms(), 0, 0).elapsed_s;
                        (
                            job.spec.clone(),
                            job.stats,
                            job.provenance.clone(),
                            passes,
                            seconds,
                        )
                    })
                    .and_then(|(spec, stats, provenance, passes, seconds)| {
                        let tiles = ledger.done_tiles(id).ok()?;
                        Some((spec, stats, provenance, passes, seconds, tiles))
                    }))
            })
            .await
            .ok()
            .flatten();
        let Some((spec, stats, provenance, passes, seconds, tiles)) = prepared else {
            return; // Deleted or cancelled meanwhile.
        };
        let store = state.tile_store().clone();
        let result = tokio::task::spawn_blocking(move || {
            let facts = JobFacts {
                stats: &stats,
                provenance: provenance.as_deref(),
                passes: passes.as_ref(),
                render_seconds: Some(seconds),
            };
            write_final(&store, id, &spec, &tiles, &facts)
        })
        .await
        .unwrap_or_else(|e| Err(AssembleError::Transient(e.into())));
        match result {
            Ok(digest) => {
                let recorded = state
                    .with_ledger(move |l| l.finish_assembly(id, &digest))
                    .await;
                if let Err(e) = recorded {
                    tracing::error!(job = id, error = %e, "recording the end of assembly failed");
                    break;
                }
                break;
            }
            Err(AssembleError::Damaged(tiles)) => {
                let requeued = state
                    .with_ledger(move |l| l.requeue_damaged(id, &tiles))
                    .await;
                match requeued {
                    Ok(()) => state.work_available(),
                    Err(e) => {
                        tracing::error!(job = id, error = %e, "requeueing damaged tiles failed")
                    }
                }
                break;
            }
            Err(AssembleError::Transient(e)) => {
                tracing::error!(job = id, error = format!("{e:#}"), retry_in = ?delay, "assembly failed; retrying");
                tokio::select! {
                    _ = tokio::time::sleep(delay) => {}
                    _ = state.shutdown_signal() => return,
                }
                delay = (delay * 2).min(RETRY_MAX);
            }
        }
    }
    if state.ledger().job(id).is_err() {
        let _ = state.remove_job_files(id).await;
    }
}

/// A PNG preview of the given tile results (black where none arrived yet).
pub fn preview_png(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
) -> anyhow::Result<Vec<u8>> {
    Ok(frame(store, job, spec, tiles)?.0.to_png_preview_bytes()?)
}
