//! What a glTF file holds that spindle does not render: collected by kind while importing and
//! reported as one warning per kind, naming every element of that kind, so nothing is dropped
//! silently.

use std::collections::BTreeMap;

/// Elements the import left out, by kind. A kind is a short phrase that says what happens
/// instead ("skins (the meshes are rendered unskinned, placed by their nodes)").
#[derive(Debug, Default, Clone)]
pub struct Ignored {
    kinds: BTreeMap<&'static str, Vec<String>>,
}

/// Elements named per warning before the rest are counted.
pub const MAX_NAMED: usize = 12;

pub const SKINS: &str = "skins (the meshes are rendered unskinned, placed by their nodes)";
pub const MORPH_TARGETS: &str = "morph targets (the base shapes are rendered)";
pub const TEXTURES: &str = "textures (materials use their constant factors)";
pub const EXTENSIONS: &str = "extensions spindle does not read";
pub const CAMERAS: &str = "cameras not chosen (--camera NAME picks another)";
pub const SPOT_LIGHTS: &str =
    "spot lights (not supported: spindle has point, sphere, quad and directional lights)";
pub const LIGHT_RANGES: &str = "light ranges (lights reach every distance, falling off as 1/d²)";
pub const EMISSION: &str = "emission (materials do not emit: use lights)";
pub const METALLIC: &str = "metallic factors (opaque materials are diffuse with their base colour)";
pub const TINTS: &str =
    "base colours of transmissive materials (a dielectric's colour is its medium's attenuation)";
pub const PARTIAL_TRANSMISSION: &str = "partial transmission (a transmission factor below 1 is rendered as a clear dielectric surface)";
pub const THIN_WALLED: &str = "thin walls (thicknessFactor 0: rendered as solid dielectrics)";
pub const NOT_TRIANGLES: &str = "primitives of points or lines (only triangles are surfaces)";

impl Ignored {
    /// Records that `element` (a glTF path such as `animations[0]`) is left out as `kind`.
    pub fn add(&mut self, kind: &'static str, element: impl Into<String>) {
        let list = self.kinds.entry(kind).or_default();
        let element = element.into();
        if !list.contains(&element) {
            list.push(element);
        }
    }

    /// One line per kind: `glTF: <kind> ignored: a, b, c` (at most [`MAX_NAMED`] named, then a
    /// count of the rest).
    pub fn warnings(&self) -> Vec<String> {
        self.kinds
            .iter()
            .map(|(kind, elements)| {
                let mut named = elements
                    .iter()
                    .take(MAX_NAMED)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", ");
                if elements.len() > MAX_NAMED {
                    named.push_str(&format!(" and {} more", elements.len() - MAX_NAMED));
                }
                format!("glTF: {kind} ignored: {named}")
            })
            .collect()
    }
}
