//! Reading a scene from disk: the JSON file and the OBJ files it names (relative to it).
//!
//! The one place a scene's paths become bytes, shared by the `spindle` command and the
//! benchmarks; the renderer takes the bytes and reads no files.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::scene::{SceneDescription, Shape};
use crate::validate::SceneError;

/// A scene file and its meshes.
pub struct SceneFiles {
    pub desc: SceneDescription,
    /// The bytes of every OBJ file the scene names, keyed by the path as written in the scene
    /// (the shape `spindle_render::Assets` aliases).
    pub assets: HashMap<String, Vec<u8>>,
}

/// Why a scene could not be read. Each variant names the file; the source says what failed.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    #[error("cannot read scene file {}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("invalid scene {}", path.display())]
    Invalid { path: PathBuf, source: SceneError },
    /// `index` is the object whose `shape.path` names `file`.
    #[error("objects[{index}].shape.path: cannot read {}", file.display())]
    Mesh {
        index: usize,
        file: PathBuf,
        source: std::io::Error,
    },
}

/// Reads and parses `path`, then reads every OBJ it refers to, relative to the scene file's
/// directory (each file once, however many objects name it).
pub fn load_scene(path: &Path) -> Result<SceneFiles, SceneFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneFileError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let desc = SceneDescription::from_json(&text).map_err(|source| SceneFileError::Invalid {
        path: path.to_path_buf(),
        source,
    })?;
    let mut assets = HashMap::new();
    read_meshes(path, &desc, &mut assets)?;
    Ok(SceneFiles { desc, assets })
}

/// Reads every OBJ that `desc` names and `assets` lacks, relative to the directory of the scene
/// file `path` (after a scene is edited, say `--set objects[0].shape.path=…`).
pub fn read_meshes(
    path: &Path,
    desc: &SceneDescription,
    assets: &mut HashMap<String, Vec<u8>>,
) -> Result<(), SceneFileError> {
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    for (index, object) in desc.objects.iter().enumerate() {
        if let Shape::Obj { path: obj, .. } = &object.shape {
            if assets.contains_key(obj) {
                continue;
            }
            let file = base.join(obj);
            let bytes = std::fs::read(&file).map_err(|source| SceneFileError::Mesh {
                index,
                file: file.clone(),
                source,
            })?;
            assets.insert(obj.clone(), bytes);
        }
    }
    Ok(())
}
