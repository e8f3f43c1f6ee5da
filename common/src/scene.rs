//! The scene file format: what a user (or an outside tool) writes to describe a render.
//!
//! These are the JSON types only. Every struct rejects unknown fields; values are checked by
//! [`SceneDescription::from_json`] (and [`SceneDescription::validate`], both in [`crate::validate`]), which name the
//! JSON path of the first bad value (`objects[0].material.medium.sigma_t[1]: must be >= 0, got
//! -0.5`). The renderer turns a validated `SceneDescription` into its own values; it never sees raw JSON.
//! `scenes/README.md` documents every field.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

pub use crate::validate::SceneError;

/// An RGB triple (linear, per-channel).
pub type Rgb = [f64; 3];
/// A point or direction in scene units.
pub type Vec3 = [f64; 3];

/// The API document's shapes of the scene's triples. `Rgb` and `Vec3` are aliases of `[f64; 3]`,
/// which the schema derive cannot name; a field names one of these instead, so the document
/// states the per-component bounds that [`crate::validate`] checks (bounds that involve the
/// whole triple, such as a non-zero direction, are the validator's alone).
mod triple_schemas {
    use std::borrow::Cow;

    use utoipa::openapi::RefOr;
    use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, Schema, Type};

    use crate::validate::MAX_COORDINATE;

    fn triple(description: &str, minimum: Option<f64>, maximum: Option<f64>) -> RefOr<Schema> {
        let component = ObjectBuilder::new()
            .schema_type(Type::Number)
            .minimum(minimum)
            .maximum(maximum);
        ArrayBuilder::new()
            .items(component)
            .min_items(Some(3))
            .max_items(Some(3))
            .description(Some(description))
            .into()
    }

    macro_rules! triple_schema {
        ($ty:ident, $name:literal, $description:literal, $min:expr, $max:expr) => {
            pub struct $ty;
            impl utoipa::PartialSchema for $ty {
                fn schema() -> RefOr<Schema> {
                    triple($description, $min, $max)
                }
            }
            impl utoipa::ToSchema for $ty {
                fn name() -> Cow<'static, str> {
                    Cow::Borrowed($name)
                }
            }
        };
    }

    triple_schema!(
        PointSchema,
        "Point",
        "A position [x, y, z]: each coordinate within the scene's extent.",
        Some(-MAX_COORDINATE),
        Some(MAX_COORDINATE)
    );
    triple_schema!(VectorSchema, "Vector", "[x, y, z], finite.", None, None);
    triple_schema!(
        ColorSchema,
        "Color",
        "Linear RGB [r, g, b], each >= 0.",
        Some(0.0),
        None
    );
    triple_schema!(
        UnitColorSchema,
        "UnitColor",
        "Linear RGB [r, g, b], each in [0, 1].",
        Some(0.0),
        Some(1.0)
    );
}
use triple_schemas::{ColorSchema, PointSchema, UnitColorSchema, VectorSchema};

/// A rotation as a quaternion `[x, y, z, w]` (glTF's order), normalised where it is used; the
/// zero quaternion is refused.
pub type Quat = [f64; 4];

/// The API document's shapes of the animation tracks, which are generic over their value
/// ([`Track`]) and so named here, as the triples are above.
mod track_schemas {
    use std::borrow::Cow;

    use utoipa::openapi::RefOr;
    use utoipa::openapi::schema::{
        AdditionalProperties, ArrayBuilder, ObjectBuilder, Schema, SchemaType, Type,
    };

    use crate::validate::{MAX_COORDINATE, MAX_FRAME, MAX_KEYS};

    fn number(minimum: Option<f64>, maximum: Option<f64>) -> ObjectBuilder {
        ObjectBuilder::new()
            .schema_type(Type::Number)
            .minimum(minimum)
            .maximum(maximum)
    }

    fn numbers(n: usize, minimum: Option<f64>, maximum: Option<f64>) -> RefOr<Schema> {
        ArrayBuilder::new()
            .items(number(minimum, maximum))
            .min_items(Some(n))
            .max_items(Some(n))
            .into()
    }

