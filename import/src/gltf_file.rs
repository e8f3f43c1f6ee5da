//! A glTF 2.0 file (`.gltf` with its buffers, or `.glb`) as a spindle scene: the entry point
//! of the importer, which reads the file, walks the default scene's nodes and converts what
//! each holds (a mesh, a camera, a light) by the modules beside it.
//!
//! Each triangle primitive of each mesh node becomes one object: an `obj` shape whose OBJ text
//! ([`crate::obj_text`]) holds the primitive's vertices already placed in the world (the node's
//! whole world matrix, shear and mirroring included, applied in f64), so the object's
//! `transform` is the identity. The OBJ's key in the assets is
//! `<file name>#nodes[n].mesh.primitives[p]`, which the renderer's messages then show. The
//! scene is checked with spindle's own validation; a value it refuses is reported with the
//! glTF element it came from.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3};
use spindle_common::scene::{
    Animation, CameraAnimation, Film, Integrator, Light, LightAnimation, Material, Object,
    ObjectAnimation, SceneDescription, Shape,
};
use spindle_common::scene_files::SceneFiles;

use crate::error::ImportError;
use crate::ignored::{self, Ignored};
use crate::lights::Converted;

/// Extensions the importer reads; any other in `extensionsUsed` is listed as ignored, and any
/// other in `extensionsRequired` refuses the file.
pub const SUPPORTED_EXTENSIONS: [&str; 4] = [
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_ior",
];

/// The film's width when the file does not say (glTF has no image size): the film is this
/// wide and as high as the camera's `aspectRatio` makes it (4:3 without one). `--set
/// film.width=… --set film.height=…` changes it.
pub const DEFAULT_FILM_WIDTH: u32 = 640;

/// How to import.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// The camera to render through: the name of a camera node or of a camera. `None`: the
    /// first camera in the scene's node order.
    pub camera: Option<String>,
}

/// A glTF file as a spindle scene.
pub struct Imported {
    /// The scene and the OBJ text of every mesh, keyed as its shapes name them.
    pub files: SceneFiles,
    /// One line per kind of thing the scene holds and spindle does not render, and notes on
    /// defaults taken.
    pub warnings: Vec<String>,
    /// Where each object came from (`nodes[3].mesh, meshes[0].primitives[1]`), by index.
    pub object_origins: Vec<String>,
    /// Where each light came from (`nodes[5] (KHR_lights_punctual.lights[0])`), by index.
    pub light_origins: Vec<String>,
}

/// Reads and converts the glTF file at `path` (buffers relative to it).
pub fn import_gltf(path: &Path, options: &Options) -> Result<Imported, ImportError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ImportError::new(&file, e))?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| invalid(&file, e))?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| file.clone());
    convert(&gltf, dir, &name, options)
}

/// A file the `gltf` crate refuses: its validation errors name their JSON paths.
fn invalid(file: &str, error: gltf::Error) -> ImportError {
    match error {
        gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors
                .iter()
                .take(8)
                .map(|(path, e)| format!("{path}: {e}"))
                .collect();
            ImportError::new(file, format!("invalid glTF: {}", list.join("; ")))
        }
        other => ImportError::new(file, format!("not a glTF 2.0 file: {other}")),
    }
}

