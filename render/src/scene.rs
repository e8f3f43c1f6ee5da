//! The renderer's scene: validated, world-space, ready to trace.
//!
//! [`Scene::build`] turns the JSON description (`spindle_common::scene::SceneDescription`) and the bytes of
//! its OBJ files ([`Assets`]) into meshes in world space, one BVH per object (for an
//! integrator's per-object descent), one scene-wide BVH over every triangle (for camera, shadow
//! and visibility rays), materials, lights and the camera. Every value is checked on the way in:
//! a bad one is a [`SceneError`] naming its JSON path. Problems that still render (an open
//! dielectric mesh, degenerate triangles) are collected in [`Scene::warnings`].

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;
use spindle_common::scene as desc;
use spindle_common::validate::{
    MAX_TRIANGLES, SceneError, check_in_extent, check_obj_placement, count_obj_triangles,
    scene_triangles,
};

use crate::Rgb;
use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::contact::Contacts;
use crate::containment;
use crate::flat_face::FlatFaces;
use crate::interfaces::{self, SecondInterface};
use crate::light::{Light, SceneSphere};
use crate::medium::Medium;
use crate::mesh::{MeshReport, TriangleMesh};
use crate::mistakes;
use crate::nesting::{self, Route, absolute_eta, relative_eta};
use crate::obj::parse_obj_with;
use crate::procedural::{MAX_SUBDIVISIONS, bumpy_sphere, icosphere};
use crate::scatter::prune::beam_table::BeamTable;
use crate::scatter::prune::bounds::PruneBounds;
use crate::transform::Transform;
use crate::wavy_box::{WaveField, wavy_box};

/// The bytes of each `obj` shape's file, keyed by the shape's `path` string exactly as written
/// in the scene. The caller reads the files (or fetches them by hash); the renderer reads none.
pub type Assets = HashMap<String, Vec<u8>>;

/// An error of a part of the scene whose own message starts with a field name (`sigma_t: must be
/// ...`): the field joins the path (`objects[0].material.medium.sigma_t`).
fn nested_error(path: impl Into<String>, problem: impl ToString) -> SceneError {
    let (path, problem) = (path.into(), problem.to_string());
    match problem.split_once(": ") {
        Some((field, rest))
            if !field.is_empty()
                && field
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.') =>
        {
            SceneError::new(format!("{path}.{field}"), rest)
        }
        _ => SceneError::new(path, problem),
    }
}

/// A smooth refractive interface around a homogeneous medium. `eta` = n_medium / n_air ≥ 1 (the
/// medium's own index; across the surface of an object nested in another medium the index that
/// counts is [`Scene::relative_eta`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dielectric {
    pub eta: f64,
    pub medium: Medium,
}

/// What an object is made of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    Dielectric(Dielectric),
    /// Opaque Lambertian, lit directly by every light (no indirect light).
    Diffuse {
        reflectance: Rgb,
    },
}

/// One object in world space.
#[derive(Debug, Clone)]
pub struct Object {
    /// `objects[i]`, for messages.
    pub name: String,
    pub mesh: TriangleMesh,
    /// A BVH over this object's triangles alone; hits report indices into `mesh`.
    pub bvh: Bvh,
    /// Spheres, normal cones and planes of its triangles and BVH nodes, for the single-scattering
    /// descent.
    pub bounds: PruneBounds,
    pub material: Material,
    pub report: MeshReport,
}

/// A short description of a built scene, for logs and EXR headers.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSummary {
    pub objects: usize,
    pub triangles: usize,
    pub lights: usize,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub warnings: Vec<String>,
}

/// The largest `max_depth` accepted (a camera path recurses once per bounce).
pub const MAX_DEPTH_LIMIT: u32 = 256;

/// At most this many point lights have their beams tabled for every dielectric object (a table
/// costs 80 bytes per BVH node and per triangle); the descents of other lights compute their
/// beams node by node, to the same bits.
pub const BEAM_TABLE_BUDGET: usize = 2;

