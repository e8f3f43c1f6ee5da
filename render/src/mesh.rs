//! Triangle meshes: the geometry every object is made of, in f64.
//!
//! A [`TriangleMesh`] holds positions, one unit normal per vertex and `[u32; 3]` triangles.
//! Convention, stated once: **vertex normals point outward**, and triangles wind
//! counter-clockwise seen from outside, so the geometric normal `E1 × E2` points outward too.
//! Meshes are checked when built (finite coordinates, indices in range); their shape is
//! summarised by a [`MeshReport`] (degenerate triangles, closed or not).

use glam::DVec3;
use rayon::slice::ParallelSliceMut;

/// What is wrong with a mesh handed to [`TriangleMesh::new`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("the mesh has no triangles")]
    Empty,
    #[error("vertex {vertex} has a non-finite coordinate {value:?}")]
    NonFinitePosition { vertex: usize, value: [f64; 3] },
    #[error("vertex {vertex} has a non-finite or zero normal {value:?}")]
    BadNormal { vertex: usize, value: [f64; 3] },
    #[error("triangle {triangle} refers to vertex {index}, but there are only {vertices} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    #[error("{normals} normals for {vertices} vertices")]
    NormalCount { normals: usize, vertices: usize },
}

/// A triangle mesh with per-vertex outward unit normals.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// The mesh was given closed and wound inside-out, and was rewound outward.
    turned_outward: bool,
}

/// A summary of a mesh's shape, for warnings and logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshReport {
    pub triangles: usize,
    /// Triangles with (near) zero area; they are kept but can never be hit.
    pub degenerate: usize,
    /// Every edge (vertices welded by exact position) is shared by exactly two triangles that
    /// traverse it in opposite directions: the mesh bounds a volume.
    pub closed: bool,
    /// Edges used by only one triangle (holes).
    pub boundary_edges: usize,
    /// Edges used by two triangles that traverse them in the same direction: faces wound
    /// against their neighbours (flipped faces).
    pub flipped_edges: usize,
    /// The mesh was given closed but wound inside-out (negative enclosed volume); it was
    /// rewound outward.
    pub inside_out: bool,
}

