//! A camera or a light inside a medium: against the closed forms of physics.md §4 (a light inside
//! the medium is the airlight integral; with η = 1 a camera inside sees the straight-path
//! integral) and against point sampling. Before, both were silently black.

mod support;

use glam::DVec3;
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_common::tile::TileRect;
use spindle_render::ray::Ray;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::{describe_plan, single_scatter};
use spindle_render::segment::Segment;
use spindle_render::{Assets, Rgb, Scene, render_tile};
use support::box_obj;

fn build(scene: Value) -> Scene {
    let desc = serde_json::from_value(scene).expect("test scene parses");
    let assets = Assets::from([(
        "cube.obj".to_string(),
        box_obj(-DVec3::ONE, DVec3::ONE, false).into_bytes(),
    )]);
    Scene::build(&desc, &assets).expect("test scene builds")
}

/// ∫ f over [a, b] by the composite midpoint rule with n panels.
fn midpoint(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    (0..n).map(|i| f(a + (i as f64 + 0.5) * h)).sum::<f64>() * h
}

const INV_4PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);

/// η = 1: a camera inside the cube, looking along −x, sees
/// `∫ σ_s p I e^{−σ_t (t + d_in)}/‖L − V‖² dt` over its segment to the wall, where `d_in` is the
/// part of V → L inside the cube (to the top face, by construction). One pixel with a tiny field
/// of view, so the camera ray is the axis.
#[test]
fn camera_inside_sees_the_straight_path_integral() {
    let (sigma_t, albedo, intensity) = (0.7, 0.8, 3.0);
    let camera = DVec3::new(0.5, 0.0, 0.0);
    let light = DVec3::new(0.2, 0.3, 6.0);
    let scene = build(json!({
        "camera": {"position": camera.to_array(), "look_at": [-1, 0, 0], "up": [0, 0, 1],
                   "fov_y": 0.01},
        "film": {"width": 1, "height": 1, "spp": 1},
        "lights": [{"type": "point", "position": light.to_array(),
                    "intensity": [intensity, intensity, intensity]}],
        "objects": [{"shape": {"type": "obj", "path": "cube.obj"},
            "material": {"type": "dielectric", "eta": 1.0, "medium": {
                "sigma_t": [sigma_t, sigma_t, sigma_t], "albedo": [albedo, albedo, albedo]}}}],
        "integrator": {"single_scatter": {"samples_per_segment": 1024}}
    }));
    assert_eq!(scene.camera_medium(), Some(0));
    assert!(
        describe_plan(&scene)
            .iter()
            .any(|l| l.contains("camera: inside objects[0]")),
        "{:?}",
        describe_plan(&scene)
    );
    let truth = midpoint(
        |t| {
            let v = camera - DVec3::X * t;
            let d = v.distance(light);
            // V → L leaves through the top face z = 1.
            let d_in = d * (1.0 - v.z) / (light.z - v.z);
            albedo * sigma_t * INV_4PI * intensity * (-sigma_t * (t + d_in)).exp() / (d * d)
        },
        0.0,
        1.5,
        100_000,
    );
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 1,
        height: 1,
    };
    let pixel = render_tile(&scene, rect);
    let value = f64::from(pixel.single_scatter[0]);
    println!("camera inside, η = 1: {value:.7e} vs {truth:.7e}");
    assert!((value / truth - 1.0).abs() < 1e-3, "{value} vs {truth}");
}

