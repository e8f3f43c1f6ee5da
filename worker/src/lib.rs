//! The spindle renderer, as a pure library (scene in, pixels out), and the farm worker process.
#![forbid(unsafe_code)]

pub mod farm;
pub mod render;
