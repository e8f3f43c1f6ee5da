//! End-to-end renders of tiny scenes whose pixel values are known in closed form.

mod support;

use glam::DVec3;
use spindle_common::scene::SceneDescription;
use spindle_common::tile::{TileRect, split_centre_first};
use spindle_render::{Assets, Scene, render_tile};
use support::box_obj;

/// The slab `[-10, 10]² × [0, thickness]`, optionally without its back face (z = 0).
fn slab_obj(thickness: f64, open_back: bool) -> String {
    box_obj(
        DVec3::new(-10.0, -10.0, 0.0),
        DVec3::new(10.0, 10.0, thickness),
        open_back,
    )
}

/// A camera looking down −z at a glass slab (z from 0 to `thickness`, scaled by `scale` about
/// the origin, σ_t divided by `scale`), with a sphere light behind it filling the view.
fn slab_scene(
    thickness: f64,
    sigma_t: f64,
    internal_reflections: u32,
    scale: f64,
    open_back: bool,
) -> (Scene, f64) {
    let radiance = 3.0;
    let sigma_t = sigma_t / scale;
    let (camera_z, light_z, light_r) = (5.0 * scale, -1000.0 * scale, 900.0 * scale);
    let json = format!(
        r#"{{
        "camera": {{ "position": [0, 0, {camera_z}], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y": 0.01 }},
        "film": {{ "width": 3, "height": 3, "spp": 4, "seed": 1 }},
        "lights": [ {{ "type": "sphere", "center": [0, 0, {light_z}], "radius": {light_r},
                       "radiance": [{radiance}, {radiance}, {radiance}] }} ],
        "objects": [ {{
            "shape": {{ "type": "obj", "path": "slab.obj" }},
            "transform": {{ "scale": [{scale}, {scale}, {scale}] }},
            "material": {{ "type": "dielectric", "eta": 1.5,
                "medium": {{ "sigma_t": [{sigma_t}, {sigma_t}, {sigma_t}], "albedo": [0, 0, 0] }} }}
        }} ],
        "integrator": {{ "max_depth": 8, "internal_reflections": {internal_reflections} }}
    }}"#
    );
    let desc: SceneDescription = serde_json::from_str(&json).unwrap();
    let assets = Assets::from([(
        "slab.obj".to_string(),
        slab_obj(thickness, open_back).into_bytes(),
    )]);
    (Scene::build(&desc, &assets).unwrap(), radiance)
}

#[test]
fn sphere_light_through_an_absorbing_glass_slab() {
    let (d, s) = (0.7, 1.3);
    let f0 = ((1.5f64 - 1.0) / (1.5 + 1.0)).powi(2);
    // Only the direct transmission: L = L_e (1 − F0)² e^{−s d}.
    let (scene, le) = slab_scene(d, s, 0, 1.0, false);
    let expected = le * (1.0 - f0).powi(2) * (-s * d).exp();
    // Two internal reflections allow one extra round trip: the series' k = 1 term.
    let (scene2, _) = slab_scene(d, s, 2, 1.0, false);
    let round_trip = f0 * f0 * (-2.0 * s * d).exp();
    let expected2 = expected * (1.0 + round_trip);
    for (scene, expected) in [(&scene, expected), (&scene2, expected2)] {
        let tile = render_tile(
            scene,
            TileRect {
                x: 0,
                y: 0,
                width: 3,
                height: 3,
            },
        );
        println!("{:?}", tile.stats);
        for (i, v) in tile.total.iter().enumerate() {
            let rel = (*v as f64 - expected).abs() / expected;
            println!("pixel channel {i}: {v} expected {expected} (relative error {rel:.2e})");
            assert!(rel < 1e-4, "got {v}, expected {expected}");
        }
        assert_eq!(tile.surface, tile.total);
        assert!(tile.single_scatter.iter().all(|&v| v == 0.0));
        assert_eq!(tile.stats.camera_rays, 9 * 4);
        assert!(tile.stats.camera_segments >= 9 * 4);
    }
    // The k = 1 term is resolved (it is 1.6e-3 of the value, far above f32 rounding).
    assert!(round_trip * expected > 1e3 * f32::EPSILON as f64 * expected);
}

