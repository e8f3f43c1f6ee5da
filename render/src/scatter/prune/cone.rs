//! The cone test ([H15] §3.2.4, "shading-normal based test", App. B.2) per triangle or BVH node:
//! at a solution `Ĥ = −N̂s`, where `Ĥ` is the normalised half vector `η ω_V + ω_L` and `N̂s` the
//! shading normal, which lies in the cone of the vertex normals. The paper measures the distance
//! from the normal cone's axis to the curve (a hyperbola) swept by the half-vector axis in the
//! plane `M·û_N = 1`, and subdivides the curve where bounding triangles are not conclusive
//! (App. B.2). Here the same distance is measured as an *angle* on the unit sphere (`tan` of it is
//! the paper's planar distance, on the relevant branch; the other branch, `û_N·û_H ≥ 0`, is at
//! angles ≥ π/2 and is discarded by the same comparison), and the range is subdivided in `t` with
//! a bound that is provably conservative on each piece (the cone around the piece's middle
//! direction widened by the angle the piece subtends). The pieces that survive give the trimmed
//! `t`-range.

use glam::DVec3;

use crate::scatter::geometry::{BoundingSphere, NormalCone};
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::beam::BeamBound;
use crate::scatter::prune::beam_table::Beams;
use crate::scatter::triangle::ends::DepthRange;

/// Subdivision depth of the cone test in `t` (at most `2^depth` pieces are examined per end).
const CONE_DEPTH: u32 = 6;

/// The cone test stops bisecting a kept piece once the angle it sweeps (seen from the sphere's
/// centre) is below this fraction of the sphere's own angular size: its halves would be bounded
/// almost as loosely. Keeping a piece is always safe; it costs a few more triangles tested and
/// saves many piece tests (docs/benchmarks.md).
const FINE_SWEEP: f64 = 0.2;

impl SegmentQuery {
    /// The cone test ([H15] §3.2.4, "shading-normal based test", App. B.2) for one triangle, given
    /// its bounding sphere and normal cone: `None` if no `t` of the range can have a solution on
    /// the triangle, else the trimmed range that holds every solution. In closed form by the
    /// [beam](super::beam) where that bounds the solutions, else by bisection.
    pub fn cone_trim(&self, sphere: BoundingSphere, normals: NormalCone) -> Option<DepthRange> {
        self.cone_trim_given(self.beam(sphere, normals), sphere, normals)
    }

    /// [`cone_trim`](Self::cone_trim) with the sphere and cone's beam for the query's light and
    /// η already known.
    pub(super) fn cone_trim_given(
        &self,
        beam: BeamBound,
        sphere: BoundingSphere,
        normals: NormalCone,
    ) -> Option<DepthRange> {
        match beam {
            BeamBound::Empty => None,
            BeamBound::Beam(beam) => beam.trim(self),
            BeamBound::Unbounded => self.bisected_trim(sphere, normals),
        }
    }

    /// [`cone_trim`](Self::cone_trim) by bisection of the range alone.
    fn bisected_trim(&self, sphere: BoundingSphere, normals: NormalCone) -> Option<DepthRange> {
        let test = ConeTest::new(self, sphere, normals);
        // The whole range's verdict starts both searches (tested once).
        let whole = test.piece(self.range.lo, self.range.hi);
        let first = test.first_kept_given(self.range.lo, self.range.hi, CONE_DEPTH, true, whole)?;
        let last = test
            .first_kept_given(self.range.lo, self.range.hi, CONE_DEPTH, false, whole)
            .unwrap_or(first);
        Some(DepthRange {
            lo: first.0,
            hi: last.1,
        })
    }

    /// The cone test without the trimming: `false` only if no `t` of the range can have a
    /// solution on the triangle (by bisection, half the work of [`cone_trim`](Self::cone_trim)
    /// when kept).
    pub fn cone_may_contain(&self, sphere: BoundingSphere, normals: NormalCone) -> bool {
        self.cone_may_contain_given(self.beam(sphere, normals), sphere, normals)
    }

    /// [`cone_may_contain`](Self::cone_may_contain) for the triangle in leaf slot `slot`, whose
    /// sphere and normal cone are given, with its beam taken from `beams`.
    pub fn triangle_may_contain(
        &self,
        beams: Beams<'_>,
        slot: u32,
        sphere: BoundingSphere,
        normals: NormalCone,
    ) -> bool {
        let beam = beams.triangle_at_slot(&self.ends, slot, sphere, normals);
        self.cone_may_contain_given(beam, sphere, normals)
    }

    /// [`cone_may_contain`](Self::cone_may_contain) with the sphere and cone's beam for the
    /// query's light and η already known.
    fn cone_may_contain_given(
        &self,
        beam: BeamBound,
        sphere: BoundingSphere,
        normals: NormalCone,
    ) -> bool {
        match beam {
            BeamBound::Empty => false,
            BeamBound::Beam(beam) => beam.trim(self).is_some(),
            BeamBound::Unbounded => self.bisected_may_contain(sphere, normals),
        }
    }

