//! The optional passes (`film.passes`: depth, normal, albedo, id) against a scene known in closed
//! form — a glass unit sphere in front of a square diffuse wall, seen along the camera's axis —
//! read back from the EXR file with the OpenEXR reader (the `exr` crate), not spindle's own.

use std::io::Cursor;

use glam::DVec3;
use serde_json::json;
use spindle_common::tile::TileRect;
use spindle_render::{Assets, Scene, render_frame, render_frame_passes};

const SIZE: u32 = 32;
const FOV_Y: f64 = 40.0;
/// The camera's distance from the centre of the unit sphere, on +z.
const DISTANCE: f64 = 5.0;
/// The wall: the square |x|, |y| ≤ WALL_HALF in the plane z = WALL_Z, facing the camera.
const WALL_Z: f64 = -2.0;
const WALL_HALF: f64 = 2.0;
const WALL_ALBEDO: [f64; 3] = [0.25, 0.5, 0.75];

const FRAME: TileRect = TileRect {
    x: 0,
    y: 0,
    width: SIZE,
    height: SIZE,
};

/// The wall (object 0, id 1) and a glass icosphere of 20·4⁴ triangles (object 1, id 2).
fn scene(spp: u32) -> Scene {
    let h = WALL_HALF;
    let wall = format!(
        "v {} {} {WALL_Z}\nv {h} {} {WALL_Z}\nv {h} {h} {WALL_Z}\nv {} {h} {WALL_Z}\nf 1 2 3\nf 1 3 4\n",
        -h, -h, -h, -h
    );
    let desc = json!({
        "camera": {"position": [0, 0, DISTANCE], "look_at": [0, 0, 0], "fov_y": FOV_Y},
        "film": {"width": SIZE, "height": SIZE, "spp": spp, "seed": 7,
                 "passes": ["id", "depth", "albedo", "normal"]},
        "lights": [{"type": "point", "position": [0, 3, 4], "intensity": [10, 10, 10]}],
        "objects": [
            {"shape": {"type": "obj", "path": "wall.obj"},
             "material": {"type": "diffuse", "reflectance": WALL_ALBEDO}},
            {"shape": {"type": "icosphere", "radius": 1, "subdivisions": 4},
             "material": {"type": "dielectric", "eta": 1.5, "medium": {
                 "sigma_t": [0.1, 0.1, 0.1], "albedo": [0, 0, 0]}}}
        ],
        "integrator": {"max_depth": 1, "internal_reflections": 0}
    });
    let assets = Assets::from([("wall.obj".to_string(), wall.into_bytes())]);
    Scene::build(&serde_json::from_value(desc).unwrap(), &assets).unwrap()
}

/// One channel of the file, by name, as f32 in row-major order, read by the `exr` crate.
fn channel(file: &[u8], name: &str) -> Vec<f32> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(file))
        .unwrap();
    let layer = &image.layer_data;
    let found = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.eq(name))
        .unwrap_or_else(|| panic!("no channel {name}"));
    found.sample_data.values_as_f32().collect()
}

/// The camera ray through image point `(x, y)` (pixel units), from the camera's definition:
/// x right, y down, the image plane at unit distance spanning ±tan(fov_y / 2) vertically.
fn ray_dir(x: f64, y: f64) -> DVec3 {
    let t = (FOV_Y.to_radians() / 2.0).tan();
    let s = f64::from(SIZE);
    let sx = (2.0 * x / s - 1.0) * t;
    let sy = (1.0 - 2.0 * y / s) * t;
    DVec3::new(sx, sy, -1.0).normalize()
}

/// Where the ray through `(x, y)` meets the unit sphere first, if it does.
fn sphere_hit(x: f64, y: f64) -> Option<DVec3> {
    let (o, d) = (DVec3::new(0.0, 0.0, DISTANCE), ray_dir(x, y));
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - 1.0);
    (disc >= 0.0).then(|| o + (-b - disc.sqrt()) * d)
}

/// Over a `k` × `k` grid of points of pixel `(px, py)`: how many see the sphere, and the mean of
/// the sphere's normal (the hit point) over the whole pixel.
fn pixel_over_sphere(px: u32, py: u32, k: u32) -> (u32, DVec3) {
    let (mut hits, mut sum) = (0, DVec3::ZERO);
    for i in 0..k {
        for j in 0..k {
            let x = f64::from(px) + (f64::from(i) + 0.5) / f64::from(k);
            let y = f64::from(py) + (f64::from(j) + 0.5) / f64::from(k);
            if let Some(p) = sphere_hit(x, y) {
                hits += 1;
                sum += p;
            }
        }
    }
    (hits, sum / f64::from(k * k))
}

/// Does every point of pixel `(px, py)` see the wall (and not the sphere, nor past the wall)?
fn wholly_wall(px: u32, py: u32) -> bool {
    let k = 8;
    (0..=k).all(|i| {
        (0..=k).all(|j| {
            let x = f64::from(px) + f64::from(i) / f64::from(k);
            let y = f64::from(py) + f64::from(j) / f64::from(k);
            let d = ray_dir(x, y);
            let p = DVec3::new(0.0, 0.0, DISTANCE) + d * ((WALL_Z - DISTANCE) / d.z);
            // A margin of the sphere's tessellation (its outline is within 0.006 px of the
            // sphere's) and of a pixel edge.
            sphere_hit(x, y).is_none()
                && pixel_over_sphere_outline_margin(x, y)
                && p.x.abs() < WALL_HALF - 0.05
                && p.y.abs() < WALL_HALF - 0.05
        })
    })
}

