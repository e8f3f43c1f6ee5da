//! glTF materials as spindle materials.
//!
//! A material with `KHR_materials_transmission` (factor > 0) is a dielectric: its index is
//! `KHR_materials_ior`'s `ior` (default 1.5), and its medium's extinction comes from
//! `KHR_materials_volume`: light keeps the fraction `c` (the `attenuationColor`) over the
//! `attenuationDistance` `d`, so `σt = −ln(c) / d` per channel (0 without the extension, or
//! with `d` infinite, or where `c` = 1). glTF carries no scattering; the material's `extras`
//! may give it: [`ALBEDO_EXTRA`] (a number or `[r, g, b]` in [0, 1], default
//! [`DEFAULT_ALBEDO`]: the volume only absorbs, as `KHR_materials_volume` defines it) and
//! [`PHASE_G_EXTRA`] (Henyey–Greenstein `g` in (−1, 1); isotropic without it). Every other
//! material is diffuse with its base colour.

use spindle_common::scene::{Material, Medium, Phase, Rgb};

use crate::error::ImportError;
use crate::ignored::{self, Ignored};

/// The `extras` key of a transmissive material's single-scattering albedo.
pub const ALBEDO_EXTRA: &str = "spindle_albedo";
/// The `extras` key of a transmissive material's Henyey–Greenstein mean cosine.
pub const PHASE_G_EXTRA: &str = "spindle_phase_g";
/// The albedo without [`ALBEDO_EXTRA`]: no scattering, as glTF's volume is absorbing only.
pub const DEFAULT_ALBEDO: f64 = 0.0;
/// glTF's index of refraction without `KHR_materials_ior`.
pub const DEFAULT_IOR: f64 = 1.5;

/// `σt = −ln(c) / d` for one channel: the extinction under which light keeps the fraction `c`
/// after the distance `d` (Beer–Lambert). `c` = 1 or `d` = ∞ give 0; `c` = 0 gives ∞.
pub fn extinction(attenuation: f64, distance: f64) -> f64 {
    if attenuation == 1.0 || distance == f64::INFINITY {
        0.0
    } else {
        -attenuation.ln() / distance
    }
}

/// The spindle material of `material` (the glTF default material when its index is `None`).
/// What the conversion drops is recorded in `ignored`.
pub fn convert(material: &gltf::Material, ignored: &mut Ignored) -> Result<Material, ImportError> {
    let element = match material.index() {
        Some(i) => format!("materials[{i}]"),
        None => "the default material".to_string(),
    };
    let pbr = material.pbr_metallic_roughness();
    let [r, g, b, _alpha] = pbr.base_color_factor().map(f64::from);
    let base: Rgb = [r, g, b];
    if pbr.base_color_texture().is_some()
        || pbr.metallic_roughness_texture().is_some()
        || material.normal_texture().is_some()
        || material.occlusion_texture().is_some()
        || material.emissive_texture().is_some()
    {
        ignored.add(ignored::TEXTURES, &element);
    }
    if material.emissive_factor().iter().any(|&e| e > 0.0) {
        ignored.add(ignored::EMISSION, &element);
    }
    let transmission = material
        .transmission()
        .filter(|t| t.transmission_factor() > 0.0);
    let Some(transmission) = transmission else {
        if pbr.metallic_factor() > 0.0 && material.index().is_some() {
            ignored.add(ignored::METALLIC, &element);
        }
        check_unit_colour(
            &format!("{element}.pbrMetallicRoughness.baseColorFactor"),
            base,
        )?;
        return Ok(Material::Diffuse { reflectance: base });
    };
    if transmission.transmission_factor() < 1.0 {
        ignored.add(ignored::PARTIAL_TRANSMISSION, &element);
    }
    if transmission.transmission_texture().is_some() {
        ignored.add(ignored::TEXTURES, &element);
    }
    if base != [1.0, 1.0, 1.0] {
        ignored.add(ignored::TINTS, &element);
    }
    let eta = material.ior().map_or(DEFAULT_IOR, f64::from);
    if !(1.0..=10.0).contains(&eta) {
        return Err(ImportError::new(
            format!("{element}.extensions.KHR_materials_ior.ior"),
            format!(
                "must be in [1, 10] for a spindle dielectric (an object denser than the air), \
                 got {eta}"
            ),
        ));
    }
    let sigma_t = match material.volume() {
        None => [0.0; 3],
        Some(volume) => {
            let path = format!("{element}.extensions.KHR_materials_volume");
            if volume.thickness_factor() == 0.0 {
                ignored.add(ignored::THIN_WALLED, &element);
            }
            if volume.thickness_texture().is_some() {
                ignored.add(ignored::TEXTURES, &element);
            }
            let distance = f64::from(volume.attenuation_distance());
            if distance.is_nan() || distance <= 0.0 {
                return Err(ImportError::new(
                    format!("{path}.attenuationDistance"),
                    format!("must be > 0, got {distance}"),
                ));
            }
            let colour = volume.attenuation_color().map(f64::from);
            let mut sigma_t = [0.0; 3];
            for (k, &c) in colour.iter().enumerate() {
                if !(c > 0.0 && c <= 1.0) {
                    return Err(ImportError::new(
                        format!("{path}.attenuationColor[{k}]"),
                        format!("must be in (0, 1] (0 would be an infinite extinction), got {c}"),
                    ));
                }
                sigma_t[k] = extinction(c, distance);
            }
            sigma_t
        }
    };
    let extras = Extras::of(material, &element)?;
    let albedo = extras.albedo()?.unwrap_or([DEFAULT_ALBEDO; 3]);
    let phase = match extras.phase_g()? {
        Some(g) => Phase::Hg { g },
        None => Phase::Isotropic,
    };
    Ok(Material::Dielectric {
        eta,
        medium: Medium {
            sigma_t,
            albedo,
            phase,
        },
    })
}

