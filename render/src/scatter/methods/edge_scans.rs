//! The edge scans of one query, each computed once and shared by the two triangles of the edge.
//!
//! Most of the per-triangle search's time goes to scanning its three edges for sign changes of
//! the skew scalar (`edge`). That scan depends only on the edge's two vertices (positions and
//! normals) and on the query (camera line, light point, η), not on the triangle, and the two
//! triangles of an edge are mostly candidates of the same query. So each edge is scanned once per
//! query, from its lower vertex index to its higher, and handed to either triangle in that
//! triangle's direction (the scan points `s = i/16` are symmetric, so reversing is exact): the
//! result is the same whichever triangle asks first, and rendering stays deterministic.

use std::collections::HashMap;

use foldhash::fast::FixedState;

use crate::mesh::TriangleMesh;
use crate::scatter::triangle::edge::{Edge, LineScan, scan_edge};
use crate::scatter::triangle::ends::PathEnds;

/// The scans of one query, by edge. Reused across queries ([`EdgeScans::clear`]) so the hot loop
/// does not allocate.
#[derive(Debug, Default)]
pub struct EdgeScans {
    /// Index into `scans` of each edge, keyed by its vertex pair, lower index first.
    slots: HashMap<u64, u32, FixedState>,
    scans: Vec<LineScan>,
}

impl EdgeScans {
    /// Forgets every scan: the next query has other ends.
    pub fn clear(&mut self) {
        self.slots.clear();
        self.scans.clear();
    }

    /// The scan of `edge` of the mesh's triangle `triangle` for `ends`, in the direction of
    /// [`Edge::line`] on that triangle.
    pub fn scan(
        &mut self,
        mesh: &TriangleMesh,
        triangle: u32,
        edge: Edge,
        ends: &PathEnds,
    ) -> LineScan {
        let v = mesh.triangles()[triangle as usize];
        let (from, to) = match edge {
            Edge::A0 => (v[0], v[2]),
            Edge::B0 => (v[0], v[1]),
            Edge::Ab1 => (v[1], v[2]),
        };
        let (lo, hi) = (from.min(to), from.max(to));
        let key = (u64::from(lo) << 32) | u64::from(hi);
        let slot = match self.slots.get(&key) {
            Some(&slot) => slot as usize,
            None => {
                let vertex = |i: u32| {
                    let n = mesh.normals()[i as usize];
                    (mesh.positions()[i as usize], n.try_normalize().unwrap_or(n))
                };
                let ((p0, n0), (p1, n1)) = (vertex(lo), vertex(hi));
                self.scans.push(scan_edge([p0, p1], [n0, n1], ends));
                let slot = self.scans.len() - 1;
                self.slots.insert(key, slot as u32);
                slot
            }
        };
        let mut scan = self.scans[slot];
        if from > to {
            scan.reverse();
        }
        scan
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::bumpy_sphere;
    use crate::scatter::triangle::edge::{LINE_SCAN, scan_line, skew};
    use crate::scatter::triangle::patch::TrianglePatch;
    use glam::DVec3;

    /// Every triangle gets the scan of its own edges (as from its own patch, up to rounding), and
    /// the same scan whether its neighbour asked for the edge first or not.
    #[test]
    fn shared_scans_match_each_triangles_own() {
        let mesh = bumpy_sphere(1.0, 2, 0.15, 2.0, 5);
        let ends = PathEnds {
            origin: DVec3::new(-0.3, 0.1, -0.2),
            dir: DVec3::new(0.6, 0.2, 0.3).normalize(),
            light: DVec3::new(2.0, 3.0, 2.5),
            eta: 1.5,
        };
        let mut forward = EdgeScans::default();
        let mut backward = EdgeScans::default();
        let count = mesh.triangle_count() as u32;
        let (mut compared, mut shared) = (0, 0);
        for triangle in 0..count {
            let patch = TrianglePatch::new(
                mesh.corners(triangle as usize),
                mesh.corner_normals(triangle as usize),
            )
            .unwrap();
            for edge in Edge::ALL {
                let own = scan_line(&patch, &ends, &edge.line());
                let a = forward.scan(&mesh, triangle, edge, &ends);
                let b = backward.scan(&mesh, count - 1 - triangle, edge, &ends);
                let b_again = backward.scan(&mesh, count - 1 - triangle, edge, &ends);
                assert_eq!(b, b_again);
                for (i, (x, y)) in own.iter().zip(a.iter()).enumerate() {
                    match (x, y) {
                        (Some(x), Some(y)) => {
                            // Same sign (unless the skew is rounding-level there) and the same
                            // λ side.
                            let (pa, pb) = edge.line().at(i as f64 / LINE_SCAN as f64);
                            let size = skew(patch.point(pa, pb), patch.normal(pa, pb), &ends)
                                .map_or(0.0, |k| k.value.abs());
                            assert!(
                                x.sign == y.sign || size <= 1e-9,
                                "triangle {triangle} {edge:?}: {x:?} vs {y:?}"
                            );
                            assert_eq!(x.ahead, y.ahead, "triangle {triangle} {edge:?}");
                            compared += 1;
                        }
                        (None, None) => {}
                        _ => panic!("triangle {triangle} {edge:?}: {x:?} vs {y:?}"),
                    }
                }
            }
        }
        // Same scans whichever triangle of an edge came first.
        for triangle in 0..count {
            for edge in Edge::ALL {
                let a = forward.scan(&mesh, triangle, edge, &ends);
                let b = backward.scan(&mesh, triangle, edge, &ends);
                assert_eq!(a, b, "triangle {triangle} {edge:?}");
                shared += 1;
            }
        }
        assert_eq!(
            forward.scans.len(),
            3 * count as usize / 2,
            "each edge scanned once"
        );
        assert!(
            compared > 1000 && shared == 3 * count,
            "{compared} {shared}"
        );
    }
}