    fn track(description: &str, value: RefOr<Schema>) -> RefOr<Schema> {
        let key = ObjectBuilder::new()
            .property(
                "frame",
                number(Some(-f64::from(MAX_FRAME)), Some(f64::from(MAX_FRAME))),
            )
            .required("frame")
            .property("value", value)
            .required("value")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        let interpolation = ObjectBuilder::new()
            .schema_type(SchemaType::new(Type::String))
            .enum_values(Some(["linear", "smooth", "step"]));
        ObjectBuilder::new()
            .property("interpolation", interpolation)
            .property(
                "keys",
                ArrayBuilder::new()
                    .items(key)
                    .min_items(Some(1))
                    .max_items(Some(MAX_KEYS)),
            )
            .required("keys")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)))
            .description(Some(description))
            .into()
    }

    macro_rules! track_schema {
        ($ty:ident, $name:literal, $description:literal, $value:expr) => {
            pub struct $ty;
            impl utoipa::PartialSchema for $ty {
                fn schema() -> RefOr<Schema> {
                    track($description, $value)
                }
            }
            impl utoipa::ToSchema for $ty {
                fn name() -> Cow<'static, str> {
                    Cow::Borrowed($name)
                }
            }
        };
    }

    track_schema!(
        PointTrackSchema,
        "PointTrack",
        "Keyframed positions [x, y, z], each coordinate within the scene's extent.",
        numbers(3, Some(-MAX_COORDINATE), Some(MAX_COORDINATE))
    );
    track_schema!(
        VectorTrackSchema,
        "VectorTrack",
        "Keyframed vectors [x, y, z], finite.",
        numbers(3, None, None)
    );
    track_schema!(
        RotationTrackSchema,
        "RotationTrack",
        "Keyframed rotations, quaternions [x, y, z, w] (not zero; normalised where used).",
        numbers(4, None, None)
    );
    track_schema!(
        AngleTrackSchema,
        "AngleTrack",
        "Keyframed angles in degrees, in (0, 180).",
        number(Some(0.0), Some(180.0)).into()
    );
}
use track_schemas::{AngleTrackSchema, PointTrackSchema, RotationTrackSchema, VectorTrackSchema};

/// Time in a scene: the frames to render, the frame rate, and keyframed values of the camera,
/// the objects and the lights. A frame is a pure function of (scene, frame):
/// [`SceneDescription::at_frame`]. Frames before a track's first key or after its last hold
/// that key's value (Blender's constant extrapolation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Animation {
    /// Frames per second, for tools that play the frames back (and glTF's seconds); the frames
    /// rendered do not depend on it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(exclusive_minimum = 0.0, maximum = 1000.0)]
    pub frame_rate: Option<f64>,
    /// The frames `spindle render` renders when `--frames` does not say (default: frame 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames: Option<FrameRange>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraAnimation>,
    /// At most one entry an object.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<ObjectAnimation>,
    /// At most one entry a light.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<LightAnimation>,
}

/// The frames `start` to `end`, both included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FrameRange {
    #[schema(maximum = 999999)]
    pub start: u32,
    #[schema(maximum = 999999)]
    pub end: u32,
}

impl FrameRange {
    /// The frames, in order.
    pub fn frames(&self) -> std::ops::RangeInclusive<u32> {
        self.start..=self.end
    }

    /// How many frames.
    pub fn len(&self) -> u64 {
        u64::from(self.end.saturating_sub(self.start)) + 1
    }

    /// Never: a range holds its start.
    pub fn is_empty(&self) -> bool {
        false
    }
}

/// How a track's value goes from one key to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Straight between keys; rotations by spherical linear interpolation (slerp), the
    /// shorter way round (glTF's LINEAR).
    #[default]
    Linear,
    /// A cubic Hermite curve through the keys whose slope at a key is the chord of its two
    /// neighbours, (next − previous) / (their frame difference) (Catmull–Rom's, for evenly spaced
    /// keys), and zero at the first and last key (an ease in and out, as Blender's default
    /// auto-clamped Bézier handles); rotations component by component on the quaternions, each
    /// key on the side of the previous one, then normalised (as Blender's quaternion curves).
    Smooth,
    /// The key's value until the next key (glTF's STEP, Blender's constant).
    Step,
}

/// A keyframed value: `keys` in increasing frame order, one key a frame at most.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Track<V> {
    #[serde(default)]
    pub interpolation: Interpolation,
    pub keys: Vec<Key<V>>,
}

