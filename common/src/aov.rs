//! The optional passes of `film.passes` (arbitrary output variables, AOVs): per pixel, what the
//! first surface its camera rays hit is — how far, which way it faces, its colour and which
//! object — beside the radiance layers, for a compositor (depth of field, relighting, isolating
//! one glass object) and a denoiser (the albedo and normal guides OIDN and OptiX take).
//!
//! Conventions, stated once (scenes/README.md says them to users):
//! - `depth`, `normal` and `albedo` are the mean over the pixel's samples, a sample whose camera
//!   ray hits nothing counting 0 — as Mitsuba 3's `aov` integrator writes them — so at a
//!   silhouette they are premultiplied by the coverage `A`, like the colour.
//! - `depth` is the camera-space depth of the first hit, the distance along the camera's viewing
//!   axis (planar: a plane facing the camera has one depth), as RenderMan's `z` and Arnold's `Z`
//!   are and Nuke's ZDefocus reads with `math` = `depth`; EXR channel `Z`, which Nuke shows as
//!   `depth.Z`.
//! - `normal` is the world-space shading normal of the first hit, pointing out of the object
//!   (`normal.X/Y/Z`).
//! - `albedo` is the first hit's diffuse reflectance for a diffuse object and 1 (white) for a
//!   dielectric, as OIDN's documentation asks of perfectly specular glass (`albedo.R/G/B`).
//! - `id` is the index of the first object hit + 1 (0: the background), not averaged: the value
//!   of the pixel's first sample (sample 0), as Arnold's closest filter keeps one sample's id
//!   rather than blending two objects' numbers into a third's (`id.id`; exact in f32 for every
//!   possible object count).
//!
//! A tile or an image holds the chosen passes' values per pixel, in [`Aov::ALL`] order,
//! interleaved (`pixel * values_per_pixel + offset`); with no pass chosen it holds none.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// One optional pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Aov {
    /// Camera-space depth of the first hit (EXR `Z`).
    Depth,
    /// World-space shading normal of the first hit (`normal.X/Y/Z`).
    Normal,
    /// Diffuse colour of the first hit; 1 for a dielectric (`albedo.R/G/B`).
    Albedo,
    /// The first sample's object index + 1, 0 for the background (`id.id`).
    Id,
}

impl Aov {
    /// Every pass, in the order a pixel's values hold them.
    pub const ALL: [Aov; 4] = [Aov::Depth, Aov::Normal, Aov::Albedo, Aov::Id];

    /// The name `film.passes` lists it by.
    pub fn name(self) -> &'static str {
        match self {
            Aov::Depth => "depth",
            Aov::Normal => "normal",
            Aov::Albedo => "albedo",
            Aov::Id => "id",
        }
    }

    /// Its EXR channels, Nuke's `layer.channel` names (`Z` alone is read as `depth.Z`).
    pub fn exr_channels(self) -> &'static [&'static str] {
        match self {
            Aov::Depth => &["Z"],
            Aov::Normal => &["normal.X", "normal.Y", "normal.Z"],
            Aov::Albedo => &["albedo.R", "albedo.G", "albedo.B"],
            Aov::Id => &["id.id"],
        }
    }

    /// Values per pixel.
    pub fn channels(self) -> usize {
        self.exr_channels().len()
    }

    fn bit(self) -> u8 {
        1 << Aov::ALL.iter().position(|&a| a == self).unwrap_or(0)
    }
}

/// The most values a pixel has over all passes.
pub const MAX_VALUES_PER_PIXEL: usize = 8;

/// The passes a film asks for, in [`Aov::ALL`] order whatever order the scene lists them in.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct AovSet(u8);

impl AovSet {
    /// No pass: what a film without `passes` writes.
    pub const NONE: AovSet = AovSet(0);

    /// The set of the listed passes (a pass listed twice is in it once; validation refuses that).
    pub fn of(list: &[Aov]) -> AovSet {
        AovSet(list.iter().fold(0, |bits, a| bits | a.bit()))
    }

    pub fn contains(self, aov: Aov) -> bool {
        self.0 & aov.bit() != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The passes in the set, in [`Aov::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Aov> {
        Aov::ALL.into_iter().filter(move |&a| self.contains(a))
    }

    /// Values per pixel over the passes of the set.
    pub fn values_per_pixel(self) -> usize {
        self.iter().map(Aov::channels).sum()
    }

    /// Each EXR channel of the set, with its pass, in the order a pixel's values hold them.
    pub fn exr_channels(self) -> impl Iterator<Item = (Aov, &'static str)> {
        self.iter()
            .flat_map(|a| a.exr_channels().iter().map(move |&name| (a, name)))
    }
}

/// What one sample's camera ray saw first; all zero where it hit nothing.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FirstHit {
    pub depth: f64,
    pub normal: [f64; 3],
    pub albedo: [f64; 3],
    /// Object index + 1; 0 for the background.
    pub id: u32,
}

/// A pixel's running sums of the passes between progressive passes (part of
/// [`crate::passes::PixelSums`] when the film asks for passes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AovSums {
    /// Σ of the samples' depths.
    pub depth: f64,
    /// Σ of the samples' normals.
    pub normal: [f64; 3],
    /// Σ of the samples' albedos.
    pub albedo: [f64; 3],
    /// Sample 0's id.
    pub id: u32,
}

impl AovSums {
    /// Adds sample `index`'s first hit (its id is kept only for sample 0).
    pub fn add(&mut self, index: u32, hit: &FirstHit) {
        self.depth += hit.depth;
        for c in 0..3 {
            self.normal[c] += hit.normal[c];
            self.albedo[c] += hit.albedo[c];
        }
        if index == 0 {
            self.id = hit.id;
        }
    }

    /// The pixel's values of the passes in `set` after `taken` samples, appended to `out` in
    /// the set's order.
    pub fn write_means(&self, set: AovSet, taken: u32, out: &mut Vec<f32>) {
        let n = f64::from(taken.max(1));
        for aov in set.iter() {
            match aov {
                Aov::Depth => out.push((self.depth / n) as f32),
                Aov::Normal => out.extend(self.normal.map(|v| (v / n) as f32)),
                Aov::Albedo => out.extend(self.albedo.map(|v| (v / n) as f32)),
                Aov::Id => out.push(self.id as f32),
            }
        }
    }

    /// The canonical bytes of the sums, little-endian in field order (f64 bits, `id` as u32).
    pub fn canonical_bytes(&self, out: &mut Vec<u8>) {
        for v in std::iter::once(&self.depth)
            .chain(&self.normal)
            .chain(&self.albedo)
        {
            out.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        out.extend_from_slice(&self.id.to_le_bytes());
    }
}

#[cfg(test)]
mod tests;