#[test]
fn diffuse_floor_under_a_point_light_and_a_glass_blocker() {
    let json = |blocker: bool| {
        let glass = if blocker {
            r#", { "shape": { "type": "icosphere", "radius": 0.3, "subdivisions": 3 },
                   "transform": { "translate": [0.9, 1.0, 0] },
                   "material": { "type": "dielectric", "eta": 1.5,
                                 "medium": { "sigma_t": [0, 0, 0], "albedo": [0, 0, 0] } } }"#
        } else {
            ""
        };
        format!(
            r#"{{
            "camera": {{ "position": [0, 5, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov_y": 0.0001 }},
            "film": {{ "width": 1, "height": 1, "spp": 2 }},
            "lights": [ {{ "type": "point", "position": [1.5, 2, 0], "intensity": [4, 8, 12] }} ],
            "objects": [ {{
                "shape": {{ "type": "obj", "path": "floor.obj" }},
                "material": {{ "type": "diffuse", "reflectance": [0.5, 0.25, 1.0] }}
            }} {glass} ]
        }}"#
        )
    };
    let floor = "v -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nf 1 4 3 2\n";
    let assets = Assets::from([("floor.obj".to_string(), floor.as_bytes().to_vec())]);
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 1,
        height: 1,
    };

    // L = ρ/π · I cos θ / r², r² = 1.5² + 2², cos θ = 2/r.
    let scene = Scene::build(&serde_json::from_str(&json(false)).unwrap(), &assets).unwrap();
    let tile = render_tile(&scene, rect);
    let r2: f64 = 1.5 * 1.5 + 4.0;
    let cos = 2.0 / r2.sqrt();
    for (c, (rho, i)) in [(0.5, 4.0), (0.25, 8.0), (1.0, 12.0)]
        .into_iter()
        .enumerate()
    {
        let expected = rho / std::f64::consts::PI * i * cos / r2;
        let got = tile.total[c] as f64;
        assert!(
            (got - expected).abs() < 1e-5 * expected,
            "channel {c}: {got} vs {expected}"
        );
    }
    assert_eq!(tile.stats.shadow_rays, 2);

    // A glass sphere on the segment from the floor point to the light blocks it.
    let blocked = Scene::build(&serde_json::from_str(&json(true)).unwrap(), &assets).unwrap();
    let tile = render_tile(&blocked, rect);
    assert!(tile.total.iter().all(|&v| v == 0.0), "{:?}", tile.total);
}

#[test]
fn pixels_are_the_same_bits_whatever_the_tiling() {
    let json = r#"{
        "camera": { "position": [0, 0.5, 4], "look_at": [0, 0, 0], "fov_y": 35 },
        "film": { "width": 24, "height": 16, "spp": 3, "seed": 11 },
        "background": [0.1, 0.2, 0.3],
        "lights": [ { "type": "sphere", "center": [0, 3, -3], "radius": 1, "radiance": [5, 5, 5] },
                    { "type": "point", "position": [2, 3, 2], "intensity": [3, 3, 3] } ],
        "objects": [
            { "shape": { "type": "bumpy_sphere", "radius": 1, "subdivisions": 4,
                         "amplitude": 0.15, "frequency": 3, "seed": 2 },
              "material": { "type": "dielectric", "eta": 1.4,
                            "medium": { "sigma_t": [0.5, 1, 2], "albedo": [0.9, 0.9, 0.9] } } },
            { "shape": { "type": "icosphere", "radius": 30, "subdivisions": 2 },
              "transform": { "translate": [0, -31.2, 0] },
              "material": { "type": "diffuse", "reflectance": [0.8, 0.8, 0.8] } }
        ]
    }"#;
    let scene = Scene::build(&serde_json::from_str(json).unwrap(), &Assets::new()).unwrap();
    let whole = render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: 24,
            height: 16,
        },
    );
    assert!(whole.total.iter().all(|v| v.is_finite()));
    assert!(whole.total.iter().any(|&v| v > 0.0));
    for size in [1, 5, 7] {
        for rect in split_centre_first(24, 16, size) {
            let tile = render_tile(&scene, rect);
            for row in 0..rect.height {
                for col in 0..rect.width {
                    let i = ((row * rect.width + col) * 3) as usize;
                    let j = (((rect.y + row) * 24 + rect.x + col) * 3) as usize;
                    assert_eq!(tile.total[i..i + 3], whole.total[j..j + 3]);
                }
            }
        }
    }
}