/// A scene ready to render.
#[derive(Debug, Clone)]
pub struct Scene {
    objects: Vec<Object>,
    bvh: Bvh,
    /// `first_triangle[o]` is the scene-wide index of object `o`'s first triangle.
    first_triangle: Vec<u32>,
    lights: Vec<Light>,
    camera: Camera,
    film: desc::Film,
    background: Rgb,
    integrator: desc::Integrator,
    scale: f64,
    /// The dielectric object whose medium holds the camera, if any.
    camera_medium: Option<usize>,
    /// Per light, the dielectric object whose medium holds it, if any.
    light_media: Vec<Option<usize>>,
    /// Per object, the dielectric object whose medium surrounds it (`nesting`), if any.
    outer: Vec<Option<usize>>,
    /// The shared interfaces between media whose surfaces coincide (`contact`).
    contacts: Contacts,
    /// Per object, its flat faces if a dielectric lies inside it (empty otherwise).
    flat_faces: Vec<FlatFaces>,
    /// Objects and lights whose light would cross a second dielectric interface.
    second_interfaces: Vec<SecondInterface>,
    /// `beam_tables[o][j]`: object `o`'s beams for point light `j` (see [`beam_tables`]).
    beam_tables: Vec<Vec<Option<BeamTable>>>,
    warnings: Vec<String>,
}

impl Scene {
    /// Builds the scene; OBJ shapes are looked up in `assets` by their `path` string.
    pub fn build(scene: &desc::SceneDescription, assets: &Assets) -> Result<Scene, SceneError> {
        // The scene format's own rules first (the same checks `Scene::from_json` applies), so
        // a description that did not come through JSON is held to them too.
        scene.validate()?;
        let film = scene.film.clone();
        if film.spp == 0 {
            return Err(SceneError::new("film.spp", "must be >= 1"));
        }
        let camera = Camera::new(&scene.camera, film.width, film.height).map_err(|e| match e {
            crate::camera::CameraError::Size(..) => SceneError::new("film", e),
            _ => nested_error("camera", e),
        })?;
        let background = DVec3::from_array(scene.background);
        if !background.is_finite() || background.min_element() < 0.0 {
            return Err(SceneError::new("background", "must be finite and >= 0"));
        }
        let integrator = scene.integrator.clone();
        if integrator.max_depth > MAX_DEPTH_LIMIT {
            return Err(SceneError::new(
                "integrator.max_depth",
                format!("must be <= {MAX_DEPTH_LIMIT}"),
            ));
        }
        // Counted before any geometry is built, by the bound the coordinator checks too.
        scene_triangles(
            scene,
            |path| match assets.get(path) {
                Some(bytes) => count_obj_triangles(bytes).map_err(|e| format!("{path}: {e}")),
                None => Err(format!("no file was supplied for {path:?}")),
            },
            MAX_TRIANGLES,
        )?;
        let objects = scene
            .objects
            .par_iter()
            .enumerate()
            .map(|(i, o)| build_object(i, o, assets))
            .collect::<Result<Vec<_>, _>>()?;
        let (objects, smoothed): (Vec<Object>, Vec<Option<SmoothedCreases>>) =
            objects.into_iter().unzip();

        let mut warnings = Vec::new();
        for ((o, d), smoothed) in objects.iter().zip(&scene.objects).zip(smoothed) {
            let what = match &d.shape {
                desc::Shape::Obj { path, .. } => format!("{} ({path})", o.name),
                _ => o.name.clone(),
            };
            if let Some(SmoothedCreases { sharp, shared }) = smoothed {
                warnings.push(format!(
                    "{what}: the OBJ has no normals and {sharp} of its {shared} edges are sharper \
                     than {SHARP_EDGE_DEG}°; they are smoothed over (set \
                     {}.shape.crease_angle, e.g. {SHARP_EDGE_DEG}, to keep them sharp)",
                    o.name
                ));
            }
            let flipped = mistakes::flipped_faces(&what, &o.report);
            if matches!(o.material, Material::Dielectric(_))
                && !o.report.closed
                && flipped.is_none()
            {
                warnings.push(format!(
                    "{what}: the dielectric mesh is not closed ({} boundary edges); rays that \
                     leave through a hole are treated as leaving the object",
                    o.report.boundary_edges
                ));
            }
            warnings.extend(flipped);
            if o.report.degenerate > 0 {
                warnings.push(format!(
                    "{what}: {} degenerate triangles (never hit)",
                    o.report.degenerate
                ));
            }
        }

        let mut first_triangle = Vec::with_capacity(objects.len());
        let mut all = Vec::new();
        for o in &objects {
            first_triangle.push(all.len() as u32);
            all.extend((0..o.mesh.triangle_count()).map(|t| o.mesh.corners(t)));
        }
        if all.len() > u32::MAX as usize / 2 {
            return Err(SceneError::new("objects", "too many triangles"));
        }
        let bvh = Bvh::build(&all);

        let scale = objects
            .iter()
            .map(|o| {
                let (lo, hi) = o.mesh.bounds();
                (hi - lo)
                    .max_element()
                    .max(lo.abs().max(hi.abs()).max_element())
            })
            .fold(0.0f64, f64::max);
        let scale = if scale > 0.0 && scale.is_finite() {
            scale
        } else {
            1.0
        };

        let reach = objects_sphere(&objects);
        let lights = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| Light::new(l, reach).map_err(|e| nested_error(format!("lights[{i}]"), e)))
            .collect::<Result<Vec<_>, _>>()?;