/// η = 1.5: the interval method (K = 1) and point sampling agree on an image from inside a glass
/// sphere (the view: camera at (0, 0, 0.5) looking at the centre).
#[test]
fn camera_inside_glass_interval_agrees_with_point_sampling() {
    let scene = |ss: Value| {
        build(json!({
            "camera": {"position": [0, 0, 0.5], "look_at": [0, 0, 0], "fov_y": 60},
            "film": {"width": 8, "height": 8, "spp": 1},
            "lights": [{"type": "point", "position": [2.5, 1, 4], "intensity": [10, 10, 10]}],
            "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
                "material": {"type": "dielectric", "eta": 1.5,
                    "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}],
            "integrator": {"single_scatter": ss}
        }))
    };
    let mean = |scene: &Scene| {
        let rect = TileRect {
            x: 0,
            y: 0,
            width: 8,
            height: 8,
        };
        let tile = render_tile(scene, rect);
        assert!(tile.single_scatter.iter().all(|v| v.is_finite()));
        tile.single_scatter
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            / 192.0
    };
    let interval = mean(&scene(json!({"method": "interval", "k": 1})));
    let points = mean(&scene(
        json!({"method": "point_sampling", "samples_per_segment": 256}),
    ));
    println!("camera inside glass: interval {interval:.6e}, point sampling {points:.6e}");
    assert!(points > 0.0 && (interval / points - 1.0).abs() < 0.02);
}

/// physics.md §4: a point light inside the medium, a camera segment inside: the airlight integral
/// `(σ_s I/h) ∫ p e^{−σ_t (x0 + h (tan u + sec u))} du` (isotropic), here by the midpoint rule in
/// u. The object's index does not matter: no interface lies between them.
#[test]
fn light_inside_matches_the_airlight_integral() {
    let (sigma_t, albedo, intensity) = (0.5, 0.9, 2.0);
    let light = DVec3::new(0.1, 0.2, -0.1);
    let scene = build(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": [{"type": "point", "position": light.to_array(),
                    "intensity": [intensity, intensity, intensity]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
            "material": {"type": "dielectric", "eta": 1.5, "medium": {
                "sigma_t": [sigma_t, sigma_t, sigma_t], "albedo": [albedo, albedo, albedo]}}}],
        "integrator": {"single_scatter": {"samples_per_segment": 4096}}
    }));
    assert_eq!(scene.light_medium(0), Some(0));
    assert!(
        describe_plan(&scene)
            .iter()
            .any(|l| l.contains("lights[0]: inside objects[0]")),
        "{:?}",
        describe_plan(&scene)
    );
    let origin = DVec3::new(-0.5, -0.3, 0.2);
    let dir = DVec3::new(1.0, 0.4, -0.2).normalize();
    let length = scene
        .bvh()
        .closest_hit(&Ray::new(origin, dir))
        .expect("inside")
        .t;
    let x0 = (light - origin).dot(dir);
    let h = (light - origin - x0 * dir).length();
    let (u0, u1) = ((-x0).atan2(h), (length - x0).atan2(h));
    let truth = albedo * sigma_t * intensity / h
        * midpoint(
            |u| INV_4PI * (-sigma_t * (x0 + h * (u.tan() + 1.0 / u.cos()))).exp(),
            u0,
            u1,
            100_000,
        );
    let segment = Segment {
        origin,
        dir,
        length,
        object: 0,
        throughput: Rgb::ONE,
    };
    let mut stats = RenderStats::default();
    let value = single_scatter(&scene, &segment, &mut Sampler::new(3, 1, 2, 0), &mut stats);
    println!("light inside: {:.7e} vs airlight {truth:.7e}", value.x);
    assert!((value.x / truth - 1.0).abs() < 2e-3, "{value} vs {truth}");
}

/// A point light exactly on the surface (a vertex of the icosphere) lights the medium, finitely;
/// a sphere or quad light that crosses the surface is refused, naming the light and the object;
/// a quad light wholly inside the medium lights it, one wholly outside (even inside the object's
/// bounding box) is in the air.
#[test]
fn lights_on_or_across_the_surface() {
    let scene = |lights: Value| {
        let desc = serde_json::from_value(json!({
            "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
            "film": {"width": 6, "height": 6, "spp": 1},
            "lights": lights,
            "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 2},
                "material": {"type": "dielectric", "eta": 1.5,
                    "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}]
        }))
        .unwrap();
        Scene::build(&desc, &Assets::new())
    };
    let on = scene(json!([{"type": "point", "position": [0, 0, 1], "intensity": [5, 5, 5]}]))
        .expect("a light on the surface is accepted");
    assert_eq!(on.light_medium(0), Some(0));
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 6,
        height: 6,
    };
    let tile = render_tile(&on, rect);
    assert!(tile.single_scatter.iter().all(|v| v.is_finite()));
    assert!(tile.single_scatter.iter().any(|&v| v > 0.0));

    let across = scene(
        json!([{"type": "sphere", "center": [0, 0, 0.9], "radius": 0.2,
                               "radiance": [1, 1, 1]}]),
    )
    .expect_err("a sphere light across the surface is refused")
    .to_string();
    assert!(
        across.starts_with("lights[0]:") && across.contains("objects[0]"),
        "{across}"
    );
    let quad = |corner: [f64; 3], edge: f64| {
        json!([{"type": "quad", "corner": corner, "edge_u": [edge, 0, 0],
                "edge_v": [0, edge, 0], "radiance": [1, 1, 1]}])
    };
    // Through the middle of the sphere: its edges never touch the surface, the surface crosses it.
    for (corner, edge) in [([-2.0, -2.0, 0.0], 4.0), ([0.5, 0.5, 0.3], 0.8)] {
        let across = scene(quad(corner, edge))
            .expect_err("a quad light across the surface is refused")
            .to_string();
        assert!(
            across.starts_with("lights[0]:")
                && across.contains("quad light")
                && across.contains("objects[0]"),
            "{across}"
        );
    }
    let inside = scene(quad([-0.3, -0.3, 0.2], 0.6)).expect("a quad inside the medium");
    assert_eq!(inside.light_medium(0), Some(0));
    let outside = scene(quad([0.8, 0.8, 0.0], 0.15)).expect("a quad in a corner of the box");
    assert_eq!(outside.light_medium(0), None);
}
