//! Wavefront OBJ meshes, parsed from bytes the caller hands in (the renderer reads no files).
//!
//! Faces are triangulated (tobj's fan, exact for convex polygons), all groups and objects of a
//! file become one mesh, and the file's normals are used only when every vertex has one
//! (otherwise smooth angle-weighted normals are computed, across every edge or only across
//! edges below a crease angle). Coordinates that are not finite and
//! indices out of range are errors; materials (`mtllib`) are ignored.

use std::io::BufReader;

use glam::DVec3;

use crate::mesh::{MeshError, TriangleMesh};

/// Why an OBJ file could not become a mesh.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ObjError {
    #[error("not a valid OBJ file: {0}")]
    Parse(String),
    #[error("a vertex has a non-finite coordinate {0:?}")]
    NonFinite([f64; 3]),
    #[error("{0}")]
    Mesh(#[from] MeshError),
}

/// Parses OBJ bytes into a triangle mesh (file units, file orientation).
pub fn parse_obj(bytes: &[u8]) -> Result<TriangleMesh, ObjError> {
    Ok(parse_obj_with(bytes, None)?.mesh)
}

/// A parsed OBJ file and whether its normals were used.
#[derive(Debug, Clone)]
pub struct ObjMesh {
    pub mesh: TriangleMesh,
    /// Every vertex had a normal in the file, and they were used.
    pub normals_given: bool,
}

/// [`parse_obj`]; a file without normals is smoothed only across edges where its faces meet
/// at less than `crease` radians when given (see [`TriangleMesh::with_crease`]).
pub fn parse_obj_with(bytes: &[u8], crease: Option<f64>) -> Result<ObjMesh, ObjError> {
    // A face of many corners makes the triangulation below quadratic: refused first, by the
    // bound the coordinator checks at submission.
    spindle_common::validate::count_obj_triangles(bytes).map_err(ObjError::Parse)?;
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj_buf(&mut BufReader::new(bytes), &options, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| ObjError::Parse(e.to_string()))?;

    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut all_have_normals = true;
    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len() as u32;
        let count = mesh.positions.len() / 3;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2])),
        );
        if mesh.normals.len() == mesh.positions.len() {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0], c[1], c[2])),
            );
        } else {
            all_have_normals = false;
        }
        for t in mesh.indices.chunks_exact(3) {
            // Indices are checked here against the model's own vertices, so a bad index can
            // never reach into another model's range.
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= count) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: triangles.len(),
                    index: bad,
                    vertices: count,
                }
                .into());
            }
            triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    // Named by value: tobj renumbers vertices, so a mesh index would not match the file's.
    if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
        return Err(ObjError::NonFinite(p.to_array()));
    }
    let normals = (all_have_normals && !normals.is_empty()).then_some(normals);
    let normals_given = normals.is_some();
    let mesh = match (normals, crease) {
        (None, Some(crease)) => TriangleMesh::with_crease(positions, triangles, crease)?,
        (normals, _) => TriangleMesh::new(positions, normals, triangles)?,
    };
    Ok(ObjMesh {
        mesh,
        normals_given,
    })
}

#[cfg(test)]
mod tests;
