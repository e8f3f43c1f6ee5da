//! Which glTF camera the image is seen through, and as what spindle camera.
//!
//! glTF has no "active" camera: without `--camera NAME` the first node with a camera in the
//! scene's depth-first order is chosen (the others are listed as ignored); with it, the node or
//! camera of that name. A glTF camera looks along its node's −z axis with +y up; spindle's
//! `look_at` is one unit along that axis, `up` the node's +y, and `fov_y` the perspective's
//! `yfov` in degrees. Orthographic cameras are refused: spindle's camera is a pinhole.

use glam::{DMat4, DVec3};
use spindle_common::scene::{Camera, Vec3};

use crate::error::ImportError;
use crate::hierarchy::PlacedNode;
use crate::ignored::{self, Ignored};

/// The chosen camera as spindle's, with the aspect ratio its film should have.
#[derive(Debug, Clone, PartialEq)]
pub struct Chosen {
    pub camera: Camera,
    /// `aspectRatio` (width / height), when the file gives one.
    pub aspect: Option<f64>,
    /// The node it sits on.
    pub node: usize,
}

/// How a camera is named: its node's name or its own.
fn names<'a>(placed: &PlacedNode<'a>, camera: &gltf::Camera<'a>) -> [Option<&'a str>; 2] {
    [placed.node.name(), camera.name()]
}

/// The camera to render through (see the module documentation); every other camera node goes
/// to `ignored`. `scene` names the glTF scene in errors.
pub fn choose(
    placed: &[PlacedNode],
    name: Option<&str>,
    scene: &str,
    ignored: &mut Ignored,
) -> Result<Chosen, ImportError> {
    let cameras: Vec<(&PlacedNode, gltf::Camera)> = placed
        .iter()
        .filter_map(|p| p.node.camera().map(|c| (p, c)))
        .collect();
    let label = |(p, c): &(&PlacedNode, gltf::Camera)| {
        let [node, camera] = names(p, c);
        format!(
            "nodes[{}]{} (cameras[{}]{})",
            p.node.index(),
            node.map(|n| format!(" {n:?}")).unwrap_or_default(),
            c.index(),
            camera.map(|n| format!(" {n:?}")).unwrap_or_default()
        )
    };
    if cameras.is_empty() {
        return Err(ImportError::new(
            scene,
            "has no camera: no node of the scene has a `camera` (export the camera too, e.g. \
             Blender's \"Include: Cameras\")",
        ));
    }
    let chosen = match name {
        None => 0,
        Some(wanted) => {
            let matches: Vec<usize> = (0..cameras.len())
                .filter(|&i| names(cameras[i].0, &cameras[i].1).contains(&Some(wanted)))
                .collect();
            match matches[..] {
                [one] => one,
                [] => {
                    let all: Vec<String> = cameras.iter().map(label).collect();
                    return Err(ImportError::new(
                        scene,
                        format!(
                            "--camera {wanted:?}: no camera or camera node has this name; the \
                             cameras are {}",
                            all.join(", ")
                        ),
                    ));
                }
                _ => {
                    let all: Vec<String> = matches.iter().map(|&i| label(&cameras[i])).collect();
                    return Err(ImportError::new(
                        scene,
                        format!(
                            "--camera {wanted:?}: several cameras have this name: {}",
                            all.join(", ")
                        ),
                    ));
                }
            }
        }
    };
    for (i, camera) in cameras.iter().enumerate() {
        if i != chosen {
            ignored.add(ignored::CAMERAS, label(camera));
        }
    }
    let (placed, camera) = &cameras[chosen];
    let element = format!("cameras[{}]", camera.index());
    let perspective = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p,
        gltf::camera::Projection::Orthographic(_) => {
            return Err(ImportError::new(
                element,
                format!(
                    "is orthographic (on nodes[{}]); spindle's camera is a pinhole: export a \
                     perspective camera",
                    placed.node.index()
                ),
            ));
        }
    };
    let fov_y = f64::from(perspective.yfov()).to_degrees();
    if !(fov_y > 0.0 && fov_y < 180.0) {
        return Err(ImportError::new(
            format!("{element}.perspective.yfov"),
            format!("must be in (0, π) radians, got {}", perspective.yfov()),
        ));
    }
    let aspect = perspective.aspect_ratio().map(f64::from);
    if let Some(a) = aspect
        && !(a > 0.0 && a.is_finite())
    {
        return Err(ImportError::new(
            format!("{element}.perspective.aspectRatio"),
            format!("must be > 0, got {a}"),
        ));
    }
    let node = format!("nodes[{}]", placed.node.index());
    let [position, look_at, up] = pose(&placed.world, &node)?;
    Ok(Chosen {
        camera: Camera {
            position,
            look_at,
            up,
            fov_y,
        },
        aspect,
        node: placed.node.index(),
    })
}

/// `[position, look_at, up]` of a camera on a node whose world matrix is `world`: the node's
/// origin, one unit along its −z axis, its +y axis. `node` names it in errors.
pub fn pose(world: &DMat4, node: &str) -> Result<[Vec3; 3], ImportError> {
    let position = world.transform_point3(DVec3::ZERO);
    let forward = world
        .transform_vector3(DVec3::NEG_Z)
        .try_normalize()
        .ok_or_else(|| {
            ImportError::new(node, "its transform collapses the camera's view axis (−z)")
        })?;
    let up = world.transform_vector3(DVec3::Y);
    Ok([
        position.to_array(),
        (position + forward).to_array(),
        up.to_array(),
    ])
}