/// A track's value at a frame (a fraction of a frame allowed: glTF's keys are in seconds).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key<V> {
    pub frame: f64,
    pub value: V,
}

/// The camera's keyframed fields; a track replaces the field it names at every frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraAnimation {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<PointTrackSchema>)]
    pub position: Option<Track<Vec3>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<PointTrackSchema>)]
    pub look_at: Option<Track<Vec3>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<VectorTrackSchema>)]
    pub up: Option<Track<Vec3>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<AngleTrackSchema>)]
    pub fov_y: Option<Track<f64>>,
}

/// An object's keyframed placement: `objects[object]`'s `transform.translate`, its rotation
/// (replacing `transform.rotate_deg`) and `transform.scale`; a track replaces its field at
/// every frame, so the field itself must be left at its default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectAnimation {
    /// The index of the object in `objects`.
    pub object: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<PointTrackSchema>)]
    pub translate: Option<Track<Vec3>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<RotationTrackSchema>)]
    pub rotation: Option<Track<Quat>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<VectorTrackSchema>)]
    pub scale: Option<Track<Vec3>>,
}

/// A light's keyframed placement: `position` moves a point light's `position`, a sphere
/// light's `center` or a quad light's `corner` (its edges kept); `direction` turns a
/// directional light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LightAnimation {
    /// The index of the light in `lights`.
    pub light: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<PointTrackSchema>)]
    pub position: Option<Track<Vec3>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<VectorTrackSchema>)]
    pub direction: Option<Track<Vec3>>,
}

/// A whole scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    pub camera: Camera,
    pub film: Film,
    #[serde(default)]
    pub lights: Vec<Light>,
    #[serde(default)]
    pub objects: Vec<Object>,
    /// Constant radiance seen where a camera path leaves the scene.
    #[serde(default)]
    #[schema(value_type = ColorSchema)]
    pub background: Rgb,
    #[serde(default)]
    pub integrator: Integrator,
    /// Time: keyframed values and the frames to render. `None` (or absent): a still, the
    /// format and the bits of a scene without time. [`SceneDescription::at_frame`] resolves a
    /// frame into a scene without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation: Option<Animation>,
}

/// Pinhole camera. Image x goes right, y goes down (row 0 at the top).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    #[schema(value_type = PointSchema)]
    pub position: Vec3,
    #[schema(value_type = PointSchema)]
    pub look_at: Vec3,
    #[serde(default = "default_up")]
    #[schema(value_type = VectorSchema)]
    pub up: Vec3,
    /// Full vertical field of view, degrees.
    #[schema(exclusive_minimum = 0.0, exclusive_maximum = 180.0)]
    pub fov_y: f64,
}

fn default_up() -> Vec3 {
    [0.0, 1.0, 0.0]
}

/// Image size and sampling.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Film {
    #[schema(minimum = 1, maximum = 16384)]
    pub width: u32,
    #[schema(minimum = 1, maximum = 16384)]
    pub height: u32,
    /// Camera samples per pixel; with `target_error`, the most a pixel may take.
    #[serde(default = "default_spp")]
    #[schema(minimum = 1, maximum = 65536)]
    pub spp: u32,
    /// Seed of the counter-based random numbers; the same seed gives the same bits.
    #[serde(default)]
    pub seed: u64,
    /// Adaptive sampling: a pixel stops after a batch of [`ADAPTIVE_BATCH`] samples once the
    /// standard error of its luminance is at most this fraction of its luminance (or is 0), and
    /// at `spp` samples in any case. `None`: every pixel takes `spp` samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(exclusive_minimum = 0.0, exclusive_maximum = 1.0)]
    pub target_error: Option<f64>,
    /// Progressive passes for at most about this many seconds (`spindle render --workers 0`):
    /// each pass adds [`ADAPTIVE_BATCH`] samples to every pixel still sampling, up to `spp`; no
    /// pass starts that the previous one's duration says would end past the budget. The image is
    /// that of the complete passes, which is the image of `spp` = the samples reached, recorded
    /// in the header. `None`: one pass to `spp` (or `target_error`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(exclusive_minimum = 0.0, exclusive_maximum = 604800.0)]
    pub time_budget_s: Option<f64>,
    /// Write the EXR in 16-bit half floats (half the size, about three significant digits,
    /// values above 65504 infinite) instead of 32-bit floats. The pixels rendered are the same.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub half: bool,
    /// Optional passes written beside the radiance layers ([`crate::aov`]): any of `depth`,
    /// `normal`, `albedo`, `id`, each at most once. Empty: none (alpha is always written).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub passes: Vec<crate::aov::Aov>,
}

