//! The query every pruning test answers: one camera segment's range of depths and one light point.

use crate::scatter::triangle::ends::{DepthRange, PathEnds};

/// One camera segment seen from one light point: the part of a pruning query shared by every node
/// and triangle of the descent. The tests look at the camera points `ends.camera_point(t)`,
/// `t ∈ range`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentQuery {
    /// The camera segment and the light point.
    pub ends: PathEnds,
    /// The depths searched.
    pub range: DepthRange,
}

impl SegmentQuery {
    /// The same query over `range`.
    pub fn with_range(&self, range: DepthRange) -> Self {
        SegmentQuery {
            ends: self.ends,
            range,
        }
    }
}
