//! Reading and checking a scene: JSON in, a [`SceneDescription`] whose every value is usable out.
//!
//! A scene comes from users and outside tools, so a mistake must come back as one clear line
//! naming where it is (`objects[0].material.medium.sigma_t[1]: must be >= 0, got -0.5`), never
//! as a panic, a hang or a NaN deep in the renderer. Parsing reports the JSON path of a
//! malformed or unknown value ([`serde_path_to_error`]); [`SceneDescription::validate`] then checks the
//! ranges the types cannot express and names the path of the first bad value, in document
//! order. Paths use `.` between fields and `[i]` for array elements (also for the components of
//! an `[x, y, z]` or `[r, g, b]` triple); the whole document is `.`.

use crate::scene::{
    Camera, Film, Integrator, Light, Material, Medium, Object, Phase, Rgb, SceneDescription, Shape,
    SingleScatter, Transform, Vec3, Waves,
};
use crate::transform::Affine;

mod animation;
pub use animation::MAX_FRAME_RATE;

/// The largest image side accepted, in pixels (a sanity cap: 16384² pixels of three RGB f32
/// layers is already 9 GiB).
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// The largest `film.spp` accepted (by the CLI, the renderer and the coordinator alike).
pub const MAX_SPP: u32 = 1 << 16;
/// The largest `film.time_budget_s` accepted: a week, beyond which a budget is a mistake.
pub const MAX_TIME_BUDGET_S: f64 = 7.0 * 24.0 * 3600.0;
/// The largest absolute world coordinate of anything in a scene — camera, lights, and every
/// vertex after its object's transform — and the largest length (radii). The renderer keeps
/// boxes in f32 (7 significant digits) and solves in f64 with absolute tolerances scaled to the
/// scene, so a scene must fit in a range where both stay meaningful; ±10⁶ leaves f32 boxes
/// resolving 0.1 at the edge and f64 solves 10 digits to spare.
pub const MAX_COORDINATE: f64 = 1e6;

/// The largest frame number: a frame range, and a key's frame in absolute value (six digits,
/// the `######` of an output path).
pub const MAX_FRAME: u32 = 999_999;
/// The most keys of one animation track.
pub const MAX_KEYS: usize = 100_000;

/// The most corners one OBJ face (`f v1 v2 … vn`) may have. A face is triangulated as a polygon,
/// whose cost grows faster than its corners (one face line of 10,000 corners took 9.6 s to
/// build); meshes from modelling tools have faces of 3 or 4 corners, and rarely more than a
/// few dozen.
pub const MAX_FACE_CORNERS: usize = 64;
/// The most squares along a side of a wavy box's top (`segments`): 1024² squares are already
/// 2.1 million triangles.
pub const MAX_WAVE_SEGMENTS: u32 = 1024;
/// The most triangles of a scene's shapes together: the bound of the renderer, of the CLI
/// and, by default, of the coordinator: 2²⁵ ≈ 33.5 million, so one icosphere of
/// [`MAX_SUBDIVISIONS`] (21 million triangles) fits.
pub const MAX_TRIANGLES: u64 = 1 << 25;
/// The smallest length accepted (radii), and the smallest absolute scale factor.
pub const MIN_LENGTH: f64 = 1e-6;
/// The largest absolute scale factor of a transform.
pub const MAX_SCALE: f64 = 1e6;
/// The largest icosphere subdivision level: level 10 is 20·4¹⁰ ≈ 21 million triangles.
pub const MAX_SUBDIVISIONS: u32 = 10;
/// The largest relative index of refraction accepted (diamond is 2.42; 10 catches typos).
pub const MAX_ETA: f64 = 10.0;
/// The largest `integrator.max_depth` accepted.
pub const MAX_DEPTH: u32 = 64;
/// The largest `integrator.multiple_scatter.max_order` accepted.
pub const MAX_ORDER: u32 = 1024;
/// The largest `integrator.multiple_scatter.paths` accepted.
pub const MAX_SECONDARY_PATHS: u32 = 64;
/// The largest `integrator.single_scatter.newton_tolerance` accepted.
pub const MAX_NEWTON_TOLERANCE: f64 = 1e-2;
/// The largest `integrator.single_scatter.k` accepted.
pub const MAX_K: u32 = 1 << 16;
/// The largest `integrator.single_scatter.samples_per_segment` accepted.
pub const MAX_SAMPLES_PER_SEGMENT: u32 = 1 << 20;