/// Samples a pixel takes between two checks of its error under `film.target_error` (and
/// before the first): enough for the variance estimate to mean something, and a multiple of the
/// sampler's 16-sample strata.
pub const ADAPTIVE_BATCH: u32 = 16;

fn default_spp() -> u32 {
    4
}

/// A light source. Lights are outside every medium.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Light {
    /// Isotropic point light; `intensity` in W/sr.
    Point {
        #[schema(value_type = PointSchema)]
        position: Vec3,
        #[schema(value_type = ColorSchema)]
        intensity: Rgb,
    },
    /// Spherical area light with uniform emitted radiance, sampled by area.
    Sphere {
        #[schema(value_type = PointSchema)]
        center: Vec3,
        #[schema(minimum = 1e-6, maximum = 1e6)]
        radius: f64,
        #[schema(value_type = ColorSchema)]
        radiance: Rgb,
    },
    /// A distant light (the sun): rays travel along `direction` (need not be unit length) and
    /// give `irradiance` (W/m²) on a surface facing them. `angular_diameter` (degrees, default 0:
    /// parallel rays) spreads them over a disk of uniform radiance, seen by the camera.
    Directional {
        #[schema(value_type = VectorSchema)]
        direction: Vec3,
        #[schema(value_type = ColorSchema)]
        irradiance: Rgb,
        #[serde(default)]
        #[schema(minimum = 0.0, maximum = 30.0)]
        angular_diameter: f64,
    },
    /// A one-sided rectangular area light of uniform `radiance`: the rectangle with corners
    /// `corner`, `corner + edge_u`, `corner + edge_u + edge_v`, `corner + edge_v` (the two edges
    /// perpendicular), emitting toward `edge_u × edge_v` only.
    Quad {
        #[schema(value_type = PointSchema)]
        corner: Vec3,
        #[schema(value_type = VectorSchema)]
        edge_u: Vec3,
        #[schema(value_type = VectorSchema)]
        edge_v: Vec3,
        #[schema(value_type = ColorSchema)]
        radiance: Rgb,
    },
}

/// One object: a shape, placed by a transform, made of a material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Object {
    pub shape: Shape,
    #[serde(default)]
    pub transform: Transform,
    pub material: Material,
}

/// A triangle-mesh shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A Wavefront OBJ file; `path` is relative to the scene file. In a farm job the path is
    /// only a key into the job's asset table (see `protocol`): nobody opens it as given.
    /// A file without normals is smoothed across every edge, or with `crease_angle` (degrees,
    /// 0…180) only across edges where its faces meet at less than that angle (0: flat faces).
    Obj {
        path: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        #[schema(minimum = 0.0, maximum = 180.0)]
        crease_angle: Option<f64>,
    },
    /// Unit-radius icosahedron subdivided `subdivisions` times (20·4^s triangles), scaled to `radius`.
    Icosphere {
        #[schema(minimum = 1e-6, maximum = 1e6)]
        radius: f64,
        #[schema(maximum = 10)]
        subdivisions: u32,
    },
    /// Icosphere displaced radially by a smooth function:
    /// `r = radius · (1 + amplitude · noise(frequency · p, seed))`, with noise in [-1, 1].
    BumpySphere {
        #[schema(minimum = 1e-6, maximum = 1e6)]
        radius: f64,
        #[schema(maximum = 10)]
        subdivisions: u32,
        #[schema(minimum = 0.0, exclusive_maximum = 1.0)]
        amplitude: f64,
        #[schema(minimum = 0.0)]
        frequency: f64,
        #[serde(default)]
        seed: u64,
    },
    /// An axis-aligned box centred at the origin, `size` = its extents along x, y and z. Its top
    /// (the +y face) may be displaced by `waves` — a water surface, say; the sides follow the
    /// waves, so the box stays closed, and its edges stay sharp.
    Box {
        #[schema(value_type = VectorSchema)]
        size: Vec3,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        waves: Option<Waves>,
    },
}