    /// [`cone_may_contain`](Self::cone_may_contain) by bisection of the range alone.
    pub(super) fn bisected_may_contain(&self, sphere: BoundingSphere, normals: NormalCone) -> bool {
        ConeTest::new(self, sphere, normals).any_kept(self.range.lo, self.range.hi, CONE_DEPTH)
    }
}

/// The cone test of one query against one sphere and normal cone, with what does not depend on
/// the piece of the segment (the light's cone) computed once.
pub(super) struct ConeTest<'a> {
    query: &'a SegmentQuery,
    sphere: BoundingSphere,
    normals: NormalCone,
    /// `û_L`, the direction from the sphere's centre to the light, and the chord of the cone of
    /// `ω_L`; None when the light is inside the sphere (nothing is bounded).
    light: Option<(DVec3, f64)>,
    /// `V(0) − C`, and the `t` of the segment's line closest to the sphere's centre.
    origin: DVec3,
    t_closest: f64,
}

impl<'a> ConeTest<'a> {
    pub(super) fn new(
        query: &'a SegmentQuery,
        sphere: BoundingSphere,
        normals: NormalCone,
    ) -> Self {
        let to_light = query.ends.light - sphere.center;
        let d_light = to_light.length();
        let light = (d_light > sphere.radius)
            .then(|| (to_light / d_light, chord_of_asin(sphere.radius / d_light)));
        let origin = query.ends.origin - sphere.center;
        ConeTest {
            query,
            sphere,
            normals,
            light,
            origin,
            t_closest: -origin.dot(query.ends.dir) / query.ends.dir.length_squared(),
        }
    }

    /// The first piece (from the low end if `from_low`, else from the high end) of a bisection of
    /// `[lo, hi]` down to `depth` levels that the piece test keeps. (A piece known to be kept
    /// need not be tested: `Certain` and `Everywhere` say which pieces are.)
    fn first_kept(&self, lo: f64, hi: f64, depth: u32, from_low: bool) -> Option<(f64, f64)> {
        self.first_kept_given(lo, hi, depth, from_low, self.piece(lo, hi))
    }

    /// [`first_kept`](Self::first_kept) given the piece test's `verdict` on `[lo, hi]`.
    fn first_kept_given(
        &self,
        lo: f64,
        hi: f64,
        depth: u32,
        from_low: bool,
        verdict: Piece,
    ) -> Option<(f64, f64)> {
        if verdict == Piece::Culled {
            return None;
        }
        if depth == 0 || hi <= lo || verdict == Piece::Fine {
            return Some((lo, hi));
        }
        if verdict == Piece::Everywhere {
            return Some(end_piece(lo, hi, depth, from_low));
        }
        let mid = 0.5 * (lo + hi);
        let (first, second) = if from_low {
            ((lo, mid), (mid, hi))
        } else {
            ((mid, hi), (lo, mid))
        };
        self.first_kept(first.0, first.1, depth - 1, from_low)
            .or_else(|| match verdict {
                // The end piece of the second half at `mid` holds the middle, so is kept.
                Piece::Certain => Some(end_piece(second.0, second.1, depth - 1, from_low)),
                _ => self.first_kept(second.0, second.1, depth - 1, from_low),
            })
    }

    /// Whether any piece of a bisection of `[lo, hi]` down to `depth` levels is kept: the same
    /// answer as `first_kept(..).is_some()`, but it stops at the first piece whose middle is
    /// [`Piece::Certain`], since every piece containing that `t`, down to any depth, is kept.
    fn any_kept(&self, lo: f64, hi: f64, depth: u32) -> bool {
        match self.piece(lo, hi) {
            Piece::Culled => false,
            Piece::Certain | Piece::Everywhere | Piece::Fine => true,
            Piece::Kept if depth == 0 || hi <= lo => true,
            Piece::Kept => {
                let mid = 0.5 * (lo + hi);
                self.any_kept(lo, mid, depth - 1) || self.any_kept(mid, hi, depth - 1)
            }
        }
    }