        let light_centers: Vec<DVec3> = lights.iter().map(Light::center).collect();
        let contacts = Contacts::find(&objects, scale)?;
        check_media_layout(&objects, camera.position(), &light_centers)?;
        warnings.extend(mistakes::lights_facing_away(&objects, &lights));
        warnings.extend(mistakes::camera_inside(
            &objects,
            camera.position(),
            &light_centers,
        ));
        let camera_medium = nesting::innermost_holding(&objects, camera.position(), None);
        let mut light_media = Vec::with_capacity(lights.len());
        for (j, light) in lights.iter().enumerate() {
            check_straddle(&objects, j, light)?;
            light_media.push(nesting::innermost_holding(&objects, light.center(), None));
        }
        let outer = nesting::outer_media(&objects, &contacts);
        let flat_faces: Vec<FlatFaces> = (0..objects.len())
            .map(|q| {
                let surrounds_dielectric = objects.iter().enumerate().any(|(o, object)| {
                    outer[o] == Some(q) && matches!(object.material, Material::Dielectric(_))
                });
                if surrounds_dielectric {
                    FlatFaces::of(&objects[q].mesh, scale)
                } else {
                    FlatFaces::default()
                }
            })
            .collect();
        let second_interfaces = interfaces::second_interfaces(
            &objects,
            &interfaces::Layout {
                lights: &lights,
                light_media: &light_media,
                outer: &outer,
                flat_faces: &flat_faces,
            },
        );
        warnings.extend(second_interfaces.iter().map(SecondInterface::describe));

        let beam_tables = beam_tables(&objects, &outer, &lights, &light_media);