fn check_unit_colour(path: &str, colour: Rgb) -> Result<(), ImportError> {
    match colour.iter().position(|c| !(0.0..=1.0).contains(c)) {
        None => Ok(()),
        Some(k) => Err(ImportError::new(
            format!("{path}[{k}]"),
            format!("must be in [0, 1], got {}", colour[k]),
        )),
    }
}

/// A material's `extras` object (empty when absent or not an object).
struct Extras {
    element: String,
    values: serde_json::Map<String, serde_json::Value>,
}

impl Extras {
    fn of(material: &gltf::Material, element: &str) -> Result<Extras, ImportError> {
        let values = match material.extras() {
            None => serde_json::Map::new(),
            Some(raw) => match serde_json::from_str(raw.get()) {
                Ok(serde_json::Value::Object(map)) => map,
                Ok(_) => serde_json::Map::new(),
                Err(e) => return Err(ImportError::new(format!("{element}.extras"), e)),
            },
        };
        Ok(Extras {
            element: element.to_string(),
            values,
        })
    }

    /// [`ALBEDO_EXTRA`]: one number for all channels or `[r, g, b]`, each in [0, 1].
    fn albedo(&self) -> Result<Option<Rgb>, ImportError> {
        let path = format!("{}.extras.{ALBEDO_EXTRA}", self.element);
        let Some(value) = self.values.get(ALBEDO_EXTRA) else {
            return Ok(None);
        };
        let bad = || {
            ImportError::new(
                &path,
                format!("must be a number or [r, g, b], each in [0, 1], got {value}"),
            )
        };
        let albedo = match value {
            serde_json::Value::Number(n) => {
                let a = n.as_f64().ok_or_else(bad)?;
                if !(0.0..=1.0).contains(&a) {
                    return Err(bad());
                }
                [a; 3]
            }
            serde_json::Value::Array(items) if items.len() == 3 => {
                let mut rgb = [0.0; 3];
                for (slot, item) in rgb.iter_mut().zip(items) {
                    *slot = item.as_f64().ok_or_else(bad)?;
                }
                rgb
            }
            _ => return Err(bad()),
        };
        check_unit_colour(&path, albedo)?;
        Ok(Some(albedo))
    }

    /// [`PHASE_G_EXTRA`]: a number in (−1, 1).
    fn phase_g(&self) -> Result<Option<f64>, ImportError> {
        let Some(value) = self.values.get(PHASE_G_EXTRA) else {
            return Ok(None);
        };
        match value.as_f64() {
            Some(g) if g > -1.0 && g < 1.0 => Ok(Some(g)),
            _ => Err(ImportError::new(
                format!("{}.extras.{PHASE_G_EXTRA}", self.element),
                format!("must be a number in (-1, 1), got {value}"),
            )),
        }
    }
}

#[cfg(test)]
mod tests;
