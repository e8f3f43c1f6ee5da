//! The `stderr` layer against the error it claims: the spread of a pixel's value over
//! independent renders (other seeds) of the same scene.

#[path = "support/penumbra.rs"]
mod penumbra;
mod support;

use serde_json::json;
use spindle_common::tile::TileRect;
use spindle_render::tile::render_pixel;
use spindle_render::{Assets, Scene, render_tile};

/// The penumbra scene, 6 × 6 pixels.
fn penumbra_scene(seed: u64, spp: u32, target_error: Option<f64>) -> Scene {
    penumbra::scene(
        25.0,
        json!({"width": 6, "height": 6, "spp": spp, "seed": seed, "target_error": target_error}),
    )
}

const WHOLE: TileRect = TileRect {
    x: 0,
    y: 0,
    width: 6,
    height: 6,
};

/// The penumbra scene at 16 spp, rendered with 48 seeds. Per pixel and channel, the measured error is the standard deviation of the total
/// over the seeds; the claimed one is the root mean square of the `stderr` layer over the seeds.
///
/// Samples are stratified (Sobol pairs), which makes the error of a mean smaller than the
/// independent-sample formula says, so `stderr` may only over-state it: the measured error,
/// summed over the pixels, must lie between 0.3 and 1.15 times the claimed one (1.15 allows for
/// the estimate's own spread over 48 seeds and 108 values: about 2 %).
#[test]
fn stderr_does_not_understate_the_error() {
    let seeds = 48u64;
    let renders: Vec<_> = (0..seeds)
        .map(|seed| render_tile(&penumbra_scene(seed, 16, None), WHOLE))
        .collect();
    let values = renders[0].total.len();
    let (mut measured, mut claimed) = (0.0, 0.0);
    for i in 0..values {
        let mean = renders.iter().map(|r| f64::from(r.total[i])).sum::<f64>() / seeds as f64;
        let variance = renders
            .iter()
            .map(|r| (f64::from(r.total[i]) - mean).powi(2))
            .sum::<f64>()
            / (seeds - 1) as f64;
        let claimed_variance = renders
            .iter()
            .map(|r| f64::from(r.stderr[i]).powi(2))
            .sum::<f64>()
            / seeds as f64;
        measured += variance.sqrt();
        claimed += claimed_variance.sqrt();
    }
    let ratio = measured / claimed;
    println!(
        "stderr: measured error over {seeds} seeds / claimed = {ratio:.3} \
         (mean claimed {:.3e}, mean measured {:.3e})",
        claimed / values as f64,
        measured / values as f64
    );
    assert!(claimed > 0.0);
    assert!(
        (0.3..=1.15).contains(&ratio),
        "measured / claimed = {ratio}"
    );
}

/// With one sample per pixel the error cannot be estimated: the layer is 0, not a guess.
#[test]
fn one_sample_gives_no_estimate() {
    let desc = serde_json::from_value(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 3, "height": 3, "spp": 1},
        "lights": [{"type": "sphere", "center": [0, 0, 3], "radius": 0.5, "radiance": [1, 1, 1]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 1},
                     "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}}]
    }))
    .unwrap();
    let scene = Scene::build(&desc, &Assets::new()).unwrap();
    let tile = render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: 3,
            height: 3,
        },
    );
    assert!(tile.total.iter().any(|&v| v > 0.0));
    assert!(tile.stderr.iter().all(|&v| v == 0.0));
}

/// Adaptive sampling (`film.target_error` 0.06, at most 256 samples), 16 seeds: over the pixels
/// that stopped before the cap, the root mean square of the measured relative error of the
/// luminance (its spread over the seeds) is within the target, and no pixel is far above it
/// (1.6×: the spread of a standard deviation estimated from 16 seeds is about 18 %); the pixels
/// take different numbers of samples, fewer in all than the cap; and a pixel is the same bits
/// rendered alone or in its tile.
#[test]
fn adaptive_sampling_stops_at_the_target() {
    let (target, cap, seeds) = (0.06, 256u32, 16u64);
    let mut luminance = vec![Vec::new(); 36];
    let mut taken = vec![0u64; 36];
    for seed in 0..seeds {
        let scene = penumbra_scene(seed, cap, Some(target));
        let pixels: Vec<_> = (0..36u32)
            .map(|i| render_pixel(&scene, i % 6, i / 6))
            .collect();
        if seed == 0 {
            let tile = render_tile(&scene, WHOLE);
            for (i, p) in pixels.iter().enumerate() {
                let total = p.radiance.total();
                assert_eq!(total.x as f32, tile.total[3 * i], "pixel {i} differs alone");
            }
        }
        for (i, p) in pixels.iter().enumerate() {
            let total = p.radiance.total();
            luminance[i].push(0.2126 * total.x + 0.7152 * total.y + 0.0722 * total.z);
            taken[i] += p.stats.camera_rays;
        }
    }
    let mut squares = Vec::new();
    for (values, &n) in luminance.iter().zip(&taken) {
        let mean = values.iter().sum::<f64>() / seeds as f64;
        if n == u64::from(cap) * seeds || mean <= 0.0 {
            continue;
        }
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
        squares.push(variance / (mean * mean));
    }
    let rms = (squares.iter().sum::<f64>() / squares.len() as f64).sqrt();
    let worst = squares.iter().fold(0.0f64, |a, &b| a.max(b)).sqrt();
    let total: u64 = taken.iter().sum();
    let (fewest, most) = (taken.iter().min().unwrap(), taken.iter().max().unwrap());
    println!(
        "target {target}: measured relative error over the {} pixels that stopped early: rms \
         {rms:.4}, worst {worst:.4}; samples per pixel {:.0}–{:.0}, mean {:.0} of {cap}",
        squares.len(),
        *fewest as f64 / seeds as f64,
        *most as f64 / seeds as f64,
        total as f64 / (36 * seeds) as f64
    );
    assert!(squares.len() >= 12, "too few pixels stopped early to judge");
    assert!(rms <= target, "rms relative error {rms} > {target}");
    assert!(worst <= 1.6 * target, "a pixel stopped with error {worst}");
    assert!(fewest < most, "every pixel took the same number of samples");
    assert!(total < u64::from(cap) * 36 * seeds);
}
