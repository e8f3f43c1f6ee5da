//! The `alpha` layer against a silhouette known in closed form: a sphere on the camera's axis,
//! whose outline in the image is a circle, read back from the EXR file the image is written as.

use serde_json::json;
use spindle_common::image::Image;
use spindle_common::tile::TileRect;
use spindle_render::{Assets, Scene, render_frame, render_frame_passes};

const SIZE: u32 = 32;
const FOV_Y: f64 = 40.0;
/// The camera's distance from the centre of the unit sphere.
const DISTANCE: f64 = 5.0;

/// A diffuse unit sphere (an icosphere of 20·4⁴ triangles, whose outline lies within 0.006
/// pixels of the sphere's) at the origin, seen from `DISTANCE` along +z, `SIZE` pixels square.
fn scene(spp: u32) -> Scene {
    let desc = json!({
        "camera": {"position": [0, 0, DISTANCE], "look_at": [0, 0, 0], "fov_y": FOV_Y},
        "film": {"width": SIZE, "height": SIZE, "spp": spp, "seed": 3},
        "lights": [{"type": "point", "position": [0, 5, 5], "intensity": [10, 10, 10]}],
        "objects": [{
            "shape": {"type": "icosphere", "radius": 1, "subdivisions": 4},
            "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
        }]
    });
    Scene::build(&serde_json::from_value(desc).unwrap(), &Assets::new()).unwrap()
}

/// The radius in pixels of the sphere's outline: the cone tangent to the sphere from the camera
/// has half-angle asin(1 / DISTANCE); the image plane at unit distance spans ±tan(fov_y / 2)
/// over SIZE / 2 pixels from the centre.
fn outline_radius() -> f64 {
    let half_angle = (1.0 / DISTANCE).asin();
    half_angle.tan() / (FOV_Y.to_radians() / 2.0).tan() * f64::from(SIZE) / 2.0
}

/// The nearest and farthest distances of pixel `(x, y)`'s square from the image centre.
fn distances(x: u32, y: u32) -> (f64, f64) {
    let c = f64::from(SIZE) / 2.0;
    let (x0, x1, y0, y1) = (
        f64::from(x) - c,
        f64::from(x + 1) - c,
        f64::from(y) - c,
        f64::from(y + 1) - c,
    );
    let nearest = |lo: f64, hi: f64| {
        if lo <= 0.0 && hi >= 0.0 {
            0.0
        } else {
            lo.abs().min(hi.abs())
        }
    };
    let near = nearest(x0, x1).hypot(nearest(y0, y1));
    let far = x0.abs().max(x1.abs()).hypot(y0.abs().max(y1.abs()));
    (near, far)
}

const FRAME: TileRect = TileRect {
    x: 0,
    y: 0,
    width: SIZE,
    height: SIZE,
};

/// Pixels wholly inside the disk are 1, wholly outside 0, those the outline crosses between, and
/// their sum is the disk's area π r² (within 1 %: the samples' stratification and the
/// icosphere's outline) — as the EXR file holds them.
#[test]
fn alpha_is_the_coverage_of_a_spheres_disk_in_the_exr_file() {
    let (image, _) = render_frame(&scene(16), FRAME, &|_| {}).unwrap();
    let back = Image::from_exr_bytes(&image.to_exr_bytes().unwrap()).unwrap();
    assert_eq!(back.alpha, image.alpha);
    let r = outline_radius();
    let (mut inside, mut outside, mut edge) = (0, 0, 0);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let alpha = back.alpha[(y * SIZE + x) as usize];
            let (near, far) = distances(x, y);
            if far < r - 0.01 {
                assert_eq!(alpha, 1.0, "pixel ({x}, {y}) is inside the disk");
                inside += 1;
            } else if near > r + 0.01 {
                assert_eq!(alpha, 0.0, "pixel ({x}, {y}) is outside the disk");
                outside += 1;
            } else {
                assert!((0.0..=1.0).contains(&alpha), "pixel ({x}, {y}): {alpha}");
                edge += 1;
            }
        }
    }
    let area: f64 = back.alpha.iter().map(|&a| f64::from(a)).sum();
    let expected = std::f64::consts::PI * r * r;
    println!(
        "r = {r:.3} px: {inside} pixels inside, {outside} outside, {edge} on the edge; \
         Σ alpha = {area:.2}, π r² = {expected:.2}"
    );
    assert!(inside > 150 && outside > 600 && edge > 40);
    assert!(
        (area / expected - 1.0).abs() < 0.01,
        "Σ alpha {area} vs π r² {expected}"
    );
    // Edge pixels really are partial: some strictly between 0 and 1.
    let partial = back.alpha.iter().filter(|&&a| a > 0.0 && a < 1.0).count();
    assert!(partial > 20, "{partial} partial pixels");
}

/// Progressive passes carry the coverage count: after two passes of 16 samples alpha is, bit
/// for bit, that of one render at 32 spp.
#[test]
fn passes_carry_alpha() {
    let scene = scene(32);
    let (image, _, report) = render_frame_passes(&scene, FRAME, &mut |_| true).unwrap();
    assert_eq!(report.passes, 2);
    let (once, _) = render_frame(&scene, FRAME, &|_| {}).unwrap();
    let bits = |v: &[f32]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&image.alpha), bits(&once.alpha));
    assert!(image.alpha.iter().any(|&a| a > 0.0 && a < 1.0));
}
