//! The benchmark scenes: one translucent object, one point light, a black background.
//!
//! Every model is placed inside the unit sphere at the origin (OBJ meshes are scaled and centred
//! from their bounds), seen by the same camera and lit by the same point light, so studies differ
//! only in the mesh and the integrator settings. A point light keeps the interval method
//! deterministic: the only randomness left is the camera jitter, which is the same for every
//! method (a pure hash of seed, pixel and sample), so errors compare methods on identical rays.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use spindle_common::scene as desc;
use spindle_render::obj::parse_obj;
use spindle_render::{Assets, Scene};

/// The meshes of `../shared/meshes` the issue names, smallest first.
pub const SHARED_MESHES: [&str; 4] = [
    "bunny-4k.obj",
    "bunny-16k.obj",
    "bunny-70k.obj",
    "nefertiti-100k.obj",
];

/// A model to render: a shape, the transform into the unit sphere, and its bytes if any.
#[derive(Clone)]
pub struct Model {
    /// Short name for tables and file names (`sphere-5120`, `bunny-4k`).
    pub name: String,
    /// `sphere`, `bumpy` or `mesh`: the family a scaling curve is drawn through.
    pub family: &'static str,
    pub shape: desc::Shape,
    pub transform: desc::Transform,
    pub assets: Assets,
    pub triangles: usize,
    /// The medium's σ_t is `density × (0.5, 1, 2)` per unit of the unit-sphere-sized model.
    pub density: f64,
}

impl Model {
    /// The procedural icosphere with `20·4^subdivisions` triangles.
    pub fn sphere(subdivisions: u32) -> Model {
        let triangles = 20 * 4usize.pow(subdivisions);
        Model {
            name: format!("sphere-{triangles}"),
            family: "sphere",
            shape: desc::Shape::Icosphere {
                radius: 1.0,
                subdivisions,
            },
            transform: desc::Transform::default(),
            assets: Assets::new(),
            triangles,
            density: 1.0,
        }
    }

    /// The bumpy sphere (radius 0.85, ±15 % bumps, so it stays inside the unit sphere).
    pub fn bumpy(subdivisions: u32) -> Model {
        let triangles = 20 * 4usize.pow(subdivisions);
        Model {
            name: format!("bumpy-{triangles}"),
            family: "bumpy",
            shape: desc::Shape::BumpySphere {
                radius: 0.85,
                subdivisions,
                amplitude: 0.15,
                frequency: 3.0,
                seed: 3,
            },
            transform: desc::Transform::default(),
            assets: Assets::new(),
            triangles,
            density: 1.0,
        }
    }

    /// An OBJ file, scaled and centred so its bounding box fits the unit sphere.
    pub fn mesh(path: &Path) -> Result<Model> {
        let bytes =
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        let mesh = parse_obj(&bytes).with_context(|| format!("invalid mesh {}", path.display()))?;
        let (lo, hi) = mesh.bounds();
        let centre = (lo + hi) * 0.5;
        let half_diagonal = (hi - lo).length() * 0.5;
        let scale = 1.0 / half_diagonal;
        // The absolute path is the asset key, so scene files written elsewhere still find it.
        let key = std::fs::canonicalize(path)
            .unwrap_or_else(|_| path.to_path_buf())
            .display()
            .to_string();
        let mut assets = Assets::new();
        assets.insert(key.clone(), bytes);
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| key.clone());
        Ok(Model {
            name,
            family: "mesh",
            shape: desc::Shape::Obj {
                path: key,
                crease_angle: None,
            },
            transform: desc::Transform {
                scale: [scale; 3],
                rotate_deg: [0.0; 3],
                translate: (-centre * scale).to_array(),
            },
            assets,
            triangles: mesh.triangle_count(),
            density: 1.0,
        })
    }

    /// The same model in a medium `density` times as dense (named `<name>-dense<density>`).
    pub fn dense(mut self, density: f64) -> Model {
        self.name = format!("{}-dense{density}", self.name);
        self.density = density;
        self
    }

    /// The scene: this model in a glass-like medium, seen by the benchmark camera.
    pub fn scene(
        &self,
        film: desc::Film,
        single_scatter: desc::SingleScatter,
    ) -> desc::SceneDescription {
        desc::SceneDescription {
            camera: desc::Camera {
                position: [0.0, 0.3, 4.2],
                look_at: [0.0, 0.0, 0.0],
                up: [0.0, 1.0, 0.0],
                fov_y: 32.0,
            },
            film,
            lights: vec![desc::Light::Point {
                position: [2.0, 3.0, 2.5],
                intensity: [40.0, 40.0, 40.0],
            }],
            objects: vec![desc::Object {
                shape: self.shape.clone(),
                transform: self.transform.clone(),
                material: desc::Material::Dielectric {
                    eta: 1.5,
                    medium: desc::Medium {
                        sigma_t: [0.5, 1.0, 2.0].map(|s| s * self.density),
                        albedo: [0.9, 0.9, 0.9],
                        phase: desc::Phase::Isotropic,
                    },
                },
            }],
            background: [0.0, 0.0, 0.0],
            // The benchmarks measure the single_scatter layer: no multiple scattering's time in
            // their figures.
            integrator: desc::Integrator {
                single_scatter,
                multiple_scatter: desc::MultipleScatter {
                    max_order: 1,
                    ..desc::MultipleScatter::default()
                },
                ..desc::Integrator::default()
            },
            animation: None,
        }
    }
}

/// A square film of `size` pixels with `spp` samples and a fixed seed.
pub fn film(size: u32, spp: u32) -> desc::Film {
    desc::Film {
        width: size,
        height: size,
        spp,
        seed: 7,
        target_error: None,
        time_budget_s: None,
        half: false,
        passes: Vec::new(),
    }
}

/// The named shared meshes found in `dir`, and a printed reason for each one missing.
pub fn shared_meshes(dir: &Path, names: &[&str]) -> (Vec<Model>, Vec<String>) {
    let mut found = Vec::new();
    let mut skipped = Vec::new();
    for name in names {
        let path: PathBuf = dir.join(name);
        if !path.is_file() {
            skipped.push(format!(
                "skipping {}: not found (the shared meshes live in ../shared/meshes)",
                path.display()
            ));
            continue;
        }
        match Model::mesh(&path) {
            Ok(model) => found.push(model),
            Err(e) => skipped.push(format!("skipping {}: {e:#}", path.display())),
        }
    }
    (found, skipped)
}

/// Builds `model` with `single_scatter` settings on `film`.
pub fn build(
    model: &Model,
    film: desc::Film,
    single_scatter: desc::SingleScatter,
) -> Result<Scene> {
    let desc = model.scene(film, single_scatter);
    Scene::build(&desc, &model.assets).with_context(|| format!("benchmark scene {}", model.name))
}

/// Single-scatter settings for `method`, everything else at its default.
pub fn settings(method: desc::ScatterMethod) -> desc::SingleScatter {
    desc::SingleScatter {
        method,
        ..desc::SingleScatter::default()
    }
}
