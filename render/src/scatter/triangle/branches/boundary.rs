//! The points where traced arcs start: points of the curve on the boundary of the region
//! `triangle × t-range`, and points on lines across the triangle for arcs that touch no boundary.

use crate::scatter::triangle::curve::CurvePoint;
use crate::scatter::triangle::edge::{BarycentricLine, Edge};
use crate::scatter::triangle::small_list::SmallList;

/// Lines across the triangle (a = 1/3, 2/3; b = 1/3, 2/3; a + b = 1/3, 2/3) scanned for points of
/// arcs that touch no edge and no range end: arcs that begin and end where the light grazes the
/// shading normal (`c_L = 0`), which strongly curved normals produce.
pub(super) const INTERIOR_LINES: [BarycentricLine; 6] = [
    BarycentricLine {
        origin: [1.0 / 3.0, 0.0],
        dir: [0.0, 2.0 / 3.0],
    },
    BarycentricLine {
        origin: [2.0 / 3.0, 0.0],
        dir: [0.0, 1.0 / 3.0],
    },
    BarycentricLine {
        origin: [0.0, 1.0 / 3.0],
        dir: [2.0 / 3.0, 0.0],
    },
    BarycentricLine {
        origin: [0.0, 2.0 / 3.0],
        dir: [1.0 / 3.0, 0.0],
    },
    BarycentricLine {
        origin: [1.0 / 3.0, 0.0],
        dir: [-1.0 / 3.0, 1.0 / 3.0],
    },
    BarycentricLine {
        origin: [2.0 / 3.0, 0.0],
        dir: [-2.0 / 3.0, 2.0 / 3.0],
    },
];

/// Where a traced arc enters or leaves the region `triangle × t-range`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Side {
    Edge(Edge),
    RangeLow,
    RangeHigh,
}

/// A point of the curve on the boundary of the region, with its oriented tangent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Boundary {
    pub side: Side,
    pub x: CurvePoint,
    pub g: CurvePoint,
    /// Whether an arc through this point has been traced.
    pub consumed: bool,
}

/// The boundary points of one triangle.
pub(super) type BoundaryPoints = SmallList<Boundary, 16>;

/// A point where the curve crosses one of the [`INTERIOR_LINES`]: a seed for arcs with no
/// boundary point, consumed when a traced arc passes through it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct InteriorSeed {
    /// The index of the line in [`INTERIOR_LINES`].
    pub line: usize,
    pub x: CurvePoint,
    pub g: CurvePoint,
    pub consumed: bool,
}

/// Interior seeds of one triangle.
pub(super) type InteriorSeeds = SmallList<InteriorSeed, 24>;
