//! The tile driver: renders a rectangle of pixels, knowing nothing of scheduling.
//!
//! Each pixel averages `film.spp` camera samples; sample `s` of pixel `(x, y)` is jittered in
//! the pixel and driven by `Sampler::new(film.seed, x, y, s)`, so a pixel's value is the same bits
//! whichever tile, thread or worker renders it. Pixels run in parallel with rayon.
//!
//! Beside the radiance each pixel keeps its coverage (the `alpha` layer): how many of its
//! samples' camera rays hit an object (`Scene::bvh`'s first hit of the very ray the transport
//! follows), so alpha is exact in the samples taken and travels between passes as a count. With
//! `film.passes` it also sums what that first hit is ([`crate::first_hit`]): the optional passes
//! are means over the pixel's samples, as Mitsuba 3's `aov` integrator writes them, except the
//! object id, sample 0's. Without passes no sum is kept or carried.

use rayon::prelude::*;
use spindle_common::aov::{AovSet, AovSums};
use spindle_common::passes::PixelSums;
use spindle_common::scene::ADAPTIVE_BATCH;
use spindle_common::stats::RenderStats;
use spindle_common::tile::{TilePixels, TileRect};

use crate::Rgb;
use crate::first_hit::first_hit;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::transport::{Radiance, radiance};

/// The mean radiance of one pixel over its samples, the standard error of its total, its
/// coverage, and what it cost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PixelValue {
    pub radiance: Radiance,
    /// `sqrt(s² / n)` per channel, with `s²` the unbiased sample variance of the total over the
    /// pixel's `n` samples (Welford's running form); 0 when `n` = 1, where it is unknown.
    pub stderr: Rgb,
    /// The share of the samples whose camera ray hit an object, in [0, 1].
    pub alpha: f64,
    /// The sums of the optional passes (`film.passes`) and the samples they are over; `None`
    /// when the film asks for none.
    pub aov: Option<(AovSums, u32)>,
    pub stats: RenderStats,
}

/// Renders pixel `(x, y)` alone (also how `--pixel x,y` replays one pixel). With
/// `film.target_error` the pixel takes samples in batches of [`ADAPTIVE_BATCH`] until its
/// luminance's relative standard error reaches the target (or is 0), at most `film.spp`; which
/// samples it takes depends only on the pixel, so any tiling gives the same bits.
pub fn render_pixel(scene: &Scene, x: u32, y: u32) -> PixelValue {
    let mut pixel = PixelProgress::default();
    pixel.advance(scene, x, y, scene.film().spp);
    pixel.value()
}

/// A pixel's running sums between progressive passes ([`crate::frame::render_frame_passes`]).
///
/// Invariant: advancing a fresh state to cap `a`, then to `b` ≥ `a`, performs exactly the
/// floating-point operations of advancing it to `b` at once, as long as `a` is a multiple of
/// [`ADAPTIVE_BATCH`] (where the stopping rule is checked): samples are taken in index order,
/// and a pixel that met `film.target_error` takes no more. So [`PixelProgress::value`] after
/// any such sequence of caps is the bits [`render_pixel`] gives with `film.spp` = the last cap.
#[derive(Debug, Clone, Copy, Default)]
pub struct PixelProgress {
    sum: Radiance,
    // Welford: the running mean of the total and the sum of squared deviations from it, per
    // channel and for the luminance.
    mean: Rgb,
    m2: Rgb,
    mean_y: f64,
    m2_y: f64,
    taken: u32,
    /// Samples whose camera ray hit an object (≤ `taken`).
    hits: u32,
    /// The pixel met `film.target_error` at a batch boundary.
    converged: bool,
    /// The optional passes' sums, when the film asks for any.
    aov: Option<AovSums>,
    stats: RenderStats,
}

impl PixelProgress {
    /// A pixel's state resumed from its sums after an earlier pass (its statistics start at
    /// zero: the earlier pass's counters travel with that pass's tile).
    pub fn resume(sums: &PixelSums) -> PixelProgress {
        PixelProgress {
            sum: Radiance {
                surface: Rgb::from_array(sums.surface),
                single_scatter: Rgb::from_array(sums.single_scatter),
                multiple_scatter: Rgb::from_array(sums.multiple_scatter),
            },
            mean: Rgb::from_array(sums.mean),
            m2: Rgb::from_array(sums.m2),
            mean_y: sums.mean_y,
            m2_y: sums.m2_y,
            taken: sums.taken,
            hits: sums.hits,
            converged: sums.converged,
            aov: sums.aov,
            stats: RenderStats::default(),
        }
    }

    /// The running sums, to the bit, for the next pass ([`PixelProgress::resume`]).
    pub fn sums(&self) -> PixelSums {
        PixelSums {
            surface: self.sum.surface.to_array(),
            single_scatter: self.sum.single_scatter.to_array(),
            multiple_scatter: self.sum.multiple_scatter.to_array(),
            mean: self.mean.to_array(),
            m2: self.m2.to_array(),
            mean_y: self.mean_y,
            m2_y: self.m2_y,
            taken: self.taken,
            hits: self.hits,
            converged: self.converged,
            aov: self.aov,
        }
    }

    /// Samples taken so far.
    pub fn taken(&self) -> u32 {
        self.taken
    }

