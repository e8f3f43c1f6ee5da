//! Where `spindle render` and `spindle submit` get a scene: a spindle scene JSON with its OBJ
//! files (`common::scene_files`), or a glTF 2.0 file (`.gltf`, `.glb`) converted here by
//! `spindle_import` into the same scene and OBJ assets, so the farm only ever sees spindle
//! scenes and every rule and limit applies alike.

use std::path::Path;

use anyhow::{Context, Result, bail};
use spindle_common::scene_files::{SceneFiles, load_scene};

/// Reads the scene at `path`. `camera` picks a glTF file's camera by name (refused for a
/// JSON scene, which has one camera); the importer's warnings (what the file holds that spindle
/// does not render) are printed on stderr when `warn`.
pub fn load(path: &Path, camera: Option<&str>, warn: bool) -> Result<SceneFiles> {
    if !spindle_import::is_gltf(path) {
        if camera.is_some() {
            bail!(
                "--camera: {} is a spindle scene, which has one camera; --camera picks a glTF \
                 file's (.gltf, .glb)",
                path.display()
            );
        }
        return Ok(load_scene(path)?);
    }
    let options = spindle_import::Options {
        camera: camera.map(str::to_string),
    };
    let imported = spindle_import::import_gltf(path, &options)
        .with_context(|| format!("cannot import {}", path.display()))?;
    if warn {
        for warning in &imported.warnings {
            eprintln!("warning: {warning}");
        }
    }
    Ok(imported.files)
}
