//! Types shared by every spindle process: the scene format, the job and tile protocol, and
//! image files. Nothing here renders or talks to the network; it is the vocabulary the
//! renderer, the coordinator, the worker process and the `spindle` command have in common.
#![forbid(unsafe_code)]

pub mod animation;
pub mod aov;
pub mod atomic_write;
pub mod camera_matrices;
pub mod header;
pub mod image;
pub mod noise;
pub mod passes;
pub mod protocol;
pub mod provenance;
pub mod scene;
pub mod scene_files;
pub mod scene_override;
pub mod stats;
pub mod tile;
pub mod tile_encoding;
pub mod transform;
pub mod validate;
