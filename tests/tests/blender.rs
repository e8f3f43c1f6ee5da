//! A scene made in Blender and exported by Blender's own glTF exporter (a second tool), then
//! imported by spindle: the camera, the sphere and the light where the Blender script put them,
//! the materials' values as it set them, and the render through the local farm the same bits
//! as `--workers 0`. Skips with a printed reason when `blender` is not on PATH (CI installs it:
//! `.ci/run`).

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use glam::DVec3;
use serde_json::Value;
use spindle_common::image::read_exr;
use spindle_common::scene::{Light, Material, Phase};
use spindle_import::{Options, import_gltf};
use spindle_render::camera::Camera;
use spindle_tests::{assert_bit_identical, output_text, run_spindle};

/// Blender's z-up coordinates as glTF's y-up ones: the exporter's `export_yup`, (x, y, z) →
/// (x, z, −y).
fn y_up(v: &Value) -> DVec3 {
    let c: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    DVec3::new(c[0], c[2], -c[1])
}

fn number(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

fn triple(v: &Value) -> [f64; 3] {
    let c: Vec<f64> = v.as_array().unwrap().iter().map(number).collect();
    [c[0], c[1], c[2]]
}

fn blender_available() -> bool {
    Command::new("blender")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Runs the scene script; returns what it set.
fn export_scene(dir: &Path) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("blender/glass_scene.py");
    let out = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(&script)
        .arg("--")
        .arg(dir.join("scene.glb"))
        .arg(dir.join("set.json"))
        .output()
        .expect("blender runs");
    assert!(
        out.status.success() && dir.join("scene.glb").is_file(),
        "{}",
        output_text(&out)
    );
    serde_json::from_str(&std::fs::read_to_string(dir.join("set.json")).unwrap()).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_blender_scene_imports_where_blender_put_it_and_renders_alike_on_the_farm() {
    if !blender_available() {
        eprintln!("skipped: `blender` is not on PATH (apt-get install blender)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let set = export_scene(dir.path());
    let glb = dir.path().join("scene.glb");
    let imported = import_gltf(&glb, &Options::default()).unwrap();
    let desc = &imported.files.desc;

    // The camera: Blender's 160 × 120 render → aspect 4:3 → a 640 × 480 film; its vertical
    // angle; the sphere's centre (what it was aimed at) at the image centre, and points along
    // Blender's camera right and up axes at the pixels a pinhole puts them.
    let cam = &set["camera"];
    let aspect = number(&cam["aspect"]);
    assert_eq!((desc.film.width, desc.film.height), (640, 480));
    assert!((aspect - 4.0 / 3.0).abs() < 1e-12);
    let fov_y = number(&cam["fov_y"]);
    assert!((desc.camera.fov_y - fov_y.to_degrees()).abs() < 1e-4);
    let position = y_up(&cam["location"]);
    assert!((DVec3::from_array(desc.camera.position) - position).length() < 1e-5);
    let camera = Camera::new(&desc.camera, desc.film.width, desc.film.height).unwrap();
    let centre = y_up(&set["sphere"]["centre"]);
    let miss = |(x, y): (f64, f64), point: DVec3| {
        let ray = camera.ray(x, y);
        ray.dir.angle_between((point - ray.origin).normalize())
    };
    assert!(miss((320.0, 240.0), centre) < 1e-5);
    let (right, up) = (y_up(&cam["right"]), y_up(&cam["up"]));
    let depth = (centre - position).length();
    let tan = (fov_y / 2.0).tan();
    for (a, b) in [(0.8, 0.3), (-1.1, -0.6)] {
        let point = centre + right * a + up * b;
        let x = 320.0 + 320.0 * a / (depth * tan * aspect);
        let y = 240.0 - 240.0 * b / (depth * tan);
        assert!(miss((x, y), point) < 1e-5, "{point} at ({x}, {y})");
    }

    // The objects: the floor, diffuse; the sphere, every vertex at the radius from the centre
    // the script gave, a dielectric with the script's values.
    assert_eq!(desc.objects.len(), 2);
    let scene = spindle_render::Scene::build(desc, &imported.files.assets).unwrap();
    let glass = desc
        .objects
        .iter()
        .position(|o| matches!(o.material, Material::Dielectric { .. }))
        .expect("a dielectric");
    let radius = number(&set["sphere"]["radius"]);
    let mesh = &scene.objects()[glass].mesh;
    let off = mesh
        .positions()
        .iter()
        .map(|p| ((*p - centre).length() - radius).abs())
        .fold(0.0, f64::max);
    assert!(off < 1e-5, "a vertex is {off} off the sphere");
    let (lo, hi) = mesh.bounds();
    assert!(((lo + hi) / 2.0 - centre).length() < 1e-5);
    let g = &set["glass"];
    let Material::Dielectric { eta, medium } = &desc.objects[glass].material else {
        unreachable!()
    };
    assert!((eta - number(&g["ior"])).abs() < 1e-6);
    // Blender's absorption density ρ is 1 / attenuationDistance: σt = −ln(c)·ρ.
    let density = number(&g["density"]);
    for (s, c) in medium.sigma_t.iter().zip(triple(&g["attenuation_colour"])) {
        let want = -c.ln() * density;
        assert!((s - want).abs() < 1e-6, "{:?}", medium.sigma_t);
    }
    assert_eq!(medium.albedo, triple(&g["albedo"]));
    assert_eq!(
        medium.phase,
        Phase::Hg {
            g: number(&g["phase_g"])
        }
    );
    let floor = 1 - glass;
    let Material::Diffuse { reflectance } = &desc.objects[floor].material else {
        panic!("the floor is {:?}", desc.objects[floor].material)
    };
    for (r, c) in reflectance.iter().zip(triple(&set["floor"]["colour"])) {
        assert!((r - c).abs() < 1e-6);
    }

    // The light: where the script put it; P W of an isotropic point is P/(4π) W/sr.
    let lamp = &set["lamp"];
    let [
        Light::Point {
            position,
            intensity,
        },
    ] = &desc.lights[..]
    else {
        panic!("{:?}", desc.lights)
    };
    assert!((DVec3::from_array(*position) - y_up(&lamp["location"])).length() < 1e-5);
    let power = number(&lamp["power"]);
    for (i, c) in intensity.iter().zip(triple(&lamp["colour"])) {
        let want = c * power / (4.0 * std::f64::consts::PI);
        assert!((i - want).abs() < 1e-5 * want, "{intensity:?}");
    }

    // Rendered in process and on the local farm: the same bits.
    let g = glb.to_str().unwrap();
    let small = [
        "--set",
        "film.width=40",
        "--set",
        "film.height=30",
        "--spp",
        "2",
    ];
    let mut here = vec!["render", g, "--workers", "0", "-o", "here.exr"];
    here.extend(small);
    let mut farm = vec!["render", g, "-o", "farm.exr"];
    farm.extend(small);
    for args in [here, farm] {
        let out = run_spindle(Some(dir.path()), &args, None, Duration::from_secs(300)).await;
        assert!(out.status.success(), "{}", output_text(&out));
    }
    let here = read_exr(dir.path().join("here.exr")).unwrap();
    let farm = read_exr(dir.path().join("farm.exr")).unwrap();
    assert_bit_identical(&here, &farm);
    // Not a black image: the floor is lit, and the glass scatters.
    let total = here.layers()[0];
    assert!(total.iter().any(|&v| v > 0.0));
}