/// A bad scene: the JSON path of the first bad value and what is wrong with it.
/// Displays as `"<path>: <problem>"`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {problem}")]
pub struct SceneError {
    /// JSON path of the bad value, e.g. `objects[0].material.medium.sigma_t[1]`; `.` is the
    /// whole document.
    pub path: String,
    /// What is wrong, in words, with the offending value where it helps.
    pub problem: String,
}

impl SceneError {
    /// The error `problem` (any message: a string or an error of a part of the scene) at the
    /// JSON path `path`.
    pub fn new(path: impl Into<String>, problem: impl ToString) -> SceneError {
        SceneError {
            path: path.into(),
            problem: problem.to_string(),
        }
    }
}

type Check = Result<(), SceneError>;

impl SceneDescription {
    /// Parses a scene from JSON text and validates it ([`SceneDescription::validate`]). Unknown fields,
    /// wrong types, missing required fields and trailing text are rejected with their path.
    pub fn from_json(text: &str) -> Result<SceneDescription, SceneError> {
        let mut json = serde_json::Deserializer::from_str(text);
        let scene: SceneDescription = serde_path_to_error::deserialize(&mut json).map_err(|e| {
            let problem = e.inner().to_string();
            SceneError::new(full_path(e.path().to_string(), &problem), problem)
        })?;
        json.end()
            .map_err(|e| SceneError::new(".", e.to_string()))?;
        scene.validate()?;
        Ok(scene)
    }

    /// Checks every value of the scene and reports the first bad one, in document order.
    /// A scene that passes can be rendered without producing NaN from its inputs.
    pub fn validate(&self) -> Check {
        check_camera("camera", &self.camera)?;
        check_film("film", &self.film)?;
        for (i, light) in self.lights.iter().enumerate() {
            check_light(&format!("lights[{i}]"), light)?;
        }
        for (i, object) in self.objects.iter().enumerate() {
            check_object(&format!("objects[{i}]"), object)?;
        }
        check_rgb_at_least("background", &self.background, 0.0)?;
        check_integrator("integrator", &self.integrator)?;
        match &self.animation {
            Some(time) => animation::check("animation", time, self),
            None => Ok(()),
        }
    }
}

/// The path of a parse error. Inside a tagged enum (`shape`, `material`, `lights[i]`) serde
/// buffers the value, so the tracked path stops at the enum; an unknown field's name is in the
/// message, so it is put back on the path.
fn full_path(path: String, problem: &str) -> String {
    let unknown = problem
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split_once('`'))
        .map(|(field, _)| field);
    match unknown {
        Some(field) if path != field && !path.ends_with(&format!(".{field}")) => {
            if path == "." {
                field.to_string()
            } else {
                format!("{path}.{field}")
            }
        }
        _ => path,
    }
}

fn check_camera(path: &str, camera: &Camera) -> Check {
    let position = format!("{path}.position");
    let look_at = format!("{path}.look_at");
    let up = format!("{path}.up");
    check_point(&position, &camera.position)?;
    check_point(&look_at, &camera.look_at)?;
    check_vec3(&up, &camera.up)?;

    // The view direction must exist and be representable.
    let view = sub(camera.look_at, camera.position);
    if view.iter().any(|x| !x.is_finite()) {
        return Err(SceneError::new(
            look_at,
            format!("is too far from {position}: their difference overflows"),
        ));
    }
    if view == [0.0; 3] {
        return Err(SceneError::new(
            look_at,
            format!("must differ from {position} (the camera needs a view direction)"),
        ));
    }

    // `up` picks the camera's roll, so it must be non-zero and not along the view direction.
    if camera.up == [0.0; 3] {
        return Err(SceneError::new(up, "must not be the zero vector"));
    }
    // sin² of the angle between `up` and the view direction, on copies scaled to O(1) so huge
    // or tiny coordinates cannot overflow; below (1e-6)² the two are parallel for any
    // practical purpose and the camera frame would be noise.
    let (v, u) = (unit_scaled(view), unit_scaled(camera.up));
    let c = cross(v, u);
    let sin2 = dot(c, c) / (dot(v, v) * dot(u, u));
    if sin2 <= 1e-12 {
        return Err(SceneError::new(
            up,
            format!("must not be parallel to the view direction ({look_at} - {position})"),
        ));
    }

    check_open_range(&format!("{path}.fov_y"), camera.fov_y, 0.0, 180.0)
}