    /// Will [`PixelProgress::advance`] take no more samples below `cap`?
    pub fn is_done(&self, cap: u32) -> bool {
        self.converged || self.taken >= cap
    }

    /// Takes samples `taken, taken + 1, …` of pixel `(x, y)` until `cap` samples are taken or
    /// the pixel meets `film.target_error`.
    pub fn advance(&mut self, scene: &Scene, x: u32, y: u32, cap: u32) {
        let film = scene.film();
        if !film.passes.is_empty() && self.aov.is_none() {
            self.aov = Some(AovSums::default());
        }
        while !self.converged && self.taken < cap {
            let mut sampler = Sampler::new(film.seed, x, y, self.taken);
            let [u, v] = sampler.next_2d();
            let ray = scene.camera().ray(x as f64 + u, y as f64 + v);
            self.stats.camera_rays += 1;
            let hit = scene.bvh().closest_hit(&ray);
            if hit.is_some() {
                self.hits += 1;
            }
            if let Some(sums) = self.aov.as_mut() {
                sums.add(self.taken, &first_hit(scene, &ray, hit.as_ref()));
            }
            let r = radiance(scene, &ray, &mut sampler, &mut self.stats);
            self.sum.surface += r.surface;
            self.sum.single_scatter += r.single_scatter;
            self.sum.multiple_scatter += r.multiple_scatter;
            self.taken += 1;
            let taken = f64::from(self.taken);
            let total = r.total();
            let delta = total - self.mean;
            self.mean += delta / taken;
            self.m2 += delta * (total - self.mean);
            let luminance = LUMINANCE.dot(total);
            let delta_y = luminance - self.mean_y;
            self.mean_y += delta_y / taken;
            self.m2_y += delta_y * (luminance - self.mean_y);
            if let Some(target) = film.target_error
                && self.taken.is_multiple_of(ADAPTIVE_BATCH)
            {
                let stderr_y = (self.m2_y.max(0.0) / ((taken - 1.0) * taken)).sqrt();
                if stderr_y <= target * self.mean_y.abs() {
                    self.converged = true;
                }
            }
        }
    }

    /// The pixel's mean over the samples taken so far, its standard error and its cost.
    pub fn value(&self) -> PixelValue {
        let n = f64::from(self.taken.max(1));
        let stderr = if self.taken > 1 {
            (self.m2.max(Rgb::ZERO) / ((n - 1.0) * n)).map(f64::sqrt)
        } else {
            Rgb::ZERO
        };
        PixelValue {
            radiance: Radiance {
                surface: self.sum.surface / n,
                single_scatter: self.sum.single_scatter / n,
                multiple_scatter: self.sum.multiple_scatter / n,
            },
            stderr,
            alpha: f64::from(self.hits) / n,
            aov: self.aov.map(|sums| (sums, self.taken)),
            stats: self.stats,
        }
    }
}

/// Rec. 709 luminance weights of linear RGB, for the adaptive stopping rule.
const LUMINANCE: Rgb = Rgb::new(0.2126, 0.7152, 0.0722);

/// Renders the pixels of `rect`.
pub fn render_tile(scene: &Scene, rect: TileRect) -> TilePixels {
    render_tile_with_progress(scene, rect, &|_| {})
}

/// Renders the pixels of `rect`, calling `rows_done(1)` after each finished row (from any
/// thread), for progress bars.
pub fn render_tile_with_progress(
    scene: &Scene,
    rect: TileRect,
    rows_done: &(dyn Fn(u64) + Sync),
) -> TilePixels {
    let rows: Vec<Vec<PixelValue>> = (0..rect.height)
        .into_par_iter()
        .map(|row| {
            let values = (0..rect.width)
                .into_par_iter()
                .map(|col| render_pixel(scene, rect.x + col, rect.y + row))
                .collect();
            rows_done(1);
            values
        })
        .collect();
    pixels_to_tile(rect, film_passes(scene), rows.iter().flatten())
}

/// The optional passes `scene`'s film asks for.
pub fn film_passes(scene: &Scene) -> AovSet {
    AovSet::of(&scene.film().passes)
}

/// The tile of `rect` from its pixels' values, in row-major order, with the optional passes
/// `passes` ([`film_passes`] of the scene that rendered them).
pub fn pixels_to_tile<'a>(
    rect: TileRect,
    passes: AovSet,
    values: impl Iterator<Item = &'a PixelValue>,
) -> TilePixels {
    let mut tile = TilePixels::black(rect);
    if !passes.is_empty() {
        tile.aov
            .reserve(rect.pixel_count() * passes.values_per_pixel());
    }
    for (i, value) in values.enumerate() {
        let r = value.radiance;
        let total = r.total();
        for c in 0..3 {
            tile.total[3 * i + c] = total[c] as f32;
            tile.surface[3 * i + c] = r.surface[c] as f32;
            tile.single_scatter[3 * i + c] = r.single_scatter[c] as f32;
            tile.multiple_scatter[3 * i + c] = r.multiple_scatter[c] as f32;
            tile.stderr[3 * i + c] = value.stderr[c] as f32;
        }
        tile.alpha[i] = value.alpha as f32;
        if !passes.is_empty() {
            let (sums, taken) = value.aov.unwrap_or_default();
            sums.write_means(passes, taken, &mut tile.aov);
        }
        tile.stats.add(&value.stats);
    }
    tile
}
