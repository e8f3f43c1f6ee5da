//! Progressive passes (`film.time_budget_s`): a render stopped after `k` passes is, bit for bit,
//! the one-pass render of `film.spp` = `k · PASS_SPP` through the tile driver — which is what
//! lets `spindle render --workers 0 --no-time-budget --spp N` reproduce a budgeted image.

#[path = "support/penumbra.rs"]
mod penumbra;
mod support;

use serde_json::json;
use spindle_common::tile::{TilePixels, TileRect};
use spindle_common::tile_encoding;
use spindle_render::{
    PASS_SPP, Scene, render_frame, render_frame_passes, render_tile, render_tile_pass,
};

/// The penumbra scene, 10 × 7 pixels, with a time budget.
fn scene(spp: u32, target_error: Option<f64>) -> Scene {
    penumbra::scene(
        30.0,
        json!({"width": 10, "height": 7, "spp": spp, "seed": 5, "target_error": target_error,
               "time_budget_s": 1.0}),
    )
}

/// The sub-rectangle rendered: not at the origin, so the pixel coordinates are checked too.
const REGION: TileRect = TileRect {
    x: 1,
    y: 2,
    width: 8,
    height: 5,
};

/// `a` and `b` (an image's or a tile's layers) hold the same bits.
fn same_bits(a: [&[f32]; 6], b: [&[f32]; 6], what: &str) {
    for (layer, (x, y)) in a.iter().zip(b).enumerate() {
        let differ = x
            .iter()
            .zip(y)
            .filter(|(p, q)| p.to_bits() != q.to_bits())
            .count();
        assert_eq!(differ, 0, "{what}: layer {layer}: {differ} values differ");
    }
}

/// Stopped after 1, 2 and 3 passes, with and without adaptive sampling: the image and the
/// statistics are those of `render_frame` at 16, 32, 48 spp.
#[test]
fn stopping_after_k_passes_is_rendering_k_times_pass_spp() {
    for target_error in [None, Some(0.08)] {
        for stop_after in 1..=3u32 {
            let budgeted = scene(200, target_error);
            let mut seen = Vec::new();
            let (image, stats, report) = render_frame_passes(&budgeted, REGION, &mut |r| {
                seen.push(r.passes);
                r.passes < stop_after
            })
            .unwrap();
            assert_eq!(seen, (1..=stop_after).collect::<Vec<_>>());
            assert_eq!(report.passes, stop_after);
            assert_eq!(report.spp, stop_after * PASS_SPP);
            let reference = scene(stop_after * PASS_SPP, target_error);
            let (expected, expected_stats) = render_frame(&reference, REGION, &|_| {}).unwrap();
            let what = format!("target {target_error:?}, {stop_after} passes");
            same_bits(image.layers(), expected.layers(), &what);
            assert_eq!(stats, expected_stats, "{what}");
            // Every camera ray is a sample taken: without a target every pixel took them all.
            if target_error.is_none() {
                let pixels = REGION.pixel_count() as u64;
                assert_eq!(stats.camera_rays, pixels * u64::from(report.spp), "{what}");
            }
        }
    }
}

/// Left to run, the passes end at `film.spp` even when it is not a multiple of the pass size,
/// without asking the caller after the last pass, and the image is the one-pass render's.
#[test]
fn passes_end_at_spp() {
    let spp = 2 * PASS_SPP + 5;
    let budgeted = scene(spp, None);
    let mut asked = 0;
    let (image, _, report) = render_frame_passes(&budgeted, REGION, &mut |r| {
        asked += 1;
        assert!(r.pixels_sampling == REGION.pixel_count(), "{r:?}");
        true
    })
    .unwrap();
    assert_eq!(
        (report.passes, report.spp, report.pixels_sampling),
        (3, spp, 0)
    );
    assert_eq!(asked, 2);
    let (expected, _) = render_frame(&scene(spp, None), REGION, &|_| {}).unwrap();
    same_bits(image.layers(), expected.layers(), "to spp");
}

/// With a target every pixel meets early (a loose 0.9), the passes stop by themselves once no
/// pixel samples any more, far below `spp`.
#[test]
fn passes_end_when_every_pixel_met_the_target() {
    let budgeted = scene(4096, Some(0.9));
    let (_, stats, report) = render_frame_passes(&budgeted, REGION, &mut |_| true).unwrap();
    assert_eq!(report.pixels_sampling, 0);
    assert!(report.spp < 4096, "{report:?}");
    assert!(stats.camera_rays <= REGION.pixel_count() as u64 * u64::from(report.spp));
}

/// On the farm a tile's passes run one at a time, each continuing from the previous pass's
/// result as it travels (the compact encoding of uploads and stored tiles): after `k` passes
/// the tile is, pixels and statistics, `render_tile` at `spp` = `min(16 k, film.spp)`, with and
/// without adaptive sampling, up to a last pass that is not a whole 16 samples.
#[test]
fn a_tile_continued_pass_by_pass_is_the_one_pass_tile() {
    let spp = 2 * PASS_SPP + 5;
    for target_error in [None, Some(0.08)] {
        let budgeted = scene(spp, target_error);
        let mut previous: Option<TilePixels> = None;
        for pass in 1..=3u32 {
            let tile = render_tile_pass(&budgeted, REGION, pass, previous.as_ref()).unwrap();
            let bytes = tile_encoding::encode(&tile).unwrap();
            let tile: TilePixels = tile_encoding::decode(&bytes, 1 << 24).unwrap();
            let cap = (pass * PASS_SPP).min(spp);
            let progress = tile.progress.as_ref().unwrap();
            assert_eq!((progress.pass, progress.spp), (pass, cap));
            let expected = render_tile(&scene(cap, target_error), REGION);
            let what = format!("target {target_error:?}, pass {pass}");
            same_bits(tile.layers(), expected.layers(), &what);
            assert_eq!(tile.stats, expected.stats, "{what}");
            previous = Some(tile);
        }
    }
}

/// A pass that does not follow the given result (wrong pass, wrong tile, no state, a first
/// pass given one) is refused with the reason, not rendered.
#[test]
fn a_pass_that_does_not_follow_its_previous_result_is_refused() {
    let budgeted = scene(64, None);
    let first = render_tile_pass(&budgeted, REGION, 1, None).unwrap();
    let refused = |pass: u32, previous: Option<&TilePixels>, says: &str| {
        let e = render_tile_pass(&budgeted, REGION, pass, previous)
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "pass {pass}: {e}");
    };
    refused(0, None, "numbered from 1");
    refused(2, None, "missing");
    refused(1, Some(&first), "starts from no samples");
    refused(3, Some(&first), "is pass 1 at 16 spp, not pass 2 at 32");
    let mut moved = first.clone();
    moved.rect.x += 1;
    refused(2, Some(&moved), "the earlier result is of the tile of");
    let mut stateless = first.clone();
    stateless.progress = None;
    refused(2, Some(&stateless), "carries no pass state");
    let mut short = first;
    short.progress.as_mut().unwrap().pixels.pop();
    refused(2, Some(&short), "pixel states for 40 pixels");
}