fn check_film(path: &str, film: &Film) -> Check {
    check_count(&format!("{path}.width"), film.width, 1, MAX_IMAGE_SIDE)?;
    check_count(&format!("{path}.height"), film.height, 1, MAX_IMAGE_SIDE)?;
    check_count(&format!("{path}.spp"), film.spp, 1, MAX_SPP)?;
    if let Some(target) = film.target_error {
        check_open_range(&format!("{path}.target_error"), target, 0.0, 1.0)?;
    }
    if let Some(budget) = film.time_budget_s {
        check_open_range(
            &format!("{path}.time_budget_s"),
            budget,
            0.0,
            MAX_TIME_BUDGET_S,
        )?;
    }
    for (i, pass) in film.passes.iter().enumerate() {
        if film.passes[..i].contains(pass) {
            return Err(SceneError::new(
                format!("{path}.passes[{i}]"),
                format!("`{}` is listed twice; list each pass once", pass.name()),
            ));
        }
    }
    Ok(())
}

fn check_light(path: &str, light: &Light) -> Check {
    match light {
        Light::Point {
            position,
            intensity,
        } => {
            check_point(&format!("{path}.position"), position)?;
            check_rgb_at_least(&format!("{path}.intensity"), intensity, 0.0)
        }
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            check_point(&format!("{path}.center"), center)?;
            check_length(&format!("{path}.radius"), *radius)?;
            check_rgb_at_least(&format!("{path}.radiance"), radiance, 0.0)
        }
        Light::Directional {
            direction,
            irradiance,
            angular_diameter,
        } => {
            check_direction(&format!("{path}.direction"), direction)?;
            check_rgb_at_least(&format!("{path}.irradiance"), irradiance, 0.0)?;
            let field = format!("{path}.angular_diameter");
            if !(angular_diameter.is_finite()
                && (0.0..=MAX_ANGULAR_DIAMETER).contains(angular_diameter))
            {
                return Err(SceneError::new(
                    field,
                    format!(
                        "must be between 0 and {MAX_ANGULAR_DIAMETER} degrees (the sun is about \
                         0.53), got {angular_diameter}"
                    ),
                ));
            }
            Ok(())
        }
        Light::Quad {
            corner,
            edge_u,
            edge_v,
            radiance,
        } => {
            check_point(&format!("{path}.corner"), corner)?;
            let (u_path, v_path) = (format!("{path}.edge_u"), format!("{path}.edge_v"));
            check_edge(&u_path, edge_u)?;
            check_edge(&v_path, edge_v)?;
            // |cos| of the angle between the edges, on copies scaled to O(1).
            let (u, v) = (unit_scaled(*edge_u), unit_scaled(*edge_v));
            let cos = dot(u, v) / (dot(u, u) * dot(v, v)).sqrt();
            if cos.abs() > MAX_QUAD_EDGE_COS {
                return Err(SceneError::new(
                    v_path,
                    format!(
                        "must be perpendicular to {u_path} (the light is a rectangle), but the \
                         angle between them is {:.6}°",
                        cos.clamp(-1.0, 1.0).acos().to_degrees()
                    ),
                ));
            }
            check_point(
                &format!("{path}.corner + edge_u + edge_v"),
                &[0, 1, 2].map(|i| corner[i] + edge_u[i] + edge_v[i]),
            )?;
            check_rgb_at_least(&format!("{path}.radiance"), radiance, 0.0)
        }
    }
}

/// How far from perpendicular a quad light's edges may be (|cos| of their angle, about 0.00006°):
/// enough for edges written with rounded decimals; the renderer makes them exactly perpendicular.
pub const MAX_QUAD_EDGE_COS: f64 = 1e-6;

/// An edge of a quad light: a length in [[`MIN_LENGTH`], [`MAX_COORDINATE`]].
fn check_edge(path: &str, v: &Vec3) -> Check {
    check_vec3(path, v)?;
    let length = dot(*v, *v).sqrt();
    if (MIN_LENGTH..=MAX_COORDINATE).contains(&length) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!(
                "its length must be between {MIN_LENGTH:e} and {MAX_COORDINATE:e}, got {length}"
            ),
        ))
    }
}

/// The widest distant light, in degrees: beyond this it is an area light, not a direction.
pub const MAX_ANGULAR_DIAMETER: f64 = 30.0;

