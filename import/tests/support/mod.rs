//! Small glTF files written by hand for the importer's tests: JSON with one base64 buffer,
//! built from the values each test states (the same values its assertions check).

use base64::Engine;
use serde_json::{Value, json};

/// One buffer's bytes with its views and accessors, appended to as data is added.
#[derive(Default)]
pub struct Data {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Data {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len()
        }));
        self.bytes.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// A VEC3 FLOAT accessor (with the min and max glTF asks of positions).
    pub fn vec3(&mut self, values: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes);
        let min: Vec<f32> = (0..3)
            .map(|k| values.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min))
            .collect();
        let max: Vec<f32> = (0..3)
            .map(|k| {
                values
                    .iter()
                    .map(|v| v[k])
                    .fold(f32::NEG_INFINITY, f32::max)
            })
            .collect();
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": values.len(), "type": "VEC3",
            "min": min, "max": max
        }));
        self.accessors.len() - 1
    }

    /// A SCALAR FLOAT accessor (animation times).
    pub fn scalars(&mut self, values: &[f32]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let min = values.iter().copied().fold(f32::INFINITY, f32::min);
        let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": values.len(), "type": "SCALAR",
            "min": [min], "max": [max]
        }));
        self.accessors.len() - 1
    }

    /// An UNSIGNED_SHORT index accessor.
    pub fn indices(&mut self, values: &[u16]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5123, "count": values.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }

    /// Puts the buffer (as a data URI), its views and accessors into `document`.
    pub fn finish(self, document: &mut Value) {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bytes)
        );
        document["buffers"] = json!([{ "byteLength": self.bytes.len(), "uri": uri }]);
        document["bufferViews"] = Value::Array(self.views);
        document["accessors"] = Value::Array(self.accessors);
    }
}

