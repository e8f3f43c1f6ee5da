//! The quad (rectangle) light against ground truth: its light samples' irradiance and, through
//! the whole renderer, a diffuse floor under it (Lambert's closed form), the light seen from the front and from behind, and single
//! scattering at η = 1 against a brute-force integral over the segment and the rectangle.

#[path = "support/segment.rs"]
mod segment_support;
mod support;

use glam::DVec3;
use segment_support::{segment_to_surface, single_scatter_mean};
use serde_json::{Value, json};
use spindle_common::scene as desc;
use spindle_common::tile::TileRect;
use spindle_render::light::{Light, SceneSphere};
use spindle_render::scatter::describe_plan;
use spindle_render::{Assets, Scene, render_tile};
use support::box_obj;

fn scene(objects: Value, lights: Value, camera: Value, spp: u32, assets: Assets) -> Scene {
    let scene = json!({
        "camera": camera,
        "film": {"width": 4, "height": 4, "spp": spp},
        "lights": lights,
        "objects": objects,
    });
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &assets).expect("test scene builds")
}

const WHOLE: TileRect = TileRect {
    x: 0,
    y: 0,
    width: 4,
    height: 4,
};

/// Lambert's formula: the irradiance at `p` (unit normal `n`) from a polygon of uniform radiance
/// `L` wholly above the receiver's horizon is `L/2 · |Σ θ_i n·ĝ_i|`, with `θ_i` the angle
/// between the directions to consecutive vertices and `ĝ_i` the unit normal of their plane.
fn lambert_irradiance(p: DVec3, n: DVec3, vertices: &[DVec3], radiance: f64) -> f64 {
    let mut sum = 0.0;
    for i in 0..vertices.len() {
        let a = (vertices[i] - p).normalize();
        let b = (vertices[(i + 1) % vertices.len()] - p).normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * n.dot(a.cross(b).normalize());
    }
    0.5 * radiance * sum.abs()
}

