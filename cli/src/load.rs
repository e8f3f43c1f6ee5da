//! Reading a scene from disk: the JSON file and the OBJ files it names (relative to it).
//!
//! This is the only place the `spindle` command turns paths into bytes for the renderer; the
//! renderer itself reads no files.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use spindle_common::scene::{SceneDescription, Shape};
use spindle_render::Assets;

/// A scene file and its meshes.
pub struct SceneFiles {
    pub desc: SceneDescription,
    pub assets: Assets,
}

/// Reads and parses `path`, then reads every OBJ it refers to, relative to the scene file's
/// directory. Errors name the file (and, for JSON, the path of the bad value).
pub fn load_scene(path: &Path) -> Result<SceneFiles> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read scene file {}", path.display()))?;
    let desc = SceneDescription::from_json(&text)
        .with_context(|| format!("invalid scene {}", path.display()))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut assets = Assets::new();
    for (i, object) in desc.objects.iter().enumerate() {
        if let Shape::Obj { path: obj } = &object.shape {
            if assets.contains_key(obj) {
                continue;
            }
            let file: PathBuf = base.join(obj);
            let bytes = std::fs::read(&file).with_context(|| {
                format!("objects[{i}].shape.path: cannot read {}", file.display())
            })?;
            assets.insert(obj.clone(), bytes);
        }
    }
    Ok(SceneFiles { desc, assets })
}