/// The cube [−1, 1]³: 8 corners (bit 0 of the index is x, bit 1 y, bit 2 z), 12 triangles
/// wound counter-clockwise seen from outside (each checked by its cross product by hand).
pub const CUBE_CORNERS: [[f32; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
];
pub const CUBE_TRIANGLES: [u16; 36] = [
    0, 2, 3, 0, 3, 1, // −z
    4, 5, 7, 4, 7, 6, // +z
    0, 4, 6, 0, 6, 2, // −x
    1, 3, 7, 1, 7, 5, // +x
    0, 1, 5, 0, 5, 4, // −y
    2, 6, 7, 2, 7, 3, // +y
];

/// The 10 × 10 floor at y = 0, normal +y.
pub const FLOOR_CORNERS: [[f32; 3]; 4] = [
    [-5.0, 0.0, -5.0],
    [5.0, 0.0, -5.0],
    [5.0, 0.0, 5.0],
    [-5.0, 0.0, 5.0],
];
pub const FLOOR_TRIANGLES: [u16; 6] = [0, 3, 2, 0, 2, 1];

/// tan(yfov / 2) of both cameras: 0.5.
pub const TAN_HALF_FOV: f64 = 0.5;

/// The glass-cube scene the tests edit:
/// - `nodes[0]` "Floor": `meshes[1]`, `materials[1]` (diffuse, base colour 0.8, 0.7, 0.6);
/// - `nodes[1]` "Glass": `meshes[0]` (the cube), scale 0.5, translation (0, 1, 0), `materials[0]`
///   (transmission 1, ior 1.33, attenuation colour (0.5, 0.25, 1) over 2 units, extras albedo
///   (0.9, 0.8, 0.7) and g 0.3);
/// - `nodes[2]` "Rig": translation (5, 1, 0), rotated 90° about +y, whose child `nodes[3]`
///   "Side camera" holds `cameras[0]`, which so looks along −x from (5, 1, 0);
/// - `nodes[4]` "Front camera": `cameras[1]` at (0, 1, 5), looking along −z;
/// - `nodes[5]` "Lamp": a point light at (1, 4, 2), 1366 cd, colour (1, 0.5, 0.25);
/// - `nodes[6]` "Sun": a directional light rotated −90° about +x (so shining down), 2049 lx.
///
/// Both cameras have yfov 2·atan(0.5) and aspect 4:3.
pub fn glass_cube() -> Value {
    let mut data = Data::default();
    let cube_positions = data.vec3(&CUBE_CORNERS);
    let cube_indices = data.indices(&CUBE_TRIANGLES);
    let floor_positions = data.vec3(&FLOOR_CORNERS);
    let floor_normals = data.vec3(&[[0.0, 1.0, 0.0]; 4]);
    let floor_indices = data.indices(&FLOOR_TRIANGLES);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let yfov = 2.0 * TAN_HALF_FOV.atan();
    let perspective = json!({ "yfov": yfov, "aspectRatio": 4.0 / 3.0, "znear": 0.1 });
    let mut document = json!({
        "asset": { "version": "2.0", "generator": "spindle-import tests (by hand)" },
        "extensionsUsed": [
            "KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_volume",
            "KHR_materials_ior"
        ],
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2, 4, 5, 6] }],
        "nodes": [
            { "name": "Floor", "mesh": 1 },
            { "name": "Glass", "mesh": 0, "scale": [0.5, 0.5, 0.5], "translation": [0.0, 1.0, 0.0] },
            { "name": "Rig", "translation": [5.0, 1.0, 0.0], "rotation": [0.0, s, 0.0, s], "children": [3] },
            { "name": "Side camera", "camera": 0 },
            { "name": "Front camera", "camera": 1, "translation": [0.0, 1.0, 5.0] },
            { "name": "Lamp", "translation": [1.0, 4.0, 2.0],
              "extensions": { "KHR_lights_punctual": { "light": 0 } } },
            { "name": "Sun", "rotation": [-s, 0.0, 0.0, s],
              "extensions": { "KHR_lights_punctual": { "light": 1 } } }
        ],
        "cameras": [
            { "name": "side", "type": "perspective", "perspective": perspective },
            { "name": "front", "type": "perspective", "perspective": perspective }
        ],
        "meshes": [
            { "name": "Cube", "primitives": [{ "attributes": { "POSITION": cube_positions },
                                               "indices": cube_indices, "material": 0 }] },
            { "name": "Floor", "primitives": [{ "attributes": { "POSITION": floor_positions,
                                                                "NORMAL": floor_normals },
                                                "indices": floor_indices, "material": 1 }] }
        ],
        "materials": [
            {
                "name": "Glass",
                "pbrMetallicRoughness": { "metallicFactor": 0.0 },
                "extensions": {
                    "KHR_materials_transmission": { "transmissionFactor": 1.0 },
                    "KHR_materials_ior": { "ior": 1.33 },
                    "KHR_materials_volume": {
                        "thicknessFactor": 1.0,
                        "attenuationColor": [0.5, 0.25, 1.0],
                        "attenuationDistance": 2.0
                    }
                },
                "extras": { "spindle_albedo": [0.9, 0.8, 0.7], "spindle_phase_g": 0.3 }
            },
            {
                "name": "Floor",
                "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.7, 0.6, 1.0], "metallicFactor": 0.0 }
            }
        ],
        "extensions": {
            "KHR_lights_punctual": {
                "lights": [
                    { "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 1366.0 },
                    { "type": "directional", "intensity": 2049.0 }
                ]
            }
        }
    });
    data.finish(&mut document);
    document
}

/// An animation of `nodes[1]`'s translation over two keyframes, added to `document` with its
/// own buffer data (the second buffer, a data URI).
pub fn add_animation(document: &mut Value) {
    let mut data = Data::default();
    let times = data.scalars(&[0.0, 1.0]);
    let moves = data.vec3(&[[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]]);
    let mut extra = json!({});
    data.finish(&mut extra);
    let buffer_index = document["buffers"].as_array().unwrap().len();
    let view_base = document["bufferViews"].as_array().unwrap().len();
    let accessor_base = document["accessors"].as_array().unwrap().len();
    for view in extra["bufferViews"].as_array_mut().unwrap() {
        view["buffer"] = json!(buffer_index);
    }
    for accessor in extra["accessors"].as_array_mut().unwrap() {
        let v = accessor["bufferView"].as_u64().unwrap() as usize + view_base;
        accessor["bufferView"] = json!(v);
    }
    let push = |document: &mut Value, key: &str, items: &Value| {
        document[key]
            .as_array_mut()
            .unwrap()
            .extend(items.as_array().unwrap().iter().cloned());
    };
    push(document, "buffers", &extra["buffers"]);
    push(document, "bufferViews", &extra["bufferViews"]);
    push(document, "accessors", &extra["accessors"]);
    document["animations"] = json!([{
        "name": "Bob",
        "samplers": [{ "input": accessor_base + times, "output": accessor_base + moves }],
        "channels": [{ "sampler": 0, "target": { "node": 1, "path": "translation" } }]
    }]);
}
