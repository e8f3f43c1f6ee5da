//! Whether a job submission is admitted: a valid scene within the [`Limits`], a crop window
//! (if any) inside the film, with every asset it names given by hash and every OBJ asset
//! already uploaded.
//!
//! Admission reads only the request and stored assets (never a client's file paths) and
//! answers a refusal as a 400 naming the offending field. The limit on jobs queued or running
//! is checked when the job is stored ([`crate::jobs::Ledger::submit`]), under the same lock
//! as the insertion.

use std::collections::HashMap;

use spindle_common::protocol::{SubmitJob, check_crop, is_hash};
use spindle_common::scene::Shape;

use crate::assets::AssetStore;
use crate::error::Error;
use crate::limits::Limits;

/// Why a job with `film.time_budget_s` is refused: a farm job renders every tile to `spp` (or
/// `target_error`); progressive passes exist only in `spindle render --workers 0`.
pub const FARM_TIME_BUDGET: &str = "scene.film.time_budget_s: the farm does not run time \
    budgets (progressive passes are only in `spindle render --workers 0`); remove it, or set \
    film.spp to the samples a budgeted local render reached (its EXR's spindle.spp)";

/// Admits `submit` or says why not.
pub async fn admit(submit: &SubmitJob, limits: &Limits, assets: &AssetStore) -> Result<(), Error> {
    submit.scene.validate().map_err(|e| {
        Error::BadRequest(if e.path == "." {
            format!("scene: {}", e.problem)
        } else {
            format!("scene.{e}")
        })
    })?;
    if submit.scene.film.time_budget_s.is_some() {
        return Err(Error::BadRequest(FARM_TIME_BUDGET.into()));
    }
    let film = &submit.scene.film;
    if let Some(crop) = &submit.crop {
        check_crop(crop, film.width, film.height).map_err(Error::BadRequest)?;
    }
    limits
        .check_film(&submit.scene, submit.tile_size, submit.crop)
        .map_err(Error::BadRequest)?;
    for (path, hash) in &submit.assets {
        if !is_hash(hash) {
            return Err(Error::BadRequest(format!(
                "assets.{path}: {hash:?} is not a blake3 hash (64 lowercase hex digits)"
            )));
        }
        // Renewed against the sweep: the job is about to name it.
        assets.touch(hash)?;
    }
    let obj_triangles = obj_triangles(submit, assets).await?;
    limits
        .check_triangles(&submit.scene, |path| {
            obj_triangles
                .get(path)
                .copied()
                .ok_or_else(|| format!("no asset given for {path:?}"))
        })
        .map_err(Error::BadRequest)
}

/// The triangle count of each OBJ shape's asset, by the shape's path.
async fn obj_triangles(
    submit: &SubmitJob,
    assets: &AssetStore,
) -> Result<HashMap<String, u64>, Error> {
    let mut counts = HashMap::new();
    for (i, object) in submit.scene.objects.iter().enumerate() {
        if let Shape::Obj { path, .. } = &object.shape {
            let Some(hash) = submit.assets.get(path) else {
                return Err(Error::BadRequest(format!(
                    "scene.objects[{i}].shape.path: no asset given for {path:?} (add it to `assets`)"
                )));
            };
            let count = assets.obj_triangles(hash).await.map_err(|e| match e {
                Error::BadRequest(m) => Error::BadRequest(format!("assets.{path}: {m}")),
                other => other,
            })?;
            counts.insert(path.clone(), count);
        }
    }
    Ok(counts)
}
