//! The beams of one object for one fixed light point, computed once per scene. A beam
//! ([`beam`](super::beam)) depends on the light point, η, and a node's or triangle's sphere and
//! normal cone, never on the camera segment: for a point light, every descent of the render would
//! otherwise recompute the same beams (docs/benchmarks.md, tenth round). A table holds one
//! [`BeamBound`] per BVH node and per triangle (by leaf slot), and serves only queries whose light
//! point and η are exactly the ones it was built for, so a table's beam is bit for bit the one
//! the descent would compute.

use glam::DVec3;
use rayon::prelude::*;

use crate::scatter::geometry::{BoundingSphere, NormalCone};
use crate::scatter::prune::beam::BeamBound;
use crate::scatter::prune::bounds::PruneBounds;
use crate::scatter::triangle::ends::PathEnds;

/// The beams of every node and triangle of one object for one light point and η.
#[derive(Debug, Clone)]
pub struct BeamTable {
    light: DVec3,
    eta: f64,
    nodes: Vec<BeamBound>,
    /// By leaf slot.
    triangles: Vec<BeamBound>,
}

impl BeamTable {
    /// The beams of the object whose pruning bounds are `bounds`, for `light` and `eta`. Nodes
    /// and triangles without a normal cone get [`BeamBound::Unbounded`] (the descent does not
    /// consult them).
    pub fn build(bounds: &PruneBounds, light: DVec3, eta: f64) -> Self {
        let beam = |sphere, cone| match cone {
            Some(cone) => BeamBound::of(light, eta, sphere, cone),
            None => BeamBound::Unbounded,
        };
        BeamTable {
            light,
            eta,
            nodes: bounds
                .nodes()
                .par_iter()
                .map(|n| beam(n.sphere, n.cone))
                .collect(),
            triangles: bounds
                .triangles()
                .par_iter()
                .map(|t| beam(t.sphere, t.cone))
                .collect(),
        }
    }

    /// Whether the table holds the beams of queries with these ends (the same light point and η,
    /// exactly).
    pub fn serves(&self, ends: &PathEnds) -> bool {
        ends.light == self.light && ends.eta == self.eta
    }

    /// How many beams the table holds: one per BVH node and one per triangle.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.nodes.len() + self.triangles.len()
    }

    /// The beam of BVH node `index`.
    pub(super) fn node(&self, index: u32) -> BeamBound {
        self.nodes[index as usize]
    }

    /// The beam of the triangle in leaf slot `slot`.
    pub(super) fn triangle_at_slot(&self, slot: u32) -> BeamBound {
        self.triangles[slot as usize]
    }
}

/// Where a descent takes its beams from: a table built for its light point, or computed afresh.
#[derive(Debug, Clone, Copy)]
pub struct Beams<'a>(Option<&'a BeamTable>);

impl<'a> Beams<'a> {
    /// The table's beams if it serves `ends`, else beams computed per node.
    pub fn for_ends(table: Option<&'a BeamTable>, ends: &PathEnds) -> Self {
        Beams(table.filter(|t| t.serves(ends)))
    }

    /// Beams computed per node and triangle.
    pub fn computed() -> Self {
        Beams(None)
    }

    /// The beam of node `index`, whose sphere and cone are given.
    pub(super) fn node(
        &self,
        ends: &PathEnds,
        index: u32,
        sphere: BoundingSphere,
        cone: NormalCone,
    ) -> BeamBound {
        self.tabled_or_computed(|table| table.node(index), ends, sphere, cone)
    }

    /// The beam of the triangle in leaf slot `slot`, whose sphere and cone are given.
    pub(super) fn triangle_at_slot(
        &self,
        ends: &PathEnds,
        slot: u32,
        sphere: BoundingSphere,
        cone: NormalCone,
    ) -> BeamBound {
        self.tabled_or_computed(|table| table.triangle_at_slot(slot), ends, sphere, cone)
    }

    /// `tabled` from the table if there is one, else the beam of `sphere` and `cone` for `ends`.
    fn tabled_or_computed(
        &self,
        tabled: impl FnOnce(&BeamTable) -> BeamBound,
        ends: &PathEnds,
        sphere: BoundingSphere,
        cone: NormalCone,
    ) -> BeamBound {
        match self.0 {
            Some(table) => tabled(table),
            None => BeamBound::of(ends.light, ends.eta, sphere, cone),
        }
    }
}