fn convert(
    gltf: &gltf::Gltf,
    dir: &Path,
    name: &str,
    options: &Options,
) -> Result<Imported, ImportError> {
    let document = &gltf.document;
    let mut ignored = Ignored::default();
    for (i, extension) in document.extensions_required().enumerate() {
        if !SUPPORTED_EXTENSIONS.contains(&extension) {
            return Err(ImportError::new(
                format!("extensionsRequired[{i}]"),
                format!("{extension} is required by the file and not supported by spindle"),
            ));
        }
    }
    for extension in document.extensions_used() {
        if !SUPPORTED_EXTENSIONS.contains(&extension) {
            ignored.add(ignored::EXTENSIONS, extension);
        }
    }
    for texture in document.textures() {
        ignored.add(
            ignored::TEXTURES,
            labelled("textures", texture.index(), texture.name()),
        );
    }

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| ImportError::new("scenes", "the file has no scene"))?;
    let scene_element = format!("scenes[{}]", scene.index());
    let placed = crate::hierarchy::walk(&scene)?;
    let chosen = crate::camera::choose(
        &placed,
        options.camera.as_deref(),
        &scene_element,
        &mut ignored,
    )?;
    let buffers = crate::buffers::load_buffers(document, gltf.blob.as_deref(), dir)?;
    let animations = crate::animation::read(document, &buffers, &mut ignored)?;
    let moves = |node: usize| animations.as_ref().filter(|a| a.moves(node));
    let mut time = Animation {
        frame_rate: Some(crate::animation::FRAME_RATE),
        frames: animations.as_ref().map(|a| a.frames),
        camera: None,
        objects: Vec::new(),
        lights: Vec::new(),
    };
    if let Some(a) = moves(chosen.node) {
        let [position, look_at, up] = a.camera(document, chosen.node)?;
        time.camera = Some(CameraAnimation {
            position: Some(position),
            look_at: Some(look_at),
            up: Some(up),
            fov_y: None,
        });
    }

    let mut notes = Vec::new();
    let (width, height) = match chosen.aspect {
        Some(aspect) => (
            DEFAULT_FILM_WIDTH,
            ((f64::from(DEFAULT_FILM_WIDTH) / aspect).round() as u32).clamp(1, 16384),
        ),
        None => {
            notes.push(format!(
                "glTF: cameras of nodes[{}] has no aspectRatio; the film is {DEFAULT_FILM_WIDTH}×{} \
                 (4:3): set film.width and film.height with --set",
                chosen.node,
                DEFAULT_FILM_WIDTH * 3 / 4
            ));
            (DEFAULT_FILM_WIDTH, DEFAULT_FILM_WIDTH * 3 / 4)
        }
    };

    let mut materials: HashMap<Option<usize>, Material> = HashMap::new();
    let mut objects = Vec::new();
    let mut object_origins = Vec::new();
    let mut assets = HashMap::new();
    let mut lights = Vec::new();
    let mut light_origins = Vec::new();
    for p in &placed {
        let node = format!("nodes[{}]", p.node.index());
        if p.node.skin().is_some() {
            ignored.add(ignored::SKINS, &node);
        }
        if let Some(light) = p.node.light() {
            let element = format!("KHR_lights_punctual.lights[{}]", light.index());
            let origin = format!("{node} ({element})");
            match crate::lights::convert(&light, &p.world, &element)? {
                Converted::Light(l) => {
                    if light.range().is_some() {
                        ignored.add(ignored::LIGHT_RANGES, &origin);
                    }
                    if let Some(a) = moves(p.node.index()) {
                        let track = a.vectors(document, p.node.index(), |world| match &l {
                            Light::Directional { .. } => {
                                world.transform_vector3(DVec3::NEG_Z).to_array()
                            }
                            _ => world.transform_point3(DVec3::ZERO).to_array(),
                        })?;
                        let directional = matches!(l, Light::Directional { .. });
                        time.lights.push(LightAnimation {
                            light: lights.len(),
                            position: (!directional).then(|| track.clone()),
                            direction: directional.then_some(track),
                        });
                    }
                    lights.push(l);
                    light_origins.push(origin);
                }
                Converted::Spot => ignored.add(ignored::SPOT_LIGHTS, origin),
            }
        }
        let Some(mesh) = p.node.mesh() else {
            continue;
        };
        for primitive in mesh.primitives() {
            let element = format!("meshes[{}].primitives[{}]", mesh.index(), primitive.index());
            let origin = format!("{node}.mesh, {element}");
            if primitive.morph_targets().next().is_some() {
                ignored.add(ignored::MORPH_TARGETS, &element);
            }
            let material_of = primitive.material();
            let material = match materials.get(&material_of.index()) {
                Some(m) => m.clone(),
                None => {
                    let m = crate::material::convert(&material_of, &mut ignored)?;
                    materials.insert(material_of.index(), m.clone());
                    m
                }
            };
            // An animated node's vertices stay in its own space; its tracks place them.
            let animated = moves(p.node.index());
            let placed_by = if animated.is_some() {
                DMat4::IDENTITY
            } else {
                p.world
            };
            let Some(world) =
                crate::mesh::world_triangles(&primitive, &buffers, &placed_by, &element)?
            else {
                ignored.add(ignored::NOT_TRIANGLES, &element);
                continue;
            };
            if world.triangles.is_empty() {
                return Err(ImportError::new(
                    &element,
                    format!("used by {node}: has no triangle of three distinct vertices"),
                ));
            }
            for v in &world.positions {
                spindle_common::validate::check_in_extent(v.to_array())
                    .map_err(|problem| ImportError::new(&origin, problem))?;
            }
            if matches!(material, Material::Dielectric { .. }) {
                check_closed(&world, &element, &node, material_of.index())?;
            }
            let key = format!("{name}#{node}.mesh.primitives[{}]", primitive.index());
            let text = crate::obj_text::obj_text(
                &world.positions,
                world.normals.as_deref(),
                &world.triangles,
            );
            assets.insert(key.clone(), text.into_bytes());
            objects.push(Object {
                shape: Shape::Obj {
                    path: key,
                    // glTF: without normals, flat shading.
                    crease_angle: world.normals.is_none().then_some(0.0),
                },
                transform: Default::default(),
                material,
            });
            if let Some(a) = animated {
                let (translate, rotation, scale) = a.placement(document, p.node.index())?;
                time.objects.push(ObjectAnimation {
                    object: objects.len() - 1,
                    translate: Some(translate),
                    rotation: Some(rotation),
                    scale: Some(scale),
                });
            }
            object_origins.push(origin);
        }
    }

    let desc = SceneDescription {
        camera: chosen.camera,
        film: Film {
            width,
            height,
            spp: 4,
            seed: 0,
            target_error: None,
            time_budget_s: None,
            half: false,
            passes: Vec::new(),
        },
        lights,
        objects,
        background: [0.0; 3],
        integrator: Integrator::default(),
        animation: animations.is_some().then_some(time),
    };
    desc.validate().map_err(|e| {
        let origin = origin_of(&e.path, chosen.node, &object_origins, &light_origins);
        ImportError::new(origin, format!("as {}: {}", e.path, e.problem))
    })?;
    let mut warnings = ignored.warnings();
    warnings.extend(notes);
    Ok(Imported {
        files: SceneFiles { desc, assets },
        warnings,
        object_origins,
        light_origins,
    })
}