/// A box's wavy top: the height field `y = size[1]/2 + h(x, z)`, a sum of a few sine waves of
/// random directions and phases drawn from `seed`, with wavelengths between `wavelength/2` and
/// `wavelength`, and `|h| <= amplitude` everywhere. The top is an even grid of
/// `segments × segments` squares, two triangles each, with the field's exact normals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Waves {
    #[schema(minimum = 0.0)]
    pub amplitude: f64,
    #[schema(minimum = 1e-6, maximum = 1e6)]
    pub wavelength: f64,
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "default_wave_segments")]
    #[schema(minimum = 1, maximum = 1024)]
    pub segments: u32,
}

fn default_wave_segments() -> u32 {
    64
}

/// `scale`, then `rotate_deg` about x, y, z in that order, then `translate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Transform {
    #[serde(default = "default_scale")]
    #[schema(value_type = VectorSchema)]
    pub scale: Vec3,
    #[serde(default)]
    #[schema(value_type = VectorSchema)]
    pub rotate_deg: Vec3,
    #[serde(default)]
    #[schema(value_type = PointSchema)]
    pub translate: Vec3,
}

fn default_scale() -> Vec3 {
    [1.0, 1.0, 1.0]
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            scale: default_scale(),
            rotate_deg: [0.0; 3],
            translate: [0.0; 3],
        }
    }
}

/// What an object is made of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Material {
    /// A smooth refractive interface of relative index `eta` (medium over air, >= 1) enclosing
    /// a homogeneous participating medium.
    Dielectric {
        #[schema(minimum = 1.0, maximum = 10.0)]
        eta: f64,
        medium: Medium,
    },
    /// An opaque Lambertian surface (a floor).
    Diffuse {
        #[schema(value_type = UnitColorSchema)]
        reflectance: Rgb,
    },
}

/// A homogeneous participating medium.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Medium {
    /// Extinction coefficient per scene unit.
    #[schema(value_type = ColorSchema)]
    pub sigma_t: Rgb,
    /// Single-scattering albedo σ_s/σ_t in [0, 1].
    #[schema(value_type = UnitColorSchema)]
    pub albedo: Rgb,
    #[serde(default)]
    pub phase: Phase,
}

/// Phase function of a medium.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Phase {
    #[default]
    Isotropic,
    /// Henyey–Greenstein with mean cosine `g` in (-1, 1).
    Hg {
        #[schema(exclusive_minimum = -1.0, exclusive_maximum = 1.0)]
        g: f64,
    },
}

/// The integrator: depth limits and the single-scattering method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Integrator {
    /// Specular bounces followed along a camera path.
    #[serde(default = "default_max_depth")]
    #[schema(maximum = 64)]
    pub max_depth: u32,
    /// Internal reflections followed inside a medium (0 = only the first segment inside).
    #[serde(default = "default_internal_reflections")]
    #[schema(maximum = 64)]
    pub internal_reflections: u32,
    #[serde(default)]
    pub single_scatter: SingleScatter,
    #[serde(default)]
    pub multiple_scatter: MultipleScatter,
}

fn default_max_depth() -> u32 {
    8
}
fn default_internal_reflections() -> u32 {
    2
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator {
            max_depth: default_max_depth(),
            internal_reflections: default_internal_reflections(),
            single_scatter: SingleScatter::default(),
            multiple_scatter: MultipleScatter::default(),
        }
    }
}

/// Multiple scattering inside a medium: from each camera segment, paths scattered by the
/// attenuation and the phase function, whose every segment inside the medium gets the
/// single-scattering light integral toward every light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MultipleScatter {
    /// The highest scattering order computed (1 turns multiple scattering off; the
    /// `multiple_scatter` layer holds orders 2 to `max_order`).
    #[serde(default = "default_max_order")]
    #[schema(minimum = 1, maximum = 1024)]
    pub max_order: u32,
    /// Secondary paths started from each camera segment.
    #[serde(default = "default_paths")]
    #[schema(minimum = 1, maximum = 64)]
    pub paths: u32,
    /// The light integral along each secondary segment: `auto` runs the object's
    /// single-scattering model (the plan's), or one named here.
    #[serde(default)]
    pub method: SecondaryMethod,
}