        Ok(Scene {
            objects,
            bvh,
            first_triangle,
            lights,
            camera,
            film,
            background,
            integrator,
            scale,
            camera_medium,
            light_media,
            outer,
            contacts,
            flat_faces,
            second_interfaces,
            beam_tables,
            warnings,
        })
    }

    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The BVH over every object's triangles; hit indices are scene-wide, see [`Scene::locate`].
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// `(object, triangle within the object)` of a scene-wide triangle index.
    pub fn locate(&self, triangle: u32) -> (usize, usize) {
        let object = self.first_triangle.partition_point(|&f| f <= triangle) - 1;
        (object, (triangle - self.first_triangle[object]) as usize)
    }

    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Object `object`'s beams for light `light`, if it is a point light they were tabled for.
    pub fn beam_table(&self, object: usize, light: usize) -> Option<&BeamTable> {
        self.beam_tables.get(object)?.get(light)?.as_ref()
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The dielectric object whose medium holds the camera (camera paths start in it), if any.
    pub fn camera_medium(&self) -> Option<usize> {
        self.camera_medium
    }

    /// The (object, light) pairs whose light would reach part of the object through a second
    /// dielectric interface (not modelled: blocked), with the share affected.
    pub fn second_interfaces(&self) -> &[SecondInterface] {
        &self.second_interfaces
    }

    /// Sentences naming each dielectric object that no light reaches by a modelled route
    /// ([`Route`]) — every light is in a medium other than its own and the one around it, or
    /// wholly behind another dielectric (a second interface that is not a flat face of the medium
    /// around it) — so its medium would render black. Empty when the scene has no lights (a dark
    /// scene is what was asked).
    pub fn unlit_media(&self) -> Vec<String> {
        if self.lights.is_empty() {
            return Vec::new();
        }
        let mut unlit = Vec::new();
        for (o, object) in self.objects.iter().enumerate() {
            if !matches!(object.material, Material::Dielectric(_)) {
                continue;
            }
            let reaches = |j: usize| match self.route(o, j) {
                Route::Inside => true,
                Route::Around | Route::FlatFaces { .. } => !self
                    .second_interfaces
                    .iter()
                    .any(|s| s.object == o && s.light == j && s.share >= 1.0),
                Route::Unmodelled => false,
            };
            if !(0..self.lights.len()).any(reaches) {
                unlit.push(format!(
                    "{} gets no light: every light reaches its medium only through a second \
                     refractive interface that is not modelled (another dielectric in the way, \
                     a curved surface of the medium around it, or a light that is not \
                     directional outside it, or in another medium), so it would render black",
                    object.name
                ));
            }
        }
        unlit
    }

    /// The dielectric object whose medium holds light `light` (it lights that medium along
    /// straight paths, with no interface), if any.
    pub fn light_medium(&self, light: usize) -> Option<usize> {
        self.light_media[light]
    }

    /// The dielectric object whose medium surrounds object `o`, if any (`nesting`).
    pub fn outer(&self, o: usize) -> Option<usize> {
        self.outer[o]
    }

    /// The dielectric object whose medium lies beyond object `o`'s surface at `p` (with the
    /// unit geometric normal `normal` there): a partner whose surface coincides there
    /// (`contact`), else the medium around `o`.
    pub fn across(&self, o: usize, p: DVec3, normal: DVec3) -> Option<usize> {
        self.contacts
            .across(&self.objects, o, p, normal, self.outer[o], self.scale)
    }

    /// The objects whose surfaces coincide with part of object `o`'s (`contact`).
    pub fn partners(&self, o: usize) -> &[usize] {
        self.contacts.partners(o)
    }

    /// Object `o`'s index relative to the medium around it (1 if it is not a dielectric).
    pub fn relative_eta(&self, o: usize) -> f64 {
        relative_eta(&self.objects, &self.outer, o)
    }

    /// The refractive index of the medium of `medium` (the air's, 1, for `None`).
    pub fn absolute_eta(&self, medium: Option<usize>) -> f64 {
        absolute_eta(&self.objects, medium)
    }

    /// Object `o`'s flat faces (`flat_face`), found only for objects with a dielectric inside.
    pub fn flat_faces(&self, o: usize) -> &FlatFaces {
        &self.flat_faces[o]
    }

    /// How the light of `lights[light]` reaches the medium of object `o`.
    pub fn route(&self, o: usize, light: usize) -> Route {
        nesting::route(
            o,
            &self.lights[light],
            self.light_media[light],
            &self.outer,
            &self.flat_faces,
        )
    }

    pub fn film(&self) -> &desc::Film {
        &self.film
    }

    pub fn background(&self) -> Rgb {
        self.background
    }

    pub fn integrator(&self) -> &desc::Integrator {
        &self.integrator
    }

    /// The size of the scene's geometry (largest of its extent and its largest coordinate), the
    /// unit of every geometric tolerance (see `ray::Ray::leaving`).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Problems that do not stop the render (open dielectric meshes, degenerate triangles).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    pub fn triangle_count(&self) -> usize {
        self.bvh.triangle_count()
    }

    pub fn summary(&self) -> SceneSummary {
        SceneSummary {
            objects: self.objects.len(),
            triangles: self.triangle_count(),
            lights: self.lights.len(),
            width: self.film.width,
            height: self.film.height,
            spp: self.film.spp,
            warnings: self.warnings.clone(),
        }
    }
}

/// Edges sharper than this (degrees) in an OBJ without normals and without a crease angle…
const SHARP_EDGE_DEG: f64 = 60.0;
/// …in at least this share of its edges make a warning: a cube's creases are smoothed into a
/// blob, which is rarely meant. Scanned meshes have a few per cent of such edges from noise.
const SHARP_EDGE_SHARE: f64 = 0.1;