/// A direction: finite and not zero.
fn check_direction(path: &str, v: &[f64; 3]) -> Check {
    if !v.iter().all(|c| c.is_finite()) {
        return Err(SceneError::new(path, format!("must be finite, got {v:?}")));
    }
    if v.iter().all(|&c| c == 0.0) {
        return Err(SceneError::new(
            path,
            "must be a direction, got the zero vector",
        ));
    }
    Ok(())
}

fn check_object(path: &str, object: &Object) -> Check {
    check_shape(&format!("{path}.shape"), &object.shape)?;
    check_transform(&format!("{path}.transform"), &object.transform)?;
    check_procedural_placement(&format!("{path}.transform"), object)?;
    check_material(&format!("{path}.material"), &object.material)
}

/// The radius of a sphere about the origin that holds every vertex of a procedural shape (an
/// icosphere's vertices lie on its sphere; a bumpy sphere's within `radius · (1 + amplitude)`,
/// its noise being within ±1; a box's within its half diagonal, the waves' amplitude added to
/// its top); `None` for an OBJ file, whose vertices only its bytes tell.
pub fn procedural_radius(shape: &Shape) -> Option<f64> {
    match shape {
        Shape::Obj { .. } => None,
        Shape::Icosphere { radius, .. } => Some(*radius),
        Shape::BumpySphere {
            radius, amplitude, ..
        } => Some(radius * (1.0 + amplitude.abs())),
        Shape::Box { size, waves } => {
            let top = size[1] / 2.0 + waves.as_ref().map_or(0.0, |w| w.amplitude.abs());
            Some((size[0] * size[0] / 4.0 + top * top + size[2] * size[2] / 4.0).sqrt())
        }
    }
}

/// A procedural shape is placed within the scene's extent when its bounding sphere is
/// ([`procedural_radius`], [`surely_within_extent`]): checked from the description alone, so
/// the coordinator refuses at submission what a worker would refuse at build. Stricter than the
/// renderer's vertex rule only for a shape whose sphere, not its vertices, crosses the extent.
fn check_procedural_placement(path: &str, object: &Object) -> Check {
    match procedural_radius(&object.shape) {
        Some(radius) if !surely_within_extent(&object.transform, radius) => Err(SceneError::new(
            path,
            format!(
                "places the shape's bounding sphere (radius {radius:e} about its origin) past \
                 the scene's extent of ±{MAX_COORDINATE:e} per coordinate (scenes/README.md)"
            ),
        )),
        _ => Ok(()),
    }
}

fn check_shape(path: &str, shape: &Shape) -> Check {
    match shape {
        Shape::Obj {
            path: file,
            crease_angle,
        } => {
            if let Some(angle) = *crease_angle {
                let angle_path = format!("{path}.crease_angle");
                check_finite(&angle_path, angle)?;
                if !(0.0..=180.0).contains(&angle) {
                    return Err(SceneError::new(
                        angle_path,
                        format!("must be an angle in degrees from 0 to 180, got {angle}"),
                    ));
                }
            }
            if file.trim().is_empty() {
                return Err(SceneError::new(
                    format!("{path}.path"),
                    "must name an OBJ file (relative to the scene file), got an empty string",
                ));
            }
            if file.contains('\0') {
                return Err(SceneError::new(
                    format!("{path}.path"),
                    "must not contain a NUL character",
                ));
            }
            Ok(())
        }
        Shape::Icosphere {
            radius,
            subdivisions,
        } => {
            check_length(&format!("{path}.radius"), *radius)?;
            check_subdivisions(&format!("{path}.subdivisions"), *subdivisions)
        }
        Shape::BumpySphere {
            radius,
            subdivisions,
            amplitude,
            frequency,
            seed: _,
        } => {
            check_length(&format!("{path}.radius"), *radius)?;
            check_subdivisions(&format!("{path}.subdivisions"), *subdivisions)?;
            let amplitude_path = format!("{path}.amplitude");
            check_finite(&amplitude_path, *amplitude)?;
            if !(0.0..1.0).contains(amplitude) {
                return Err(SceneError::new(
                    amplitude_path,
                    format!(
                        "must be in [0, 1) (a fraction of the radius; 1 or more would fold the \
                         surface through the centre), got {amplitude}"
                    ),
                ));
            }
            check_at_least(&format!("{path}.frequency"), *frequency, 0.0)
        }
        Shape::Box { size, waves } => {
            for (i, side) in size.iter().enumerate() {
                check_length(&format!("{path}.size[{i}]"), *side)?;
            }
            match waves {
                Some(waves) => check_waves(&format!("{path}.waves"), waves, size[1]),
                None => Ok(()),
            }
        }
    }
}

