//! A glTF mesh primitive as a triangle soup in world space: its positions placed by the node's
//! world matrix, its normals by the matrix's inverse transpose (renormalised), its indices
//! triangulated (triangles, strips, fans), and its winding reversed where the matrix mirrors
//! space, so front faces stay front faces.

use glam::{DMat3, DMat4, DVec3};
use gltf::Semantic;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use crate::error::ImportError;

/// A primitive's triangles in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldTriangles {
    pub positions: Vec<DVec3>,
    /// One unit normal per position, when the primitive has `NORMAL`.
    pub normals: Option<Vec<DVec3>>,
    pub triangles: Vec<[u32; 3]>,
}

/// The triangles of `primitive` placed by `world`; `None` for points and lines. `element` names
/// the primitive (`meshes[0].primitives[1]`) in errors; accessors are named by their index.
pub fn world_triangles(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    world: &DMat4,
    element: &str,
) -> Result<Option<WorldTriangles>, ImportError> {
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(None);
    }
    let position_accessor = primitive.get(&Semantic::Positions).ok_or_else(|| {
        ImportError::new(
            format!("{element}.attributes"),
            "has no POSITION: a primitive needs vertex positions",
        )
    })?;
    check_accessor(&position_accessor, "POSITION", element, true)?;
    let normal_accessor = primitive.get(&Semantic::Normals);
    if let Some(accessor) = &normal_accessor {
        check_accessor(accessor, "NORMAL", element, true)?;
    }
    if let Some(accessor) = primitive.indices() {
        check_accessor(&accessor, "indices", element, false)?;
    }

    let reader = primitive.reader(|buffer| buffers.get(buffer.index()).map(Vec::as_slice));
    let out_of_range = |accessor: &gltf::Accessor, what: &str| {
        ImportError::new(
            format!("accessors[{}]", accessor.index()),
            format!("{what} of {element}: reaches past the end of its buffer view or buffer"),
        )
    };
    let local: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| out_of_range(&position_accessor, "POSITION"))?
        .collect();
    let count = local.len();
    let positions: Vec<DVec3> = local
        .iter()
        .map(|p| world.transform_point3(DVec3::from_array(p.map(f64::from))))
        .collect();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(ImportError::new(
            format!("accessors[{}]", position_accessor.index()),
            format!("POSITION {i} of {element} is not finite once placed"),
        ));
    }

    let normals = match &normal_accessor {
        None => None,
        Some(accessor) => {
            let local: Vec<[f32; 3]> = reader
                .read_normals()
                .ok_or_else(|| out_of_range(accessor, "NORMAL"))?
                .collect();
            if local.len() != count {
                return Err(ImportError::new(
                    format!("accessors[{}]", accessor.index()),
                    format!(
                        "NORMAL of {element} has {} values for {count} positions",
                        local.len()
                    ),
                ));
            }
            let normal_matrix = DMat3::from_mat4(*world).inverse().transpose();
            let mut placed = Vec::with_capacity(count);
            for (i, n) in local.iter().enumerate() {
                let n = normal_matrix * DVec3::from_array(n.map(f64::from));
                let unit = n.try_normalize().ok_or_else(|| {
                    ImportError::new(
                        format!("accessors[{}]", accessor.index()),
                        format!("NORMAL {i} of {element} is zero or not finite"),
                    )
                })?;
                placed.push(unit);
            }
            Some(placed)
        }
    };

    let indices: Vec<u32> = match primitive.indices() {
        None => (0..count as u32).collect(),
        Some(accessor) => {
            let indices: Vec<u32> = reader
                .read_indices()
                .ok_or_else(|| out_of_range(&accessor, "indices"))?
                .into_u32()
                .collect();
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= count) {
                return Err(ImportError::new(
                    format!("accessors[{}]", accessor.index()),
                    format!(
                        "indices of {element}: index {bad} names no vertex (there are {count})"
                    ),
                ));
            }
            indices
        }
    };
    let mut triangles = triangulate(mode, &indices).ok_or_else(|| {
        ImportError::new(
            element,
            format!(
                "{} indices do not make whole triangles ({mode:?})",
                indices.len()
            ),
        )
    })?;
    if world.determinant() < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    Ok(Some(WorldTriangles {
        positions,
        normals,
        triangles,
    }))
}

