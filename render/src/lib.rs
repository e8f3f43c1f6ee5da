//! The renderer: a pure library, scene in, pixels out.
//!
//! [`Scene::build`] validates a scene description and the bytes of its meshes into world-space
//! geometry with BVHs; [`render_tile`] renders a rectangle of it. Nothing here opens a file or a
//! socket or starts a runtime (this crate depends on no I/O or async crate), and a pixel's value depends only on
//! (scene, seed, pixel, sample).

#![forbid(unsafe_code)]

pub mod bvh;
pub mod camera;
pub mod contact;
pub mod containment;
pub mod crossing;
pub mod first_hit;
pub mod flat_face;
pub mod frame;
pub mod fresnel;
pub mod interfaces;
pub mod light;
pub mod medium;
pub mod mesh;
pub mod mistakes;
pub mod multiple_scatter;
pub mod nesting;
pub mod obj;
pub mod procedural;
pub mod provenance;
pub mod ray;
pub mod rgb;
pub mod sampler;
pub mod scatter;
pub mod scene;
pub mod segment;
pub mod tile;
pub mod tile_pass;
pub mod transform;
pub mod transport;
pub mod wavy_box;

pub use frame::{
    FrameSoFar, PASS_SPP, PassReport, render_frame, render_frame_passes, render_frame_until,
};
pub use provenance::provenance;
pub use rgb::Rgb;
pub use scene::{Assets, Scene};
pub use spindle_common::validate::SceneError;
pub use tile::{
    PixelProgress, PixelValue, film_passes, pixels_to_tile, render_pixel, render_tile,
    render_tile_with_progress,
};
pub use tile_pass::{PassError, render_tile_pass};