#[test]
fn slab_value_holds_at_tiny_and_huge_scales() {
    // The same slab scaled by 1e-4 and 1e3 (σ_t scaled inversely) gives the same pixels: the
    // surface offsets and tolerances follow the scene's size. (1e3 is the largest scale that
    // keeps its light, 1000 units away, within the scene bounds of ±1e6.)
    let (d, s) = (0.5, 2.0);
    let f0 = 0.04;
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 3,
        height: 3,
    };
    for scale in [1e-4, 1.0, 1e3] {
        let (scene, le) = slab_scene(d, s, 2, scale, false);
        let expected =
            le * (1.0 - f0) * (1.0 - f0) * (-s * d).exp() * (1.0 + f0 * f0 * (-2.0 * s * d).exp());
        let tile = render_tile(&scene, rect);
        for v in &tile.total {
            let rel = (*v as f64 - expected).abs() / expected;
            assert!(rel < 1e-4, "scale {scale}: {v} vs {expected}");
        }
    }
}

#[test]
fn a_ray_escaping_an_open_mesh_leaves_the_object() {
    // The slab without its back face: refracted camera rays escape through the hole, travel to
    // the edge of the object's bounds (z = 0, so through the full thickness) and carry on in air
    // to the light, as through a perfectly transmitting interface: L = L_e (1 − F0) e^{−s d}.
    let (d, s) = (0.5, 1.0);
    let (scene, le) = slab_scene(d, s, 2, 1.0, true);
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    let expected = le * (1.0 - 0.04) * (-s * d).exp();
    let tile = render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: 3,
            height: 3,
        },
    );
    for v in &tile.total {
        assert!(
            (*v as f64 - expected).abs() < 1e-4 * expected,
            "{v} vs {expected}"
        );
    }
}

#[test]
fn lossless_glass_in_a_white_furnace_conserves_radiance() {
    // A clear glass sphere in a uniform white background of radiance 1: at every interface the
    // split weights F and 1 − F sum to 1 and the n² factors of entry and exit cancel, so every
    // pixel sees at most 1; only paths cut by the depth limits lose anything (little, far from
    // the silhouette). A wrong n² or Fresnel bookkeeping shows up as values far from 1.
    let json = r#"{
        "camera": { "position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y": 32 },
        "film": { "width": 24, "height": 24, "spp": 2 },
        "background": [1, 1, 1],
        "objects": [ { "shape": { "type": "icosphere", "radius": 1, "subdivisions": 5 },
            "material": { "type": "dielectric", "eta": 1.5,
                          "medium": { "sigma_t": [0, 0, 0], "albedo": [0, 0, 0] } } } ],
        "integrator": { "max_depth": 40, "internal_reflections": 30 }
    }"#;
    let scene = Scene::build(&serde_json::from_str(json).unwrap(), &Assets::new()).unwrap();
    let tile = render_tile(
        &scene,
        TileRect {
            x: 0,
            y: 0,
            width: 24,
            height: 24,
        },
    );
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for row in 0..24 {
        for col in 0..24 {
            let v = tile.total[(row * 24 + col) * 3];
            lo = lo.min(v);
            hi = hi.max(v);
            // The central pixels see the sphere far from grazing: nearly lossless.
            if (8..16).contains(&row) && (8..16).contains(&col) {
                assert!((v - 1.0).abs() < 1e-4, "pixel {col},{row}: {v}");
            }
        }
    }
    println!(
        "white furnace: pixels in [{lo}, {hi}], segments {}",
        tile.stats.camera_segments
    );
    assert!(hi <= 1.0 + 1e-5, "radiance was created: {hi}");
    assert!(lo > 0.999, "too much radiance was lost: {lo}");
}
