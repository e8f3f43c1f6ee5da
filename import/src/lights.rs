//! `KHR_lights_punctual` lights as spindle lights, with their photometric units made
//! radiometric.
//!
//! glTF gives a point light's intensity in candela (lm/sr) and a directional light's in lux
//! (lm/m²); spindle's are W/sr ([`Light::Point`]'s `intensity`) and W/unit²
//! ([`Light::Directional`]'s `irradiance`; glTF's unit is the metre). One watt of light at
//! 555 nm is [`LUMENS_PER_WATT`] lumens (the definition of the candela), so
//! `intensity = colour · I / 683` and `irradiance = colour · E / 683`: exactly the inverse of
//! Blender's exporter, which writes `P / 4π · 683` cd for a point light of `P` W and `S · 683`
//! lx for a sun of strength `S` W/m². Spot lights are not supported (the caller lists them as
//! ignored); `range` is a cut-off for real-time renderers and is ignored too.

use glam::{DMat4, DVec3};
use spindle_common::scene::Light;

use crate::error::ImportError;

/// Lumens per watt at 555 nm, the factor between glTF's photometric and spindle's radiometric
/// units.
pub const LUMENS_PER_WATT: f64 = 683.0;

/// What a glTF light becomes.
#[derive(Debug, Clone, PartialEq)]
pub enum Converted {
    Light(Light),
    /// A spot light, which spindle cannot render.
    Spot,
}

/// The spindle light of `light` on a node whose world matrix is `world`: a point light at the
/// node's origin, a directional light shining along the node's −z axis. `element` names the
/// light in errors.
pub fn convert(
    light: &gltf::khr_lights_punctual::Light,
    world: &DMat4,
    element: &str,
) -> Result<Converted, ImportError> {
    let colour = light.color().map(f64::from);
    let intensity = f64::from(light.intensity());
    if !(intensity >= 0.0 && intensity.is_finite()) {
        return Err(ImportError::new(
            format!("{element}.intensity"),
            format!("must be >= 0 and finite, got {intensity}"),
        ));
    }
    if let Some(k) = colour.iter().position(|c| !(*c >= 0.0 && c.is_finite())) {
        return Err(ImportError::new(
            format!("{element}.color[{k}]"),
            format!("must be >= 0 and finite, got {}", colour[k]),
        ));
    }
    let radiometric = colour.map(|c| c * intensity / LUMENS_PER_WATT);
    Ok(match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => Converted::Light(Light::Point {
            position: world.transform_point3(DVec3::ZERO).to_array(),
            intensity: radiometric,
        }),
        gltf::khr_lights_punctual::Kind::Directional => {
            let direction = world.transform_vector3(DVec3::NEG_Z);
            if direction.length() == 0.0 || !direction.is_finite() {
                return Err(ImportError::new(
                    element,
                    "its node's transform collapses the light's direction (−z) to zero",
                ));
            }
            Converted::Light(Light::Directional {
                direction: direction.to_array(),
                irradiance: radiometric,
                angular_diameter: 0.0,
            })
        }
        gltf::khr_lights_punctual::Kind::Spot { .. } => Converted::Spot,
    })
}
