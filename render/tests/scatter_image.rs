//! Whole-image agreement of the single-scattering integrators (issue 3): the interval method
//! against the brute-force reference, through the renderer's public tile rendering.

use spindle_common::scene::SceneDescription;
use spindle_common::tile::{TilePixels, TileRect};
use spindle_render::{Assets, Scene, render_tile};

const WIDTH: u32 = 8;
const HEIGHT: u32 = 8;

/// A small icosphere and a small bumpy sphere side by side (80 triangles each, η = 1.5, HG
/// g = 0.3, absorbing, coloured σ_t), one point light, 1 spp, only the first segment inside each
/// object (`max_depth` 1), with the given `single_scatter` settings and no multiple scattering
/// (its secondary segments would run the same, here brute-force, model: only time).
fn scene(single_scatter: &str) -> Scene {
    let json = format!(
        r#"{{
        "camera": {{ "position": [0, 0.3, 5], "look_at": [0, 0, 0], "fov_y": 36 }},
        "film": {{ "width": {WIDTH}, "height": {HEIGHT}, "spp": 1, "seed": 5 }},
        "lights": [ {{ "type": "point", "position": [1.0, 3.0, 2.0], "intensity": [20, 20, 20] }} ],
        "objects": [
            {{ "shape": {{ "type": "icosphere", "radius": 0.7, "subdivisions": 1 }},
               "transform": {{ "translate": [-0.8, 0, 0] }},
               "material": {{ "type": "dielectric", "eta": 1.5, "medium": {{
                   "sigma_t": [0.5, 1.0, 0.25], "albedo": [0.8, 0.8, 0.8],
                   "phase": {{ "type": "hg", "g": 0.3 }} }} }} }},
            {{ "shape": {{ "type": "bumpy_sphere", "radius": 0.7, "subdivisions": 1,
                          "amplitude": 0.1, "frequency": 2, "seed": 3 }},
               "transform": {{ "translate": [0.8, 0, 0] }},
               "material": {{ "type": "dielectric", "eta": 1.5, "medium": {{
                   "sigma_t": [0.5, 1.0, 0.25], "albedo": [0.8, 0.8, 0.8],
                   "phase": {{ "type": "hg", "g": 0.3 }} }} }} }}
        ],
        "integrator": {{ "max_depth": 1, "internal_reflections": 0,
                         "single_scatter": {single_scatter},
                         "multiple_scatter": {{ "max_order": 1 }} }}
    }}"#
    );
    let desc: SceneDescription = serde_json::from_str(&json).expect("test scene parses");
    Scene::build(&desc, &Assets::new()).expect("test scene builds")
}

/// Every pixel rendered as its own 1×1 tile (the same bits as any tiling), so that each pixel's
/// statistics are known.
fn render_pixels(scene: &Scene) -> Vec<TilePixels> {
    let mut pixels = Vec::new();
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let rect = TileRect {
                x,
                y,
                width: 1,
                height: 1,
            };
            pixels.push(render_tile(scene, rect));
        }
    }
    pixels
}

/// The `single_scatter` layer of the interval method (K = 8, midpoint) against the reference
/// (no pruning, 1024 stratified jittered points per segment, every solution from 16 Newton
/// starts per triangle) on an 8×8 image of both objects: 51 lit pixel channels (above 1e-3 of
/// the peak), 4 pixels whose segment crosses a fold (a volume caustic).
///
/// Measured: worst per-pixel relative difference 2.7e-2 without folds and 1.2e-1 on the pixels
/// with folds (the reference's noise there, see below), image total 3.1e-3; asserted below 6e-2,
/// 0.15 and 1e-2. The per-pixel differences are the reference's
/// noise: its integrand peaks near the volume caustics that interpolated normals make inside
/// such coarse triangles, so jittered points converge slowly. On two pixels with the largest
/// differences at M = 512 (3 %), the reference at M = 16384 came within 1.5e-4 of the interval
/// method at K = 512 (diagnostic runs, too slow for this test); the interval method's own
/// quadrature error at K = 8 is up to 1.8e-2 on a pixel with a fold (K = 256 as the yardstick),
/// where the integrand has an integrable 1/√ peak. About 20 s in the dev profile, almost all of
/// it the reference.
#[test]
fn interval_image_matches_reference_image() {
    let start = std::time::Instant::now();
    let interval = render_pixels(&scene(r#"{ "method": "interval", "k": 8 }"#));
    let interval_time = start.elapsed();
    let reference = render_pixels(&scene(
        r#"{ "method": "reference", "samples_per_segment": 1024 }"#,
    ));
    println!(
        "interval {interval_time:?}, reference {:?}",
        start.elapsed() - interval_time
    );
    let peak = reference
        .iter()
        .flat_map(|p| p.single_scatter.iter())
        .fold(0.0f32, |m, &v| m.max(v)) as f64;
    let (mut worst_smooth, mut worst_fold, mut lit, mut with_folds) = (0.0f64, 0.0f64, 0, 0);
    let (mut sum_interval, mut sum_reference) = (0.0, 0.0);
    for (i, (a, b)) in interval.iter().zip(&reference).enumerate() {
        assert_eq!(a.stats.capacity_drops, 0);
        let folds = a.stats.folds > 0;
        if folds {
            with_folds += 1;
        }
        for c in 0..3 {
            let (x, y) = (a.single_scatter[c] as f64, b.single_scatter[c] as f64);
            assert!(x.is_finite() && x >= 0.0);
            sum_interval += x;
            sum_reference += y;
            if y <= 1e-3 * peak {
                continue;
            }
            lit += 1;
            let err = (x - y).abs() / y;
            if err > 2e-2 {
                println!(
                    "pixel {i} channel {c} (folds {}): {x:e} vs {y:e} ({err:.2e})",
                    a.stats.folds
                );
            }
            if folds {
                worst_fold = worst_fold.max(err);
            } else {
                worst_smooth = worst_smooth.max(err);
            }
        }
    }
    let total = (sum_interval / sum_reference - 1.0).abs();
    println!(
        "{lit} lit pixel channels ({with_folds} pixels with folds): worst {worst_smooth:.2e} \
         without folds, {worst_fold:.2e} with; image total {total:.2e}"
    );
    assert!(
        lit >= 30 && with_folds >= 1,
        "{lit} lit, {with_folds} with folds"
    );
    // At a fold the reference's point samples carry the singular 1/D (infinite variance, log-
    // divergent), so fold pixels get a wider bound, set by the reference's noise. With the Sobol
    // sampler's camera rays, pixel 45 (red): reference M = 1024 / 16384: 1.5906e-2 / 1.4332e-2,
    // interval K = 8 / 64: 1.4077e-2 / 1.4222e-2 — the reference's M = 1024 value is 12 % off,
    // its M = 16384 value within 0.8 % of the interval method (diagnostic runs).
    assert!(
        worst_smooth < 6e-2,
        "per pixel without folds: {worst_smooth}"
    );
    assert!(worst_fold < 0.15, "per pixel with folds: {worst_fold}");
    assert!(total < 1e-2, "image total {total}");
}