impl TriangleMesh {
    /// A mesh from positions, optional per-vertex normals and triangles. Without normals, smooth
    /// angle-weighted normals are computed (see [`smooth_normals`]). A closed mesh wound
    /// inside-out (negative enclosed volume) is rewound outward. Given normals are normalised and
    /// flipped where they disagree with the winding's smooth normal, so all normals point out.
    pub fn new(
        positions: Vec<DVec3>,
        normals: Option<Vec<DVec3>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<TriangleMesh, MeshError> {
        let (triangles, turned_outward) = checked_and_oriented(&positions, triangles)?;
        let smooth = smooth_normals(&positions, &triangles);
        let normals = match normals {
            None => smooth,
            Some(given) => {
                if given.len() != positions.len() {
                    return Err(MeshError::NormalCount {
                        normals: given.len(),
                        vertices: positions.len(),
                    });
                }
                let mut out = Vec::with_capacity(given.len());
                for (vertex, (n, s)) in given.iter().zip(&smooth).enumerate() {
                    let Some(unit) = n.try_normalize() else {
                        return Err(MeshError::BadNormal {
                            vertex,
                            value: n.to_array(),
                        });
                    };
                    // Given normals that disagree with the (outward) winding are flipped.
                    out.push(if unit.dot(*s) < 0.0 { -unit } else { unit });
                }
                out
            }
        };
        Ok(TriangleMesh {
            positions,
            normals,
            triangles,
            turned_outward,
        })
    }

    /// A mesh from positions and triangles without normals, smoothed only across edges where
    /// its faces meet at less than `crease` radians (see [`creased_normals`]): π is
    /// [`TriangleMesh::new`]'s smooth rule exactly, 0 gives flat faces. Vertices on a crease
    /// are split, one per normal.
    pub fn with_crease(
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
        crease: f64,
    ) -> Result<TriangleMesh, MeshError> {
        let (triangles, turned_outward) = checked_and_oriented(&positions, triangles)?;
        let (positions, triangles, normals) = creased_normals(&positions, &triangles, crease);
        Ok(TriangleMesh {
            positions,
            normals,
            triangles,
            turned_outward,
        })
    }

    /// `(sharp, shared)`: of the edges shared by exactly two triangles (vertices welded by exact
    /// position), how many join faces whose normals are more than `angle` radians apart.
    pub fn sharp_edges(&self, angle: f64) -> (usize, usize) {
        let canon = weld(&self.positions);
        let mut faces: std::collections::HashMap<(u32, u32), Vec<usize>> = Default::default();
        for (ti, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (canon[t[k] as usize], canon[t[(k + 1) % 3] as usize]);
                faces.entry((a.min(b), a.max(b))).or_default().push(ti);
            }
        }
        let normal = |ti: usize| {
            let [p0, p1, p2] = self.corners(ti);
            (p1 - p0).cross(p2 - p0).try_normalize()
        };
        let cos = angle.cos();
        let mut sharp = 0;
        let mut shared = 0;
        for uses in faces.values().filter(|u| u.len() == 2) {
            shared += 1;
            if let (Some(a), Some(b)) = (normal(uses[0]), normal(uses[1]))
                && a.dot(b) < cos
            {
                sharp += 1;
            }
        }
        (sharp, shared)
    }

    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    pub fn normals(&self) -> &[DVec3] {
        &self.normals
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The corners `[P0, P1, P2]` of triangle `i`.
    pub fn corners(&self, i: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The vertex normals `[N0, N1, N2]` of triangle `i`.
    pub fn corner_normals(&self, i: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[i];
        [
            self.normals[a as usize],
            self.normals[b as usize],
            self.normals[c as usize],
        ]
    }

    /// Unnormalised geometric normal `E1 × E2` of triangle `i` (outward, length twice the area).
    pub fn geometric_normal(&self, i: usize) -> DVec3 {
        let [p0, p1, p2] = self.corners(i);
        (p1 - p0).cross(p2 - p0)
    }

    /// Unit interpolated shading normal `normalize(N0 + a(N1 − N0) + b(N2 − N0))` at barycentrics
    /// (a, b); falls back to the geometric normal where the interpolation vanishes.
    pub fn shading_normal(&self, i: usize, a: f64, b: f64) -> DVec3 {
        let [n0, n1, n2] = self.corner_normals(i);
        let n = n0 + a * (n1 - n0) + b * (n2 - n0);
        n.try_normalize()
            .unwrap_or_else(|| self.geometric_normal(i).normalize_or_zero())
    }

    /// The point at barycentrics (a, b): `P0 + a·E1 + b·E2`.
    pub fn point(&self, i: usize, a: f64, b: f64) -> DVec3 {
        let [p0, p1, p2] = self.corners(i);
        p0 + a * (p1 - p0) + b * (p2 - p0)
    }

    /// Axis-aligned bounds `(min, max)` of the vertices.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// Degenerate triangles and closedness.
    pub fn report(&self) -> MeshReport {
        let edges = edge_report(&self.positions, &self.triangles);
        let degenerate = (0..self.triangles.len())
            .filter(|&i| is_degenerate(self.corners(i)))
            .count();
        MeshReport {
            triangles: self.triangles.len(),
            degenerate,
            closed: edges.closed,
            boundary_edges: edges.boundary,
            flipped_edges: edges.flipped,
            inside_out: self.turned_outward,
        }
    }

    /// The mesh with every position and normal mapped (for transforms). `flip_winding` reverses
    /// every triangle, for mappings that mirror space, so the winding stays outward.
    pub fn mapped(
        &self,
        position: impl Fn(DVec3) -> DVec3,
        normal: impl Fn(DVec3) -> DVec3,
        flip_winding: bool,
    ) -> TriangleMesh {
        let positions = self.positions.iter().map(|&p| position(p)).collect();
        let normals = self
            .normals
            .iter()
            .map(|&n| normal(n).normalize_or_zero())
            .collect();
        let mut triangles = self.triangles.clone();
        if flip_winding {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        TriangleMesh {
            positions,
            normals,
            triangles,
            turned_outward: self.turned_outward,
        }
    }
}

/// The checks every mesh passes (triangles, finite coordinates, indices in range), and a
/// closed mesh wound inside-out (negative enclosed volume) rewound outward.
/// Returns the triangles and whether they were rewound.
fn checked_and_oriented(
    positions: &[DVec3],
    mut triangles: Vec<[u32; 3]>,
) -> Result<(Vec<[u32; 3]>, bool), MeshError> {
    if triangles.is_empty() {
        return Err(MeshError::Empty);
    }
    if let Some((vertex, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(MeshError::NonFinitePosition {
            vertex,
            value: p.to_array(),
        });
    }
    for (triangle, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(MeshError::IndexOutOfRange {
                triangle,
                index,
                vertices: positions.len(),
            });
        }
    }
    // The volume is only meaningful when the mesh is closed.
    let inside_out =
        signed_volume(positions, &triangles) < 0.0 && edge_report(positions, &triangles).closed;
    if inside_out {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    Ok((triangles, inside_out))
}

/// A triangle is degenerate when its area is below 1e-12 of the square of its longest edge
/// (collinear or repeated corners).
fn is_degenerate([p0, p1, p2]: [DVec3; 3]) -> bool {
    let longest = (p1 - p0)
        .length_squared()
        .max((p2 - p1).length_squared())
        .max((p0 - p2).length_squared());
    (p1 - p0).cross(p2 - p0).length_squared() <= 1e-24 * longest * longest || longest == 0.0
}

/// Each vertex's representative under welding by exact position (bit pattern): the smallest
/// index with the same position. Sort-based, so millions of vertices take a fraction of a second.
fn weld(positions: &[DVec3]) -> Vec<u32> {
    let key = |i: u32| {
        let p = positions[i as usize];
        ([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()], i)
    };
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    order.par_sort_unstable_by_key(|&i| key(i));
    let mut canon = vec![0u32; positions.len()];
    let mut representative = 0;
    for (k, &i) in order.iter().enumerate() {
        if k == 0 || key(i).0 != key(order[k - 1]).0 {
            representative = i;
        }
        canon[i as usize] = representative;
    }
    canon
}

/// How a triangle soup's edges are shared, vertices welded by exact position.
struct EdgeReport {
    /// Every edge used once in each direction.
    closed: bool,
    /// Edges used once.
    boundary: usize,
    /// Edges used twice in the same direction.
    flipped: usize,
}

/// The [`EdgeReport`] of a triangle soup.
fn edge_report(positions: &[DVec3], triangles: &[[u32; 3]]) -> EdgeReport {
    let canon = weld(positions);
    // Every directed edge as (undirected key, direction), sorted so each edge's uses are adjacent.
    let mut edges: Vec<(u64, bool)> = Vec::with_capacity(triangles.len() * 3);
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (canon[t[k] as usize], canon[t[(k + 1) % 3] as usize]);
            if a != b {
                edges.push((((a.min(b) as u64) << 32) | a.max(b) as u64, a < b));
            }
        }
    }
    edges.par_sort_unstable();
    let (mut boundary, mut flipped, mut closed) = (0, 0, !edges.is_empty());
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        let forward = group.iter().filter(|e| e.1).count();
        let reverse = group.len() - forward;
        boundary += (group.len() == 1) as usize;
        flipped += (group.len() == 2 && (forward == 2 || reverse == 2)) as usize;
        closed &= forward == 1 && reverse == 1;
    }
    EdgeReport {
        closed,
        boundary,
        flipped,
    }
}

/// Signed enclosed volume (positive when a closed mesh winds outward).
fn signed_volume(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    // Relative to the first vertex, for accuracy far from the origin.
    let o = positions.first().copied().unwrap_or(DVec3::ZERO);
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize] - o);
            a.dot(b.cross(c))
        })
        .sum::<f64>()
        / 6.0
}