/// An OBJ without normals whose many sharp edges were smoothed over.
struct SmoothedCreases {
    sharp: usize,
    shared: usize,
}

fn build_object(
    index: usize,
    object: &desc::Object,
    assets: &Assets,
) -> Result<(Object, Option<SmoothedCreases>), SceneError> {
    let mut smoothed = None;
    let name = format!("objects[{index}]");
    let field = |f: &str| format!("{name}.{f}");
    let positive = |f: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(SceneError::new(
                field(f),
                format!("must be finite and > 0, got {v}"),
            ))
        }
    };
    let subdivisions = |s: u32| {
        if s <= MAX_SUBDIVISIONS {
            Ok(())
        } else {
            Err(SceneError::new(
                field("shape.subdivisions"),
                format!("must be <= {MAX_SUBDIVISIONS}, got {s}"),
            ))
        }
    };
    let local = match &object.shape {
        desc::Shape::Obj { path, crease_angle } => {
            let bytes = assets.get(path).ok_or_else(|| {
                SceneError::new(
                    field("shape.path"),
                    format!("no file was supplied for {path:?}"),
                )
            })?;
            let obj = parse_obj_with(bytes, crease_angle.map(f64::to_radians))
                .map_err(|e| SceneError::new(field("shape.path"), format!("{path}: {e}")))?;
            // The coordinator's check at submission, so a worker refuses nothing it admitted.
            check_obj_placement(bytes, &object.transform)
                .map_err(|e| SceneError::new(field("transform"), format!("{path}: {e}")))?;
            if !obj.normals_given && crease_angle.is_none() {
                let (sharp, shared) = obj.mesh.sharp_edges(SHARP_EDGE_DEG.to_radians());
                if sharp as f64 >= SHARP_EDGE_SHARE * shared as f64 && sharp > 0 {
                    smoothed = Some(SmoothedCreases { sharp, shared });
                }
            }
            obj.mesh
        }
        &desc::Shape::Icosphere {
            radius,
            subdivisions: s,
        } => {
            positive("shape.radius", radius)?;
            subdivisions(s)?;
            icosphere(radius, s)
        }
        &desc::Shape::BumpySphere {
            radius,
            subdivisions: s,
            amplitude,
            frequency,
            seed,
        } => {
            positive("shape.radius", radius)?;
            subdivisions(s)?;
            if !(amplitude.is_finite() && amplitude.abs() < 1.0) {
                return Err(SceneError::new(
                    field("shape.amplitude"),
                    format!("must be in (-1, 1), got {amplitude}"),
                ));
            }
            if !(frequency.is_finite() && frequency >= 0.0) {
                return Err(SceneError::new(
                    field("shape.frequency"),
                    format!("must be finite and >= 0, got {frequency}"),
                ));
            }
            bumpy_sphere(radius, s, amplitude, frequency, seed)
        }
        // Its sizes and waves were checked by `SceneDescription::validate`, which `Scene::build`
        // runs first.
        desc::Shape::Box { size, waves } => {
            let surface = waves.as_ref().map(|w| {
                (
                    WaveField::new(w.amplitude, w.wavelength, w.seed),
                    w.segments,
                )
            });
            wavy_box(
                DVec3::from_array(*size),
                surface.as_ref().map(|(field, segments)| (field, *segments)),
            )
        }
    };
    let transform =
        Transform::new(&object.transform).map_err(|e| nested_error(field("transform"), e))?;
    let mesh = transform.apply(&local);
    // f32 boxes and f64 solves are meaningful only within the scene extent the format allows
    // (an OBJ's own coordinates are not seen by `validate`; its file was checked placed, above).
    for p in mesh.positions() {
        check_in_extent(p.to_array()).map_err(|e| SceneError::new(field("transform"), e))?;
    }
    let material = match &object.material {
        desc::Material::Dielectric { eta, medium } => {
            if !(eta.is_finite() && *eta >= 1.0) {
                return Err(SceneError::new(
                    field("material.eta"),
                    format!("must be finite and >= 1 (denser than air), got {eta}"),
                ));
            }
            Material::Dielectric(Dielectric {
                eta: *eta,
                medium: Medium::new(medium)
                    .map_err(|e| nested_error(field("material.medium"), e))?,
            })
        }
        desc::Material::Diffuse { reflectance } => {
            let r = DVec3::from_array(*reflectance);
            if !r.is_finite() || r.min_element() < 0.0 || r.max_element() > 1.0 {
                return Err(SceneError::new(
                    field("material.reflectance"),
                    "every component must be in [0, 1]",
                ));
            }
            Material::Diffuse { reflectance: r }
        }
    };
    let triangles: Vec<[DVec3; 3]> = (0..mesh.triangle_count())
        .map(|t| mesh.corners(t))
        .collect();
    let bvh = Bvh::build(&triangles);
    let object = Object {
        name,
        bounds: PruneBounds::build(&mesh, &bvh),
        bvh,
        report: mesh.report(),
        mesh,
        material,
    };
    Ok((object, smoothed))
}

