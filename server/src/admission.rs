//! Whether a job submission is admitted: a valid scene within the [`Limits`], a crop window
//! (if any) inside the film, with every asset it names given by hash and every OBJ asset
//! already uploaded.
//!
//! An OBJ asset is checked as a worker's build would check it: its faces and vertices
//! (`count_obj_triangles`), and its vertices placed by its object's transform within the scene's
//! extent (`check_obj_placement`), so a scene no worker can build is refused here, not at the
//! first lease.
//!
//! Admission reads only the request and stored assets (never a client's file paths) and
//! answers a refusal as a 400 naming the offending field. The limit on jobs queued or running
//! is checked when the job is stored ([`crate::ledger::Ledger::submit`]), under the same lock
//! as the insertion.

use std::collections::HashMap;

use spindle_common::passes::MAX_PASS_TILE_SIZE;
use spindle_common::protocol::{SubmitJob, check_crop, is_hash};
use spindle_common::scene::Shape;
use spindle_common::validate::{MAX_FRAME, surely_within_extent};

use crate::assets::AssetStore;
use crate::error::Error;
use crate::limits::Limits;

/// Admits `submit` or says why not.
pub async fn admit(submit: &SubmitJob, limits: &Limits, assets: &AssetStore) -> Result<(), Error> {
    submit.scene.validate().map_err(|e| {
        Error::BadRequest(if e.path == "." {
            format!("scene: {}", e.problem)
        } else {
            format!("scene.{e}")
        })
    })?;
    match (&submit.scene.animation, submit.frame) {
        (Some(_), None) => {
            return Err(Error::BadRequest(
                "frame: a scene with `animation` needs the frame the job renders (`spindle \
                 submit --frames N` sends it)"
                    .into(),
            ));
        }
        (_, Some(frame)) if frame > MAX_FRAME => {
            return Err(Error::BadRequest(format!(
                "frame: must be at most {MAX_FRAME}, got {frame}"
            )));
        }
        _ => {}
    }
    let film = &submit.scene.film;
    if film.time_budget_s.is_some() && submit.tile_size > MAX_PASS_TILE_SIZE {
        return Err(Error::BadRequest(format!(
            "tile_size: {} is too large for a job with scene.film.time_budget_s, whose tiles \
             carry each pixel's running sums between passes: at most {MAX_PASS_TILE_SIZE}",
            submit.tile_size
        )));
    }
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

/// The triangle count of each OBJ shape's asset, by the shape's path, once each shape's
/// transform is known to keep the file's vertices within the scene's extent (as a worker's
/// build checks them, [`spindle_common::validate::check_obj_placement`]).
async fn obj_triangles(
    submit: &SubmitJob,
    assets: &AssetStore,
) -> Result<HashMap<String, u64>, Error> {
    let mut counts = HashMap::new();
    // Placed as the workers place them: at the job's frame.
    let still = match submit.frame {
        Some(frame) => submit.scene.at_frame(frame),
        None => submit.scene.clone(),
    };
    for (i, object) in still.objects.iter().enumerate() {
        if let Shape::Obj { path, .. } = &object.shape {
            let Some(hash) = submit.assets.get(path) else {
                return Err(Error::BadRequest(format!(
                    "scene.objects[{i}].shape.path: no asset given for {path:?} (add it to `assets`)"
                )));
            };
            let in_asset = |e| match e {
                Error::BadRequest(m) => Error::BadRequest(format!("assets.{path}: {m}")),
                other => other,
            };
            let summary = assets.obj_summary(hash).await.map_err(in_asset)?;
            if !surely_within_extent(&object.transform, summary.radius) {
                assets
                    .check_obj_placement(hash, object.transform.clone())
                    .await
                    .map_err(|e| match e {
                        Error::BadRequest(m) => {
                            Error::BadRequest(format!("scene.objects[{i}].transform: {path}: {m}"))
                        }
                        other => other,
                    })?;
            }
            counts.insert(path.clone(), summary.triangles);
        }
    }
    Ok(counts)
}