/// Irradiance from a quad light at receivers close by (sampled by solid angle), far away (by
/// area) and at a slant, against Lambert's closed form; behind the light, none.
#[test]
fn quad_light_irradiance_matches_lamberts_formula() {
    let (corner, eu, ev) = ([-1.0, -0.5, 2.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
    // Edges (ev, eu): the normal ev × eu is −z, so the light at z = 2 shines down.
    let light = Light::new(
        &desc::Light::Quad {
            corner,
            edge_u: ev,
            edge_v: eu,
            radiance: [3.0; 3],
        },
        SceneSphere {
            center: DVec3::ZERO,
            radius: 1.0,
        },
    )
    .unwrap();
    let vertices = [
        DVec3::from_array(corner),
        DVec3::from_array(corner) + DVec3::from_array(ev),
        DVec3::from_array(corner) + DVec3::from_array(ev) + DVec3::from_array(eu),
        DVec3::from_array(corner) + DVec3::from_array(eu),
    ];
    for (p, n) in [
        (DVec3::ZERO, DVec3::Z),
        (
            DVec3::new(0.3, 0.2, 1.7),
            DVec3::new(0.1, 0.0, 1.0).normalize(),
        ),
        (
            DVec3::new(2.0, -1.0, 0.5),
            DVec3::new(-0.5, 0.2, 1.0).normalize(),
        ),
        // Ω = 2e-4 sr: sampled by area.
        (DVec3::new(0.0, 0.0, -98.0), DVec3::Z),
    ] {
        let mut e = 0.0;
        let k = 300;
        for i in 0..k {
            for j in 0..k {
                let u = [(i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64];
                let s = light.sample_incident(p, u).expect("in front of the light");
                let hit = p + s.dir * s.distance;
                assert!(
                    (hit.z - 2.0).abs() < 1e-9,
                    "the sample is on the light: {hit}"
                );
                e += s.weight.x * s.dir.dot(n).max(0.0);
            }
        }
        e /= (k * k) as f64;
        let expected = lambert_irradiance(p, n, &vertices, 3.0);
        assert!(
            (e - expected).abs() < 2e-3 * expected,
            "at {p}: {e} vs {expected}"
        );
    }
    assert!(
        light
            .sample_incident(DVec3::new(0.0, 0.0, 3.0), [0.5, 0.5])
            .is_none()
    );
}

/// A diffuse floor (top at z = 0) under a 2 × 1.5 quad at height 1.2, off to one side and facing
/// down: the camera sees a spot about 6e-4 wide around the origin, whose radiance is
/// `ρ/π · E(0)` with `E` from Lambert's formula (E varies by about 5e-4 across the spot).
/// Looking up into the quad the camera sees its radiance; from above it sees its black back.
#[test]
fn a_diffuse_floor_and_the_quad_match_the_closed_forms() {
    let floor = box_obj(
        DVec3::new(-10.0, -10.0, -1.0),
        DVec3::new(10.0, 10.0, 0.0),
        false,
    );
    let (corner, edge_u, edge_v) = (
        DVec3::new(-0.5, -0.3, 1.2),
        DVec3::new(0.0, 1.5, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
    );
    let (rho, radiance) = (0.6, 4.0);
    let quad = json!([{"type": "quad", "corner": corner.to_array(), "edge_u": edge_u.to_array(),
                       "edge_v": edge_v.to_array(), "radiance": [radiance, radiance, radiance]}]);
    let assets = || Assets::from([("floor.obj".to_string(), floor.clone().into_bytes())]);
    let lit = scene(
        json!([{"shape": {"type": "obj", "path": "floor.obj"},
                "material": {"type": "diffuse", "reflectance": [rho, rho, rho]}}]),
        quad.clone(),
        json!({"position": [0, -1, 3], "look_at": [0, 0, 0], "fov_y": 0.01}),
        64,
        assets(),
    );
    let vertices = [
        corner,
        corner + edge_u,
        corner + edge_u + edge_v,
        corner + edge_v,
    ];
    let truth =
        rho / std::f64::consts::PI * lambert_irradiance(DVec3::ZERO, DVec3::Z, &vertices, radiance);
    let pixels = render_tile(&lit, WHOLE);
    let worst = pixels
        .surface
        .iter()
        .map(|&v| v as f64 / truth - 1.0)
        .fold(0.0f64, |a, e| a.max(e.abs()));
    println!("floor under the quad: Lambert {truth:.6}, worst relative error {worst:.1e} (64 spp)");
    assert!(worst < 3e-3, "{:?} vs {truth}", pixels.surface);

    let centre = corner + 0.5 * (edge_u + edge_v);
    let looking = |from: DVec3| {
        let s = scene(
            json!([]),
            quad.clone(),
            json!({"position": from.to_array(), "look_at": centre.to_array(), "up": [0, 1, 0],
                   "fov_y": 5}),
            1,
            Assets::new(),
        );
        render_tile(&s, WHOLE).surface
    };
    assert!(
        looking(DVec3::new(0.3, 0.2, -2.0))
            .iter()
            .all(|&v| v == radiance as f32)
    );
    assert!(looking(DVec3::new(0.3, 0.2, 4.0)).iter().all(|&v| v == 0.0));
}

/// Single scattering at η = 1 (σ_t → 0, isotropic) from a quad light: the radiance along a
/// camera segment is `σ_s/(4π) ∫ds ∫ L cos_y / r² dA` over the segment and the rectangle.
/// Brute force: 400 points along the segment × a 400² grid on the rectangle (midpoints). The
/// renderer: the mean of 4096 camera samples, each with one light point; it must agree within
/// four of its own standard errors, and the standard error be under 0.5 %.
#[test]
fn single_scattering_at_eta_one_matches_brute_force() {
    let (corner, edge_u, edge_v) = (
        DVec3::new(-1.0, 1.6, -0.8),
        DVec3::new(1.8, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 1.4),
    );
    let radiance = 2.5;
    let desc = serde_json::from_value(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": [{"type": "quad", "corner": corner.to_array(), "edge_u": edge_u.to_array(),
                    "edge_v": edge_v.to_array(), "radiance": [radiance, radiance, radiance]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
                     "material": {"type": "dielectric", "eta": 1.0, "medium": {
                        "sigma_t": [1e-12, 1e-12, 1e-12], "albedo": [1, 1, 1]}}}]
    }))
    .unwrap();
    let scene = Scene::build(&desc, &Assets::new()).unwrap();
    assert!(describe_plan(&scene)[0].contains("straight_line"));
    let (origin, dir) = (
        DVec3::new(-0.6, 0.1, 0.05),
        DVec3::new(1.0, 0.2, -0.1).normalize(),
    );
    let segment = segment_to_surface(&scene, origin, dir);
    // The light faces down (edge_u × edge_v is −y), toward the sphere.
    let normal = edge_u.cross(edge_v).normalize();
    assert!(normal.y < 0.0);

    let (mean, stderr) = single_scatter_mean(&scene, &segment, 4096, (17, 3, 5));

    let (ns, na) = (400, 400);
    let area = edge_u.length() * edge_v.length();
    let mut brute = 0.0;
    for i in 0..ns {
        let x = origin + dir * (segment.length * (i as f64 + 0.5) / ns as f64);
        for j in 0..na {
            for k in 0..na {
                let y = corner
                    + edge_u * ((j as f64 + 0.5) / na as f64)
                    + edge_v * ((k as f64 + 0.5) / na as f64);
                let r = x - y;
                let r2 = r.length_squared();
                brute += normal.dot(r).max(0.0) / (r2 * r2.sqrt());
            }
        }
    }
    let sigma_s = 1e-12;
    brute *= sigma_s / (4.0 * std::f64::consts::PI) * radiance * area / (na * na) as f64
        * segment.length
        / ns as f64;
    let error = mean / brute - 1.0;
    println!(
        "quad light, eta = 1: {mean:.6e} ± {stderr:.1e} vs brute force {brute:.6e} \
         ({error:+.2e}, {:.1} standard errors)",
        (mean - brute).abs() / stderr
    );
    assert!(stderr < 5e-3 * brute, "too noisy: {stderr} of {brute}");
    assert!((mean - brute).abs() < 4.0 * stderr, "{mean} vs {brute}");
}