#[cfg(test)]
mod tests;

/// Each dielectric object's medium must be apart from every other's or wholly inside it (the
/// region two crossing surfaces both bound has no one medium; surfaces that touch are sorted by
/// `contact::Contacts::find`), and must not lie inside a closed
/// diffuse object that the camera is outside of or that holds no light (nothing there could be
/// seen or lit; a closed room around the camera and a light is fine). Refused naming both objects.
fn check_media_layout(
    objects: &[Object],
    camera: DVec3,
    lights: &[DVec3],
) -> Result<(), SceneError> {
    let dielectric = |o: &Object| matches!(o.material, Material::Dielectric(_));
    for (i, inner) in objects.iter().enumerate().filter(|(_, o)| dielectric(o)) {
        for (k, other) in objects.iter().enumerate() {
            if k == i {
                continue;
            }
            let cross =
                || containment::surfaces_cross(&inner.mesh, &inner.bvh, &other.mesh, &other.bvh);
            if dielectric(other) && k < i && cross() {
                return Err(SceneError::new(
                    inner.name.clone(),
                    format!(
                        "its surface crosses the surface of {}: two dielectric objects must be \
                         apart or one wholly inside the other (overlapping media are not \
                         supported)",
                        other.name
                    ),
                ));
            }
            if !matches!(other.material, Material::Diffuse { .. }) || !other.report.closed {
                continue;
            }
            let holds = |p: DVec3| containment::holds(&other.mesh, p);
            let enclosed = inner.mesh.positions().first().is_some_and(|&v| holds(v)) && !cross();
            let why = if !enclosed {
                continue;
            } else if !holds(camera) {
                "the camera is outside it, so the medium cannot be seen"
            } else if !lights.iter().any(|&l| holds(l)) {
                "no light is inside it, so the medium cannot be lit"
            } else {
                continue;
            };
            return Err(SceneError::new(
                inner.name.clone(),
                format!(
                    "the medium lies inside the closed diffuse object {} and {why} (a medium \
                     inside an opaque object is refused)",
                    other.name
                ),
            ));
        }
    }
    Ok(())
}

/// The sphere around every object's bounds (the unit sphere when there are none).
fn objects_sphere(objects: &[Object]) -> SceneSphere {
    let mut bounds: Option<(DVec3, DVec3)> = None;
    for o in objects {
        let (lo, hi) = o.mesh.bounds();
        bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
    }
    match bounds {
        Some((lo, hi)) if (hi - lo).is_finite() && hi.cmpge(lo).all() => SceneSphere {
            center: 0.5 * (lo + hi),
            radius: (0.5 * (hi - lo).length()).max(1e-6),
        },
        _ => SceneSphere {
            center: DVec3::ZERO,
            radius: 1.0,
        },
    }
}