/// The triangles of an index list in glTF's primitive `mode`, wound as the specification says;
/// triangles that repeat a vertex (a strip's joins) are dropped. `None` when a `Triangles`
/// list is not a multiple of three.
pub fn triangulate(mode: Mode, indices: &[u32]) -> Option<Vec<[u32; 3]>> {
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::Triangles => {
            if !indices.len().is_multiple_of(3) {
                return None;
            }
            indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        }
        // Triangle i is (p_i, p_{i+1+i%2}, p_{i+2-i%2}).
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                let odd = i % 2;
                [indices[i], indices[i + 1 + odd], indices[i + 2 - odd]]
            })
            .collect(),
        // Triangle i is (p_{i+1}, p_{i+2}, p_0).
        Mode::TriangleFan => (0..indices.len().saturating_sub(2))
            .map(|i| [indices[i + 1], indices[i + 2], indices[0]])
            .collect(),
        _ => Vec::new(),
    };
    Some(
        triangles
            .into_iter()
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect(),
    )
}

/// The accessor holds what the reader will read: `vector` attributes are VEC3 of 32-bit floats,
/// indices are unsigned scalars; at least one element; no sparse storage (not read here).
fn check_accessor(
    accessor: &gltf::Accessor,
    what: &str,
    element: &str,
    vector: bool,
) -> Result<(), ImportError> {
    let fits = if vector {
        accessor.dimensions() == Dimensions::Vec3 && accessor.data_type() == DataType::F32
    } else {
        accessor.dimensions() == Dimensions::Scalar
            && matches!(
                accessor.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            )
    };
    let wanted = if vector {
        "VEC3 of FLOAT"
    } else {
        "SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"
    };
    check_accessor_as(accessor, what, element, fits, wanted)
}

/// Checks that `accessor` (`fits`: of the type `wanted` names) can be read: at least one
/// element, not sparse, every element within its buffer view and the view within its buffer.
pub(crate) fn check_accessor_as(
    accessor: &gltf::Accessor,
    what: &str,
    element: &str,
    fits: bool,
    wanted: &str,
) -> Result<(), ImportError> {
    let name = format!("accessors[{}]", accessor.index());
    if !fits {
        return Err(ImportError::new(
            name,
            format!(
                "{what} of {element} must be {wanted}, got {:?} of {:?}",
                accessor.dimensions(),
                accessor.data_type()
            ),
        ));
    }
    if accessor.count() == 0 {
        return Err(ImportError::new(
            format!("{name}.count"),
            format!("{what} of {element}: must be at least 1"),
        ));
    }
    let Some(view) = accessor.view().filter(|_| accessor.sparse().is_none()) else {
        return Err(ImportError::new(
            name,
            format!(
                "{what} of {element}: sparse accessors (or none with no bufferView) are not \
                 supported"
            ),
        ));
    };
    let view_end = view.offset() as u128 + view.length() as u128;
    if view_end > view.buffer().length() as u128 {
        return Err(ImportError::new(
            format!("bufferViews[{}]", view.index()),
            format!(
                "reaches byte {view_end} of buffers[{}], which has {}",
                view.buffer().index(),
                view.buffer().length()
            ),
        ));
    }
    // offset + stride·(count − 1) + size ≤ the view's length, in arithmetic that cannot
    // overflow (a hostile count must not wrap around to a short read).
    let size = accessor.size() as u128;
    let stride = view.stride().map_or(size, |s| s as u128);
    let end = accessor.offset() as u128 + stride * (accessor.count() as u128 - 1) + size;
    if end > view.length() as u128 {
        return Err(ImportError::new(
            name,
            format!(
                "{what} of {element}: {} elements reach byte {end} of bufferViews[{}], which \
                 has {}",
                accessor.count(),
                view.index(),
                view.length()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