/// Is `(x, y)` clear of the sphere's outline by a margin of 0.05 on the sphere's scale?
fn pixel_over_sphere_outline_margin(x: f64, y: f64) -> bool {
    let (o, d) = (DVec3::new(0.0, 0.0, DISTANCE), ray_dir(x, y));
    // Distance from the sphere's centre to the ray's line.
    (o - o.dot(d) * d).length() > 1.05
}

/// Does no point of pixel `(px, py)` see the wall or the sphere?
fn wholly_background(px: u32, py: u32) -> bool {
    let c = |v: u32| f64::from(v);
    [
        (c(px), c(py)),
        (c(px + 1), c(py)),
        (c(px), c(py + 1)),
        (c(px + 1), c(py + 1)),
    ]
    .iter()
    .all(|&(x, y)| {
        let d = ray_dir(x, y);
        let p = DVec3::new(0.0, 0.0, DISTANCE) + d * ((WALL_Z - DISTANCE) / d.z);
        p.x.abs().max(p.y.abs()) > WALL_HALF + 0.05
    })
}

/// Depth of the wall (its camera-space z, the same at every pixel: 7), its albedo and normal;
/// inside the sphere's disk the analytic normal averaged over the pixel, albedo 1 (glass), id 2;
/// the wall's id 1 and the background's 0 with depth, normal and albedo 0; on the sphere's
/// silhouette ids of either object, never a blend.
#[test]
fn the_passes_in_the_exr_file_are_the_scenes_depth_normal_albedo_and_ids() {
    let (image, _) = render_frame(&scene(16), FRAME, &|_| {}).unwrap();
    let file = image.to_exr_bytes().unwrap();
    let z = channel(&file, "Z");
    let n: Vec<Vec<f32>> = ["normal.X", "normal.Y", "normal.Z"]
        .iter()
        .map(|c| channel(&file, c))
        .collect();
    let albedo: Vec<Vec<f32>> = ["albedo.R", "albedo.G", "albedo.B"]
        .iter()
        .map(|c| channel(&file, c))
        .collect();
    let id = channel(&file, "id.id");
    let alpha = channel(&file, "A");

    let wall_depth = DISTANCE - WALL_Z;
    let (mut wall, mut sphere, mut background, mut silhouette) = (0, 0, 0, [0, 0]);
    let mut worst_normal: f64 = 0.0;
    for py in 0..SIZE {
        for px in 0..SIZE {
            let i = (py * SIZE + px) as usize;
            let normal = DVec3::new(n[0][i].into(), n[1][i].into(), n[2][i].into());
            let rgb = [albedo[0][i], albedo[1][i], albedo[2][i]];
            let (covered, mean_normal) = pixel_over_sphere(px, py, 16);
            if wholly_wall(px, py) {
                wall += 1;
                assert!(
                    (f64::from(z[i]) - wall_depth).abs() < 1e-5,
                    "({px}, {py}): depth {} of the wall at {wall_depth}",
                    z[i]
                );
                assert_eq!(rgb, WALL_ALBEDO.map(|v| v as f32), "({px}, {py})");
                assert!((normal - DVec3::Z).length() < 1e-6, "({px}, {py}) {normal}");
                assert_eq!(id[i], 1.0, "({px}, {py})");
            } else if wholly_background(px, py) {
                background += 1;
                assert_eq!(
                    (z[i], rgb, normal, id[i], alpha[i]),
                    (0.0, [0.0; 3], DVec3::ZERO, 0.0, 0.0),
                    "({px}, {py})"
                );
            } else if covered == 256 && mean_normal.z > 0.5 {
                // Wholly inside the disk, away from the outline (where the normal turns fast).
                sphere += 1;
                worst_normal = worst_normal.max((normal - mean_normal).abs().max_element());
                assert_eq!(rgb, [1.0; 3], "({px}, {py}): glass is white");
                assert_eq!(id[i], 2.0, "({px}, {py})");
                // The depth lies between the sphere's nearest point and its outline's.
                assert!(
                    (DISTANCE - 1.0..DISTANCE).contains(&f64::from(z[i])),
                    "({px}, {py}) depth {}",
                    z[i]
                );
            } else if covered > 0 && covered < 256 {
                // On the silhouette: sample 0 saw one object or the other.
                assert!(id[i] == 1.0 || id[i] == 2.0, "({px}, {py}): id {}", id[i]);
                silhouette[(id[i] as usize) - 1] += 1;
            }
        }
    }
    println!(
        "{wall} wall pixels, {sphere} sphere pixels (normal within {worst_normal:.4} of the \
         analytic mean), {background} background pixels, silhouette ids {silhouette:?}"
    );
    assert!(
        wall > 200 && sphere > 150 && background > 300,
        "too few pixels checked"
    );
    assert!(
        silhouette[0] > 5 && silhouette[1] > 5,
        "both objects on the silhouette"
    );
    // The icosphere's smooth normals are within about 1e-3 of the sphere's; 16 stratified
    // samples estimate the pixel's mean normal to a few 1e-3 where it turns slowest.
    assert!(worst_normal < 0.01, "normal off by {worst_normal}");
}

/// Progressive passes carry the passes' sums: after two passes of 16 samples the optional
/// passes are, bit for bit, those of one render at 32 spp.
#[test]
fn progressive_passes_carry_the_optional_passes() {
    let scene = scene(32);
    let (image, _, report) = render_frame_passes(&scene, FRAME, &mut |_| true).unwrap();
    assert_eq!(report.passes, 2);
    let (once, _) = render_frame(&scene, FRAME, &|_| {}).unwrap();
    let bits = |v: &[f32]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
    assert_eq!(image.passes, once.passes);
    assert_eq!(image.aov.len(), (SIZE * SIZE * 8) as usize);
    assert_eq!(bits(&image.aov), bits(&once.aov));
}