/// An area light must lie wholly inside or wholly outside each medium: a sphere or quad light
/// that crosses a dielectric surface is refused, naming both.
fn check_straddle(objects: &[Object], j: usize, light: &Light) -> Result<(), SceneError> {
    for o in objects {
        if !matches!(o.material, Material::Dielectric(_)) {
            continue;
        }
        let (lo, hi) = o.mesh.bounds();
        let what = match *light {
            Light::Sphere { center, radius, .. } => {
                let near_box = center.clamp(lo, hi).distance(center) < radius;
                (near_box && containment::distance_to_mesh(&o.mesh, center) < radius)
                    .then(|| format!("the sphere light (centre {center}, radius {radius})"))
            }
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                ..
            } => quad_crosses_mesh(&o.mesh, corner, edge_u, edge_v)
                .then(|| format!("the quad light (corner {corner}, edges {edge_u}, {edge_v})")),
            Light::Point { .. } | Light::Directional { .. } => None,
        };
        if let Some(what) = what {
            return Err(SceneError::new(
                format!("lights[{j}]"),
                format!(
                    "{what} crosses the surface of {}: a light must lie wholly inside or wholly \
                     outside each medium",
                    o.name
                ),
            ));
        }
    }
    Ok(())
}

/// Whether the rectangle `corner + s·u + t·v` (`s, t ∈ [0, 1]`) and the mesh's surface cross:
/// two non-coplanar triangles meet exactly when an edge of one passes through the other, so
/// every edge of each triangle near the quad is tested against the quad's two halves, and the
/// quad's four edges against the triangle.
fn quad_crosses_mesh(mesh: &TriangleMesh, corner: DVec3, u: DVec3, v: DVec3) -> bool {
    let quad_points = [corner, corner + u, corner + u + v, corner + v];
    let quad_lo = quad_points.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let quad_hi = quad_points
        .iter()
        .fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    let (lo, hi) = mesh.bounds();
    if quad_lo.cmpgt(hi).any() || quad_hi.cmplt(lo).any() {
        return false;
    }
    let halves = [
        [quad_points[0], quad_points[1], quad_points[2]],
        [quad_points[0], quad_points[2], quad_points[3]],
    ];
    (0..mesh.triangle_count()).any(|i| {
        let tri = mesh.corners(i);
        let tri_lo = tri[0].min(tri[1]).min(tri[2]);
        let tri_hi = tri[0].max(tri[1]).max(tri[2]);
        if tri_lo.cmpgt(quad_hi).any() || tri_hi.cmplt(quad_lo).any() {
            return false;
        }
        (0..3).any(|k| {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            halves.iter().any(|h| segment_crosses_triangle(a, b, *h))
        }) || (0..4).any(|k| {
            let (a, b) = (quad_points[k], quad_points[(k + 1) % 4]);
            segment_crosses_triangle(a, b, tri)
        })
    })
}

/// Whether the segment `a–b` passes through the triangle (a segment in its plane does not).
fn segment_crosses_triangle(a: DVec3, b: DVec3, [p, q, r]: [DVec3; 3]) -> bool {
    let n = (q - p).cross(r - p);
    let (da, db) = ((a - p).dot(n), (b - p).dot(n));
    if da * db > 0.0 || da == db {
        return false;
    }
    let x = a + (b - a) * (da / (da - db));
    // Inside when x is on the inner side of every edge.
    [(p, q), (q, r), (r, p)]
        .iter()
        .all(|&(s, t)| (t - s).cross(x - s).dot(n) >= 0.0)
}

/// The beam tables of every dielectric object for every point light outside all media (the
/// lights whose descents use them; a sphere or area light's point moves from sample to sample),
/// the first [`BEAM_TABLE_BUDGET`] such lights only.
fn beam_tables(
    objects: &[Object],
    outer: &[Option<usize>],
    lights: &[Light],
    light_media: &[Option<usize>],
) -> Vec<Vec<Option<BeamTable>>> {
    let mut budget = BEAM_TABLE_BUDGET;
    let chosen: Vec<Option<DVec3>> = lights
        .iter()
        .zip(light_media)
        .map(|(light, medium)| match (light, medium) {
            (Light::Point { position, .. }, None) if budget > 0 => {
                budget -= 1;
                Some(*position)
            }
            _ => None,
        })
        .collect();
    objects
        .iter()
        .enumerate()
        .map(|(i, o)| match o.material {
            // Only objects in the air see the lights in the air along straight lines.
            Material::Dielectric(d) if outer[i].is_none() => chosen
                .iter()
                .map(|light| light.map(|l| BeamTable::build(&o.bounds, l, d.eta)))
                .collect(),
            _ => Vec::new(),
        })
        .collect()
}