/// A box's waves: the top must stay above the bottom with room to spare, so the amplitude is
/// less than half the box's height.
fn check_waves(path: &str, waves: &Waves, height: f64) -> Check {
    let amplitude_path = format!("{path}.amplitude");
    check_at_least(&amplitude_path, waves.amplitude, 0.0)?;
    if waves.amplitude >= height / 2.0 {
        return Err(SceneError::new(
            amplitude_path,
            format!(
                "must be less than half the box's height size[1] = {height} (the top would reach \
                 the bottom), got {}",
                waves.amplitude
            ),
        ));
    }
    check_length(&format!("{path}.wavelength"), waves.wavelength)?;
    if !(1..=MAX_WAVE_SEGMENTS).contains(&waves.segments) {
        return Err(SceneError::new(
            format!("{path}.segments"),
            format!(
                "must be from 1 to {MAX_WAVE_SEGMENTS} (squares along a side of the top), got {}",
                waves.segments
            ),
        ));
    }
    Ok(())
}

/// Triangles of a box shape: its top is `n × n` squares (`n` = the waves' segments, 1 for a flat
/// box) of two triangles; each side is `n` quads of two triangles from the bottom edge up to the
/// top's border; the bottom is a fan of `4n` triangles from its centre to the sides' lower edges.
pub fn box_triangles(waves: Option<&Waves>) -> u64 {
    let n = u64::from(waves.map_or(1, |w| w.segments));
    2 * n * n + 12 * n
}

fn check_subdivisions(path: &str, subdivisions: u32) -> Check {
    if subdivisions > MAX_SUBDIVISIONS {
        return Err(SceneError::new(
            path,
            format!(
                "must be <= {MAX_SUBDIVISIONS} (level {MAX_SUBDIVISIONS} is already 20·4^10 ≈ 21 \
                 million triangles), got {subdivisions}"
            ),
        ));
    }
    Ok(())
}

fn check_transform(path: &str, transform: &Transform) -> Check {
    let scale = format!("{path}.scale");
    check_vec3(&scale, &transform.scale)?;
    for (i, s) in transform.scale.iter().enumerate() {
        if *s == 0.0 {
            return Err(SceneError::new(
                format!("{scale}[{i}]"),
                "must not be 0 (a zero scale flattens the object and has no inverse)",
            ));
        }
        if !(MIN_LENGTH..=MAX_SCALE).contains(&s.abs()) {
            return Err(SceneError::new(
                format!("{scale}[{i}]"),
                format!(
                    "must be between {MIN_LENGTH:e} and {MAX_SCALE:e} in absolute value (the scene \
                     must fit within ±{MAX_COORDINATE:e}), got {s}"
                ),
            ));
        }
    }
    check_vec3(&format!("{path}.rotate_deg"), &transform.rotate_deg)?;
    check_point(&format!("{path}.translate"), &transform.translate)
}

fn check_material(path: &str, material: &Material) -> Check {
    match material {
        Material::Dielectric { eta, medium } => {
            let eta_path = format!("{path}.eta");
            check_finite(&eta_path, *eta)?;
            if *eta < 1.0 {
                return Err(SceneError::new(
                    eta_path,
                    format!(
                        "must be >= 1, got {eta}: eta < 1 (a medium less dense than the air \
                         around it) is unsupported by the single-scattering method"
                    ),
                ));
            }
            if *eta > MAX_ETA {
                return Err(SceneError::new(
                    eta_path,
                    format!("must be <= {MAX_ETA}, got {eta}"),
                ));
            }
            check_medium(&format!("{path}.medium"), medium)
        }
        Material::Diffuse { reflectance } => {
            check_rgb_unit(&format!("{path}.reflectance"), reflectance)
        }
    }
}

fn check_medium(path: &str, medium: &Medium) -> Check {
    check_rgb_at_least(&format!("{path}.sigma_t"), &medium.sigma_t, 0.0)?;
    check_rgb_unit(&format!("{path}.albedo"), &medium.albedo)?;
    match medium.phase {
        Phase::Isotropic => Ok(()),
        Phase::Hg { g } => check_open_range(&format!("{path}.phase.g"), g, -1.0, 1.0),
    }
}

