//! Scene importers: files other tools write, converted to spindle's own scene
//! ([`spindle_common::scene::SceneDescription`] and the bytes of the meshes it names), so every
//! validation rule and limit of a spindle scene applies to them unchanged and the coordinator
//! never sees the foreign format.
//!
//! Today one format: glTF 2.0 (`.gltf`, `.glb`), read with the `gltf` crate
//! ([`import_gltf`]). `scenes/README.md` ("glTF scenes") says what maps to what.
#![forbid(unsafe_code)]

pub mod animation;
pub mod buffers;
pub mod camera;
pub mod error;
pub mod gltf_file;
pub mod hierarchy;
pub mod ignored;
pub mod lights;
pub mod material;
pub mod mesh;
pub mod obj_text;

pub use error::ImportError;
pub use gltf_file::{Imported, Options, import_gltf};

/// Whether `path` names a glTF file (`.gltf` or `.glb`, any case), which [`import_gltf`] reads;
/// anything else is a spindle scene JSON.
pub fn is_gltf(path: &std::path::Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}
