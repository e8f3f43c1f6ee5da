//! The final image of a job, and its preview: finished tiles read back from the store and placed
//! into one image of the job's window (the film, or its crop: then the EXR's data window is
//! the crop inside the film's display window, as `render --workers 0 --crop` writes it).
//!
//! Tiles are inserted in tile index order and the EXR writer's bytes depend only on the image,
//! so the file does not depend on which worker rendered which tile or in what order tiles
//! arrived. The header carries the film's settings, the summed render statistics
//! (`spindle.stats.<counter>`) and the job's provenance as its workers reported it (renderer,
//! objects, triangles, lights, warnings, the single-scattering plan:
//! `Provenance::header_attributes`), the same names and values `spindle render --workers 0`
//! writes.
//!
//! Assembly never fails a job whose tiles are all in: a stored tile found damaged (missing,
//! truncated, altered) goes back to the queue to be rendered again, and any other error (I/O,
//! a full disk) is retried with backoff until it passes; a restarted coordinator resumes. A
//! budgeted job's tiles are all in at the end of each of its passes: [`finish`] first ends the
//! pass (the same backoff, a bounded number of times: [`crate::passes`]), and assembles only
//! after the last. Only [`finish`] is async; the rest blocks and runs under `spawn_blocking`.

use std::time::Duration;

use spindle_common::image::Image;
use spindle_common::protocol::{JobSpec, PassInfo};
use spindle_common::provenance::Provenance;
use spindle_common::stats::RenderStats;

use crate::AppState;
use crate::error::Error;
use crate::passes::{PASS_END_ATTEMPTS, PassEnd};
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
    let mut image = Image::window(film.width, film.height, spec.window())?;
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

/// The EXR header attributes of a finished job.
pub fn attributes(
    spec: &JobSpec,
    stats: &RenderStats,
    provenance: Option<&Provenance>,
    passes: Option<&PassInfo>,
) -> anyhow::Result<Vec<(String, String)>> {
    let film = &spec.scene.film;
    let window = spec.window();
    let mut attributes = vec![
        ("spindle.spp".to_string(), film.spp.to_string()),
        ("spindle.seed".to_string(), film.seed.to_string()),
        (
            "spindle.region".to_string(),
            format!(
                "{},{},{},{}",
                window.x, window.y, window.width, window.height
            ),
        ),
        (
            "spindle.integrator".to_string(),
            serde_json::to_string(&spec.scene.integrator)?,
        ),
    ];
    for (name, value) in stats.entries() {
        attributes.push((format!("spindle.stats.{name}"), value.to_string()));
    }
    if let Some(provenance) = provenance {
        attributes.extend(provenance.header_attributes());
    }
    // A job with a time budget: how many passes reached `spindle.spp` (the job's spp by then).
    if let Some(passes) = passes {
        attributes.push(("spindle.passes".to_string(), passes.pass.to_string()));
        attributes.push((
            "spindle.time_budget_s".to_string(),
            passes.budget_s.to_string(),
        ));
    }
    Ok(attributes)
}

/// Writes the final EXR of a job whose tiles are all in, atomically; returns the SHA-256 of
/// its bytes (hex), which clients check it by.
pub fn write_final(
    store: &TileStore,
    job: u64,
    spec: &JobSpec,
    tiles: &[(u32, String)],
    stats: &RenderStats,
    provenance: Option<&Provenance>,
    passes: Option<&PassInfo>,
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
    image
        .attributes
        .extend(attributes(spec, stats, provenance, passes)?);
    let bytes = image.to_exr_bytes().map_err(anyhow::Error::from)?;
    std::fs::create_dir_all(store.job_dir(job)).map_err(anyhow::Error::from)?;
    spindle_common::atomic_write::write(store.image_path(job), &bytes)
        .map_err(anyhow::Error::from)?;
    Ok(sha256_hex(&bytes))
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
/// ([`crate::jobs::Ledger::end_of_pass`]), retrying an error with backoff; after
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
                        (job.spec.clone(), job.stats, job.provenance.clone(), passes)
                    })
                    .and_then(|(spec, stats, provenance, passes)| {
                        Some((spec, stats, provenance, passes, ledger.done_tiles(id).ok()?))
                    }))
            })
            .await
            .ok()
            .flatten();
        let Some((spec, stats, provenance, passes, tiles)) = prepared else {
            return; // Deleted or cancelled meanwhile.
        };
        let store = state.tile_store().clone();
        let result = tokio::task::spawn_blocking(move || {
            write_final(
                &store,
                id,
                &spec,
                &tiles,
                &stats,
                provenance.as_deref(),
                passes.as_ref(),
            )
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