fn check_integrator(path: &str, integrator: &Integrator) -> Check {
    let max_depth = format!("{path}.max_depth");
    check_count(&max_depth, integrator.max_depth, 0, MAX_DEPTH)?;
    if integrator.internal_reflections > integrator.max_depth {
        return Err(SceneError::new(
            format!("{path}.internal_reflections"),
            format!(
                "must be <= {max_depth} ({}), got {}",
                integrator.max_depth, integrator.internal_reflections
            ),
        ));
    }
    check_single_scatter(
        &format!("{path}.single_scatter"),
        &integrator.single_scatter,
    )?;
    let multiple = &integrator.multiple_scatter;
    check_count(
        &format!("{path}.multiple_scatter.max_order"),
        multiple.max_order,
        1,
        MAX_ORDER,
    )?;
    check_count(
        &format!("{path}.multiple_scatter.paths"),
        multiple.paths,
        1,
        MAX_SECONDARY_PATHS,
    )
}

fn check_single_scatter(path: &str, settings: &SingleScatter) -> Check {
    check_count(&format!("{path}.k"), settings.k, 1, MAX_K)?;
    let tolerance = format!("{path}.newton_tolerance");
    check_finite(&tolerance, settings.newton_tolerance)?;
    if !(settings.newton_tolerance > 0.0 && settings.newton_tolerance <= MAX_NEWTON_TOLERANCE) {
        return Err(SceneError::new(
            tolerance,
            format!(
                "must be in (0, {MAX_NEWTON_TOLERANCE}], got {}",
                settings.newton_tolerance
            ),
        ));
    }
    check_count(
        &format!("{path}.samples_per_segment"),
        settings.samples_per_segment,
        1,
        MAX_SAMPLES_PER_SEGMENT,
    )?;
    let auto = format!("{path}.auto_tolerance");
    check_finite(&auto, settings.auto_tolerance)?;
    if !(0.0..1.0).contains(&settings.auto_tolerance) {
        return Err(SceneError::new(
            auto,
            format!("must be in [0, 1), got {}", settings.auto_tolerance),
        ));
    }
    Ok(())
}

// ---- Checks of single values -------------------------------------------------------------

fn check_finite(path: &str, x: f64) -> Check {
    if x.is_finite() {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("must be a finite number, got {x}"),
        ))
    }
}

fn check_vec3(path: &str, v: &Vec3) -> Check {
    for (i, x) in v.iter().enumerate() {
        check_finite(&format!("{path}[{i}]"), *x)?;
    }
    Ok(())
}

/// A position in the world: every coordinate within ±[`MAX_COORDINATE`].
fn check_point(path: &str, v: &Vec3) -> Check {
    for (i, x) in v.iter().enumerate() {
        let component = format!("{path}[{i}]");
        check_finite(&component, *x)?;
        if x.abs() > MAX_COORDINATE {
            return Err(SceneError::new(
                component,
                format!(
                    "must be within ±{MAX_COORDINATE:e} (the scene's extent, see scenes/README.md), \
                     got {x}"
                ),
            ));
        }
    }
    Ok(())
}

/// A length (a radius): in [[`MIN_LENGTH`], [`MAX_COORDINATE`]].
fn check_length(path: &str, x: f64) -> Check {
    check_positive(path, x)?;
    if (MIN_LENGTH..=MAX_COORDINATE).contains(&x) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("must be between {MIN_LENGTH:e} and {MAX_COORDINATE:e}, got {x}"),
        ))
    }
}

fn check_at_least(path: &str, x: f64, lo: f64) -> Check {
    check_finite(path, x)?;
    if x >= lo {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("must be >= {lo}, got {x}")))
    }
}

fn check_positive(path: &str, x: f64) -> Check {
    check_finite(path, x)?;
    if x > 0.0 {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("must be > 0, got {x}")))
    }
}

/// `x` in the open interval (lo, hi).
fn check_open_range(path: &str, x: f64, lo: f64, hi: f64) -> Check {
    check_finite(path, x)?;
    if lo < x && x < hi {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("must be in ({lo}, {hi}), got {x}"),
        ))
    }
}

fn check_rgb_at_least(path: &str, rgb: &Rgb, lo: f64) -> Check {
    for (i, x) in rgb.iter().enumerate() {
        check_at_least(&format!("{path}[{i}]"), *x, lo)?;
    }
    Ok(())
}