fn default_max_order() -> u32 {
    64
}
fn default_paths() -> u32 {
    1
}

impl Default for MultipleScatter {
    fn default() -> Self {
        MultipleScatter {
            max_order: default_max_order(),
            paths: default_paths(),
            method: SecondaryMethod::default(),
        }
    }
}

/// The estimator of the light along a multiple-scattering path's secondary segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum SecondaryMethod {
    /// The object's single-scattering model, as the plan chose it.
    #[default]
    Auto,
    /// Holzschuch 2015: per-triangle depth intervals.
    Interval,
    /// Walter et al. 2009: stratified points along the segment.
    PointSampling,
    /// The straight-line approximation: fast, dark where the boundary bends the light.
    StraightLine,
}

/// Which single-scattering estimator runs, and its accuracy settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SingleScatter {
    #[serde(default)]
    pub method: ScatterMethod,
    /// Interval method: samples per triangle interval (midpoint rule).
    #[serde(default = "default_k")]
    #[schema(minimum = 1, maximum = 65536)]
    pub k: u32,
    /// Interval method: jitter the K samples (unbiased) instead of the midpoint rule.
    #[serde(default)]
    pub jitter: bool,
    /// Newton stopping tolerance on ‖f‖ for sample points (relative, dimensionless).
    #[serde(default = "default_newton_tolerance")]
    #[schema(exclusive_minimum = 0.0, maximum = 0.01)]
    pub newton_tolerance: f64,
    /// Point sampling (and the reference): stratified samples along each camera segment.
    #[serde(default = "default_samples_per_segment")]
    #[schema(minimum = 1, maximum = 1048576)]
    pub samples_per_segment: u32,
    /// Pruning stages; each can be switched off for measurement.
    #[serde(default)]
    pub pruning: Pruning,
    /// `auto` only: allowed relative error when choosing a cheaper model (e.g. straight line).
    #[serde(default = "default_auto_tolerance")]
    #[schema(minimum = 0.0, exclusive_maximum = 1.0)]
    pub auto_tolerance: f64,
}

fn default_k() -> u32 {
    1
}
fn default_newton_tolerance() -> f64 {
    1e-10
}
fn default_samples_per_segment() -> u32 {
    64
}
fn default_auto_tolerance() -> f64 {
    0.0
}

impl Default for SingleScatter {
    fn default() -> Self {
        SingleScatter {
            method: ScatterMethod::default(),
            k: default_k(),
            jitter: false,
            newton_tolerance: default_newton_tolerance(),
            samples_per_segment: default_samples_per_segment(),
            pruning: Pruning::default(),
            auto_tolerance: default_auto_tolerance(),
        }
    }
}

/// The single-scattering estimators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ScatterMethod {
    /// Choose the cheapest exact model the scene allows (and say which in the log and EXR header).
    #[default]
    Auto,
    /// Holzschuch 2015: per-triangle depth intervals.
    Interval,
    /// Walter et al. 2009: stratified points along the segment.
    PointSampling,
    /// Straight-line approximation (light reaches V in a straight line through the boundary).
    StraightLine,
    /// Brute force with no pruning and dense sampling, for tests.
    Reference,
    /// No single scattering (the `single_scatter` layer stays black).
    None,
}

/// Pruning stages of the hierarchical descent ([H15] §3.2.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Pruning {
    /// The spindle test on BVH nodes.
    #[serde(default = "yes")]
    pub spindle: bool,
    /// The half-vector / shading-normal cone test, on BVH nodes (the cone of every normal below
    /// the node) and per triangle.
    #[serde(default = "yes")]
    pub cone: bool,
    /// Geometric sidedness per triangle: the light in front of the triangle's plane and the
    /// camera point behind it (physics.md §2.3), which also trims the t-range.
    #[serde(default = "yes")]
    pub plane: bool,
}

fn yes() -> bool {
    true
}

impl Default for Pruning {
    fn default() -> Self {
        Pruning {
            spindle: true,
            cone: true,
            plane: true,
        }
    }
}