/// `textures[2] "wood"`.
fn labelled(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("{kind}[{index}] {name:?}"),
        None => format!("{kind}[{index}]"),
    }
}

/// A dielectric must bound a volume: every edge (vertices welded by exact position, as the
/// renderer welds them) shared by exactly two triangles wound opposite ways.
fn check_closed(
    world: &crate::mesh::WorldTriangles,
    element: &str,
    node: &str,
    material: Option<usize>,
) -> Result<(), ImportError> {
    let mesh = spindle_render::mesh::TriangleMesh::new(
        world.positions.clone(),
        None,
        world.triangles.clone(),
    )
    .map_err(|e| ImportError::new(element, e))?;
    let report = mesh.report();
    if report.closed {
        return Ok(());
    }
    let material = material.map_or("the default material".to_string(), |i| {
        format!("materials[{i}]")
    });
    Err(ImportError::new(
        element,
        format!(
            "used by {node} with the transmissive {material}, but not a closed manifold mesh \
             ({} boundary edges, or edges of more than two triangles): a dielectric must bound \
             a volume",
            report.boundary_edges
        ),
    ))
}

/// The glTF element a spindle scene path (`objects[2].material.eta`, `lights[0].position`,
/// `camera.up`) came from.
fn origin_of(path: &str, camera_node: usize, objects: &[String], lights: &[String]) -> String {
    let index = |prefix: &str| {
        path.strip_prefix(prefix)
            .and_then(|rest| rest.split(']').next())
            .and_then(|i| i.parse::<usize>().ok())
    };
    if let Some(i) = index("objects[")
        && let Some(origin) = objects.get(i)
    {
        return origin.clone();
    }
    if let Some(i) = index("lights[")
        && let Some(origin) = lights.get(i)
    {
        return origin.clone();
    }
    if path.starts_with("camera") {
        return format!("nodes[{camera_node}].camera");
    }
    "the converted scene".to_string()
}