/// Every component in [0, 1].
fn check_rgb_unit(path: &str, rgb: &Rgb) -> Check {
    for (i, x) in rgb.iter().enumerate() {
        let component = format!("{path}[{i}]");
        check_finite(&component, *x)?;
        if !(0.0..=1.0).contains(x) {
            return Err(SceneError::new(
                component,
                format!("must be in [0, 1], got {x}"),
            ));
        }
    }
    Ok(())
}

/// An integer in [lo, hi].
fn check_count(path: &str, n: u32, lo: u32, hi: u32) -> Check {
    if n < lo {
        Err(SceneError::new(path, format!("must be >= {lo}, got {n}")))
    } else if n > hi {
        Err(SceneError::new(path, format!("must be <= {hi}, got {n}")))
    } else {
        Ok(())
    }
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `v` divided by its largest absolute component (so that component is ±1); `v` is non-zero.
fn unit_scaled(v: Vec3) -> Vec3 {
    let m = v[0].abs().max(v[1].abs()).max(v[2].abs());
    [v[0] / m, v[1] / m, v[2] / m]
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Triangles an OBJ file describes — a face line `f v1 v2 … vn` is a fan of n − 2 triangles —
/// after checking, in one linear pass, what would make the renderer refuse the file, so that
/// the coordinator refuses it at submission rather than at the first lease: a face of more than
/// [`MAX_FACE_CORNERS`] corners, a vertex whose coordinates are not three numbers within
/// ±[`MAX_COORDINATE`], a face corner naming a vertex the file does not have, or no face at
/// all. Each error names its line.
pub fn count_obj_triangles(bytes: &[u8]) -> Result<u64, String> {
    let mut triangles = 0u64;
    let mut vertices = 0u64;
    // The largest positive vertex index a face names, and its line: checked at the end, as a
    // face may name a vertex given later in the file.
    let mut furthest: Option<(u64, usize)> = None;
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.trim_ascii();
        let mut tokens = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        match tokens.next() {
            Some(b"v") => {
                let mut coordinates = 0;
                for token in tokens.take(3) {
                    let x = std::str::from_utf8(token)
                        .ok()
                        .and_then(|t| t.parse::<f64>().ok())
                        .filter(|x| x.is_finite() && x.abs() <= MAX_COORDINATE);
                    if x.is_none() {
                        return Err(format!(
                            "line {}: a vertex coordinate {:?}: must be a number within \
                             ±{MAX_COORDINATE:e} (the scene's extent)",
                            n + 1,
                            String::from_utf8_lossy(token)
                        ));
                    }
                    coordinates += 1;
                }
                if coordinates < 3 {
                    return Err(format!("line {}: a vertex needs three coordinates", n + 1));
                }
                vertices += 1;
            }
            Some(b"f") => {
                let mut corners = 0usize;
                for token in tokens {
                    corners += 1;
                    if corners > MAX_FACE_CORNERS {
                        let all = line
                            .split(|b| b.is_ascii_whitespace())
                            .filter(|t| !t.is_empty())
                            .count()
                            - 1;
                        return Err(format!(
                            "line {}: a face of {all} corners; at most {MAX_FACE_CORNERS} (split \
                             it into smaller faces)",
                            n + 1
                        ));
                    }
                    let index = token.split(|&b| b == b'/').next().unwrap_or_default();
                    let index = std::str::from_utf8(index)
                        .ok()
                        .and_then(|t| t.parse::<i64>().ok());
                    match index {
                        Some(i) if i > 0 => {
                            let i = i as u64;
                            if furthest.is_none_or(|(f, _)| i > f) {
                                furthest = Some((i, n + 1));
                            }
                        }
                        // Relative to the vertices so far.
                        Some(i) if i < 0 && i.unsigned_abs() <= vertices => {}
                        _ => {
                            return Err(format!(
                                "line {}: a face corner {:?}: must name one of the vertices \
                                 before it (1 … {vertices}, or −1 … −{vertices} counting back)",
                                n + 1,
                                String::from_utf8_lossy(token)
                            ));
                        }
                    }
                }
                triangles += corners.saturating_sub(2) as u64;
            }
            _ => {}
        }
    }
    if let Some((index, line)) = furthest.filter(|&(i, _)| i > vertices) {
        return Err(format!(
            "line {line}: a face names vertex {index}, but the file has {vertices} vertices"
        ));
    }
    if triangles == 0 {
        return Err("the file has no faces (no `f` line of three or more corners)".into());
    }
    Ok(triangles)
}

/// Whether a vertex placed in the world is within the scene's extent: every coordinate finite
/// and within ±[`MAX_COORDINATE`]. The one rule for placed vertices, of the renderer (every
/// shape, after its transform) and of the coordinator (OBJ files, [`check_obj_placement`]).
pub fn check_in_extent(p: Vec3) -> Result<(), String> {
    if p.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE) {
        Ok(())
    } else {
        Err(format!(
            "places a vertex at {p:?}, outside the scene's extent of ±{MAX_COORDINATE:e} per \
             coordinate (scenes/README.md)"
        ))
    }
}