    /// The cone test on the piece `[lo, hi]` of the segment: [`Piece::Culled`] only if no `V(t)`
    /// of the piece can see a solution on the triangle.
    pub(super) fn piece(&self, lo: f64, hi: f64) -> Piece {
        let Some((light_axis, chord_l)) = self.light else {
            return Piece::Kept;
        };
        let r = self.sphere.radius;
        // Points of the segment relative to the sphere's centre.
        let at = |t: f64| self.origin + t * self.query.ends.dir;
        // A piece inside the (convex) sphere: nothing is bounded on it or on any part of it.
        if at(lo).length_squared() <= r * r && at(hi).length_squared() <= r * r {
            return Piece::Everywhere;
        }
        let d2_piece = at(self.t_closest.max(lo).min(hi)).length_squared();
        // (NaN keeps the piece: nothing is bounded.)
        if d2_piece.is_nan() || d2_piece <= r * r {
            return Piece::Kept;
        }
        // Bound ω_L by the cone around û_L of half-angle asin(r/d_L), and ω_V by the cone around
        // the direction to the piece's middle, of half-angle asin(r/d) plus the angle half the
        // piece subtends from the sphere (at most its length over the distance). The tips of unit
        // vectors in a cone of half-angle θ lie within the chord 2 sin(θ/2) of the axis's tip, and
        // chords add along a sum of angles (the chord is the sphere's straight-line metric), so
        // the tip of H = η ω_V + ω_L lies within η r_V + r_L of η û_V + û_L. No trigonometry
        // and few roots or divisions: this test runs for most nodes and triangles of every query.
        let eta = self.query.ends.eta;
        let inv_d = d2_piece.sqrt().recip();
        let middle = at(0.5 * (lo + hi));
        let sweep = 0.5 * (hi - lo) * inv_d;
        let chord_sphere = chord_bound(r * inv_d);
        let chord_v = chord_sphere + sweep.min(2.0);
        let h_axis = eta * middle.normalize() + light_axis;
        let h2 = h_axis.length_squared();
        let spread = eta * chord_v + chord_l;
        if spread.is_nan() || h2.is_nan() || spread * spread >= h2 {
            return Piece::Kept;
        }
        // Halving a piece shrinks only its sweep: once that is small beside the sphere's own
        // angular size, the halves' bounds are nearly this one's, and bisecting on rarely culls.
        let fine = sweep < FINE_SWEEP * chord_sphere;
        // The half vector of the sphere's centre, the light and V at the piece's middle, itself
        // in the normal cone: every piece holding that V, however small, holds this H in its
        // bound, so is kept (the margin covers the rounding of the comparison below). Squared:
        // cos θ_N ≥ 0.
        let along_axis = -h_axis.dot(self.normals.axis);
        if along_axis > 0.0 && along_axis * along_axis >= self.normals.cos2 * h2 {
            return Piece::Certain;
        }
        // A solution needs Ĥ = −N̂s: the angle between −û_H and the normal cone's axis at most
        // θ_N + θ_H, with sin θ_H = spread/|H|. Both are below π/2, so compare cosines, times |H|:
        // |H| cos(θ_N + θ_H) = cos θ_N √(|H|² − spread²) − sin θ_N · spread, i.e. kept iff
        // `along + sin θ_N · spread ≥ cos θ_N √(|H|² − spread²)`, compared squared (no root).
        let (cos_n, sin_n) = (self.normals.cos_wide, self.normals.sin_wide);
        let lhs = along_axis + sin_n * spread;
        if lhs >= 0.0 && lhs * lhs >= cos_n * cos_n * (h2 - spread * spread) {
            if fine { Piece::Fine } else { Piece::Kept }
        } else {
            Piece::Culled
        }
    }
}

/// The cone test's verdict on a piece of the segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Piece {
    /// No `V(t)` of the piece can see a solution.
    Culled,
    /// The bound does not exclude a solution.
    Kept,
    /// Kept, and so is every sub-piece holding the piece's middle, at any depth.
    Certain,
    /// Kept, and so is every sub-piece.
    Everywhere,
    /// Kept, and not worth bisecting further (see [`FINE_SWEEP`]).
    Fine,
}

/// The piece at the low (`at_low`) or high end of `[lo, hi]` after `depth` bisections.
fn end_piece(lo: f64, hi: f64, depth: u32, at_low: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (lo, hi);
    for _ in 0..depth {
        let mid = 0.5 * (lo + hi);
        if at_low {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (lo, hi)
}

/// `2 sin(asin(s)/2)`, the chord of the cone of half-angle `asin(s)`, `s ∈ [0, 1]`, without
/// trigonometry: `√(2(1 − √(1 − s²)))`, written without cancellation for small `s`.
fn chord_of_asin(s: f64) -> f64 {
    let s2 = s * s;
    (2.0 * s2 / (1.0 + (1.0 - s2).max(0.0).sqrt())).sqrt()
}

/// An upper bound of [`chord_of_asin`] without roots or divisions where it matters:
/// `s (1 + s²/8 + s⁴/8)` for `s ≤ 0.9` (the chord is `s + s³/8 + 3s⁵/128 + …`; at most 1.2 % over,
/// checked densely in `tests`), the exact value beyond.
pub(super) fn chord_bound(s: f64) -> f64 {
    if s <= 0.9 {
        let s2 = s * s;
        s * (1.0 + 0.125 * s2 * (1.0 + s2))
    } else {
        chord_of_asin(s)
    }
}
