//! The node hierarchy of a glTF scene: every node reached from the scene's roots with its world
//! matrix, the product of its ancestors' local matrices and its own (glTF's column vectors:
//! `world = parent_world · local`), composed in f64.

use glam::{DMat4, DQuat, DVec3};

use crate::error::ImportError;

/// A node of the scene with its place in the world.
#[derive(Clone)]
pub struct PlacedNode<'a> {
    pub node: gltf::Node<'a>,
    pub world: DMat4,
}

/// The nodes of `scene` in depth-first order (a parent before its children, children in the
/// order they are listed), each once. A node reached twice (two parents, or a cycle) is an
/// error: glTF nodes form a forest.
pub fn walk<'a>(scene: &gltf::Scene<'a>) -> Result<Vec<PlacedNode<'a>>, ImportError> {
    let mut seen = std::collections::HashSet::new();
    let mut placed = Vec::new();
    let mut stack: Vec<(gltf::Node<'a>, DMat4)> = scene
        .nodes()
        .map(|node| (node, DMat4::IDENTITY))
        .collect::<Vec<_>>();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let element = format!("nodes[{}]", node.index());
        if !seen.insert(node.index()) {
            return Err(ImportError::new(
                element,
                format!(
                    "reached twice from scenes[{}] (a node has at most one parent, and no cycles)",
                    scene.index()
                ),
            ));
        }
        let world = parent * local_matrix(&node, &element)?;
        if !world.is_finite() {
            return Err(ImportError::new(
                element,
                "its world transform overflows (not finite)",
            ));
        }
        let mut children: Vec<_> = node.children().map(|child| (child, world)).collect();
        children.reverse();
        stack.extend(children);
        placed.push(PlacedNode { node, world });
    }
    Ok(placed)
}

/// A node's local matrix: its `matrix`, or `T · R · S` of its `translation`, `rotation` (a unit
/// quaternion; normalised here in f64) and `scale`.
pub fn local_matrix(node: &gltf::Node, element: &str) -> Result<DMat4, ImportError> {
    if let gltf::scene::Transform::Matrix { matrix } = node.transform() {
        if !matrix.as_flattened().iter().all(|v| v.is_finite()) {
            return Err(ImportError::new(
                format!("{element}.matrix"),
                "must be finite",
            ));
        }
        return Ok(DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from))));
    }
    let (translation, rotation, scale) = local_parts(node, element)?;
    Ok(DMat4::from_scale_rotation_translation(
        scale,
        rotation,
        translation,
    ))
}

/// A node's `translation`, `rotation` (normalised in f64) and `scale`, checked (those a
/// `matrix` decomposes into, for a node that gives one).
pub fn local_parts(node: &gltf::Node, element: &str) -> Result<(DVec3, DQuat, DVec3), ImportError> {
    let (translation, rotation, scale) = node.transform().decomposed();
    let finite = |values: &[f32], field: &str| {
        if values.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(ImportError::new(
                format!("{element}.{field}"),
                "must be finite",
            ))
        }
    };
    finite(&translation, "translation")?;
    finite(&rotation, "rotation")?;
    finite(&scale, "scale")?;
    let [x, y, z, w] = rotation.map(f64::from);
    let rotation = DQuat::from_xyzw(x, y, z, w);
    if rotation.length() < 1e-6 {
        return Err(ImportError::new(
            format!("{element}.rotation"),
            format!("must be a unit quaternion, got [{x}, {y}, {z}, {w}]"),
        ));
    }
    Ok((
        DVec3::from_array(translation.map(f64::from)),
        rotation.normalize(),
        DVec3::from_array(scale.map(f64::from)),
    ))
}