/// The vertices (`v` lines) of an OBJ file that parse as three numbers, with their line
/// numbers; [`count_obj_triangles`] refuses a file with any other.
fn obj_vertices(bytes: &[u8]) -> impl Iterator<Item = (usize, Vec3)> + '_ {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .filter_map(|(n, line)| {
            let mut tokens = line
                .split(|b| b.is_ascii_whitespace())
                .filter(|t| !t.is_empty());
            if tokens.next() != Some(b"v") {
                return None;
            }
            let mut p = [0.0; 3];
            for x in &mut p {
                *x = std::str::from_utf8(tokens.next()?).ok()?.parse().ok()?;
            }
            Some((n + 1, p))
        })
}

/// The largest distance of an OBJ file's vertices from its origin (0 without vertices): with
/// [`surely_within_extent`], a placement that needs no vertex-by-vertex check.
pub fn obj_radius(bytes: &[u8]) -> f64 {
    obj_vertices(bytes)
        .map(|(_, p)| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
        .fold(0.0, f64::max)
}

/// True when every point within `radius` of the origin, placed by `transform`, is within the
/// scene's extent: a rotation keeps lengths, so no coordinate of `M·p` passes the largest
/// absolute scale times `radius`, to which the translation adds. False says nothing: then
/// [`check_obj_placement`] decides, vertex by vertex. A margin of 10⁻⁹ of the extent covers the
/// rounding of the placement's arithmetic.
pub fn surely_within_extent(transform: &Transform, radius: f64) -> bool {
    let scale = transform.scale.iter().fold(0.0, |m: f64, s| m.max(s.abs()));
    let shift = transform
        .translate
        .iter()
        .fold(0.0, |m: f64, t| m.max(t.abs()));
    scale * radius + shift <= MAX_COORDINATE * (1.0 - 1e-9)
}

/// Checks that `transform` keeps every vertex of an OBJ file within the scene's extent
/// ([`check_in_extent`]), placing each as the renderer does ([`Affine`]); the error names the
/// first vertex's line. Linear in the file.
pub fn check_obj_placement(bytes: &[u8], transform: &Transform) -> Result<(), String> {
    let placement = Affine::new(transform);
    for (line, p) in obj_vertices(bytes) {
        check_in_extent(placement.point(p)).map_err(|e| format!("line {line}: {e}"))?;
    }
    Ok(())
}

/// Triangles of an icosphere subdivided `subdivisions` times: 20·4^s, or `None` past u64.
pub fn icosphere_triangles(subdivisions: u32) -> Option<u64> {
    4u64.checked_pow(subdivisions)?.checked_mul(20)
}

/// The triangles of every shape of `scene` together, known without building any geometry;
/// `obj_triangles(path)` gives an OBJ shape's count (or the problem with its file). Refused,
/// naming the object where the total passes it, past `max` triangles (the renderer's and the
/// CLI's bound is [`MAX_TRIANGLES`]; a coordinator may set a lower one).
pub fn scene_triangles(
    scene: &SceneDescription,
    mut obj_triangles: impl FnMut(&str) -> Result<u64, String>,
    max: u64,
) -> Result<u64, SceneError> {
    let mut total: u64 = 0;
    for (i, object) in scene.objects.iter().enumerate() {
        let count = match &object.shape {
            Shape::Obj { path, .. } => obj_triangles(path)
                .map_err(|e| SceneError::new(format!("objects[{i}].shape.path"), e))?,
            Shape::Icosphere { subdivisions, .. } | Shape::BumpySphere { subdivisions, .. } => {
                icosphere_triangles(*subdivisions).unwrap_or(u64::MAX)
            }
            Shape::Box { waves, .. } => box_triangles(waves.as_ref()),
        };
        total = total.saturating_add(count);
        if total > max {
            return Err(SceneError::new(
                format!("objects[{i}].shape"),
                format!("the scene has more than {max} triangles (the limit)"),
            ));
        }
    }
    Ok(total)
}

#[cfg(test)]
mod tests;