/// Smooth vertex normals: each triangle's unit normal weighted by its corner angle, summed over
/// the vertices welded by exact position (so seam duplicates share one normal). Degenerate
/// triangles add nothing; a vertex touched only by degenerate triangles gets the normal of its
/// position direction from the mesh centroid, or +z, so every normal is a unit vector.
pub fn smooth_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let canon = weld(positions);
    let mut sum = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [p0, p1, p2] = t.map(|i| positions[i as usize]);
        let Some(n) = (p1 - p0).cross(p2 - p0).try_normalize() else {
            continue;
        };
        let angles = [
            corner_angle(p1 - p0, p2 - p0),
            corner_angle(p2 - p1, p0 - p1),
            corner_angle(p0 - p2, p1 - p2),
        ];
        for k in 0..3 {
            sum[canon[t[k] as usize] as usize] += n * angles[k];
        }
    }
    let centroid = positions.iter().copied().sum::<DVec3>() / positions.len().max(1) as f64;
    (0..positions.len())
        .map(|i| {
            sum[canon[i] as usize]
                .try_normalize()
                .or_else(|| (positions[i] - centroid).try_normalize())
                .unwrap_or(DVec3::Z)
        })
        .collect()
}

/// Normals for a mesh whose file gives none, smoothed only across edges where the faces meet
/// at less than `crease` (radians; π smooths everywhere, 0 gives flat faces).
///
/// Each triangle corner's normal is the angle-weighted sum of the unit normals of the faces
/// around its vertex (welded by exact position) that are within `crease` of the corner's own
/// face, summed in triangle order. A vertex whose corners get different normals is split into
/// one vertex per normal; positions are copied, so welding (and so the mesh's closedness) is
/// unchanged. When no vertex splits, positions, triangles and normals are exactly those of
/// [`smooth_normals`] (the same sums in the same order).
pub fn creased_normals(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    crease: f64,
) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<DVec3>) {
    let canon = weld(positions);
    let faces: Vec<Option<(DVec3, [f64; 3])>> = triangles
        .iter()
        .map(|t| {
            let [p0, p1, p2] = t.map(|i| positions[i as usize]);
            let n = (p1 - p0).cross(p2 - p0).try_normalize()?;
            Some((
                n,
                [
                    corner_angle(p1 - p0, p2 - p0),
                    corner_angle(p2 - p1, p0 - p1),
                    corner_angle(p0 - p2, p1 - p2),
                ],
            ))
        })
        .collect();
    // The corners around each welded vertex, in triangle order (compressed rows).
    let mut start = vec![0usize; positions.len() + 1];
    for t in triangles {
        for &i in t {
            start[canon[i as usize] as usize + 1] += 1;
        }
    }
    for v in 0..positions.len() {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut around = vec![(0u32, 0u8); start[positions.len()]];
    for (ti, t) in triangles.iter().enumerate() {
        for (k, &i) in t.iter().enumerate() {
            let v = canon[i as usize] as usize;
            around[fill[v]] = (ti as u32, k as u8);
            fill[v] += 1;
        }
    }
    let centroid = positions.iter().copied().sum::<DVec3>() / positions.len().max(1) as f64;
    let cos_crease = crease.cos();
    // At π every face counts (a dot product of opposite unit normals may round below -1).
    let everything = crease >= std::f64::consts::PI;
    let corner_normal = |ti: usize, k: usize| {
        let i = triangles[ti][k] as usize;
        let v = canon[i] as usize;
        let own = faces[ti].map(|(n, _)| n);
        let mut sum = DVec3::ZERO;
        for &(tj, kj) in &around[start[v]..start[v + 1]] {
            let Some((n, angles)) = faces[tj as usize] else {
                continue;
            };
            // A degenerate corner takes the smooth normal; others only faces within the crease.
            if everything || own.is_none_or(|own| own.dot(n) >= cos_crease) {
                sum += n * angles[kj as usize];
            }
        }
        sum.try_normalize()
            .or_else(|| (positions[i] - centroid).try_normalize())
            .unwrap_or(DVec3::Z)
    };
    let mut out_positions = positions.to_vec();
    let mut out_normals: Vec<Option<DVec3>> = vec![None; positions.len()];
    // Further normals of a split vertex: (original vertex, normal bits) -> new vertex.
    let mut split: std::collections::HashMap<(u32, [u64; 3]), u32> = Default::default();
    let mut out_triangles = triangles.to_vec();
    for (ti, t) in triangles.iter().enumerate() {
        for (k, &i) in t.iter().enumerate() {
            let n = corner_normal(ti, k);
            match out_normals[i as usize] {
                None => out_normals[i as usize] = Some(n),
                Some(first)
                    if first.to_array().map(f64::to_bits) == n.to_array().map(f64::to_bits) => {}
                Some(_) => {
                    let key = (i, n.to_array().map(f64::to_bits));
                    let new = *split.entry(key).or_insert_with(|| {
                        out_positions.push(positions[i as usize]);
                        out_normals.push(Some(n));
                        (out_positions.len() - 1) as u32
                    });
                    out_triangles[ti][k] = new;
                }
            }
        }
    }
    // Vertices no triangle uses keep the smooth rule's fallback.
    let normals = out_normals
        .into_iter()
        .zip(&out_positions)
        .map(|(n, p)| n.unwrap_or_else(|| (*p - centroid).try_normalize().unwrap_or(DVec3::Z)))
        .collect();
    (out_positions, out_triangles, normals)
}

/// The angle between two edge vectors, by atan2 (accurate near 0 and π, unlike acos).
fn corner_angle(u: DVec3, v: DVec3) -> f64 {
    u.cross(v).length().atan2(u.dot(v))
}

#[cfg(test)]
mod tests;
