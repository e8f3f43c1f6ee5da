//! The spindle and cone tests on single spheres and cones.

use glam::DVec3;

use super::{Rng, segment_through, valid_path};
use crate::scatter::geometry::{BoundingSphere, NormalCone};
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::cone::{ConeTest, Piece, chord_bound};
use crate::scatter::prune::spindle::max_cosine_to_arc;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};

/// The proof that pruning is conservative: over many valid refraction paths (built forward, so
/// valid by construction, including grazing exits and every η of issue 3), neither the spindle
/// test on the triangle's sphere, nor on a box around it, nor the cone test (on the segment's
/// range, or on the path's `t` alone) ever discards the triangle, and the trimmed t-range always
/// contains the path's `t`.
#[test]
fn pruning_never_discards_a_valid_path() {
    let mut rng = Rng(7);
    let (mut tried, mut cone_trimmed) = (0, 0);
    for _ in 0..40_000 {
        let Some(path) = valid_path(&mut rng) else {
            continue;
        };
        let (query, t_v) = segment_through(&mut rng, &path);
        tried += 1;
        let sphere = BoundingSphere::of_triangle(path.p);
        let lo = path.p[0].min(path.p[1]).min(path.p[2]);
        let hi = path.p[0].max(path.p[1]).max(path.p[2]);
        let slack = DVec3::splat(rng.next() * sphere.radius);
        let boxed = BoundingSphere::of_box(lo - slack, hi + slack);
        assert!(
            query.spindle_may_contain(sphere),
            "spindle culled a valid path (triangle sphere): {query:?} {sphere:?}"
        );
        assert!(
            query.spindle_may_contain(boxed),
            "spindle culled a valid path (node box): {query:?} {boxed:?}"
        );
        if let Some(cone) = NormalCone::of_normals(path.n) {
            let trimmed = query.cone_trim(sphere, cone);
            let Some(DepthRange { lo: t0, hi: t1 }) = trimmed else {
                panic!("cone test culled a valid path: {query:?} t={t_v} {sphere:?} {cone:?}");
            };
            assert!(
                t0 <= t_v && t_v <= t1,
                "trimmed range [{t0}, {t1}] misses t = {t_v}: {query:?}"
            );
            assert!(
                query.cone_may_contain(sphere, cone),
                "cone test (no trim) culled a valid path: {query:?} t={t_v}"
            );
            // At the single depth of the path (the interval method's test of a range end).
            let at_t = query.with_range(DepthRange { lo: t_v, hi: t_v });
            assert!(
                at_t.cone_may_contain(sphere, cone),
                "cone test at the path's own depth culled it: {query:?} t={t_v}"
            );
            if t1 - t0 < query.range.hi - query.range.lo {
                cone_trimmed += 1;
            }
        }
    }
    println!("{tried} valid paths kept by both tests; the cone test trimmed {cone_trimmed} ranges");
    assert!(tried > 10_000, "too few valid paths generated: {tried}");
}

/// The shortcuts of the bisection are honest: where a piece is `Certain`, every piece of a
/// deeper bisection that holds its middle is kept; where it is `Everywhere`, every piece is.
/// Segments centred on valid paths' camera points, with spheres centred on their refraction
/// points, give many `Certain` pieces.
#[test]
fn certain_pieces_stay_kept_when_bisected() {
    let mut rng = Rng(23);
    let (mut certain, mut everywhere) = (0, 0);
    for _ in 0..40_000 {
        let Some(path) = valid_path(&mut rng) else {
            continue;
        };
        let Some(cone) = NormalCone::of_normals(path.n) else {
            continue;
        };
        // Pieces and spheres small beside the distance to V, so that their bounds are tight.
        let size = path.v.distance(path.point);
        let dir = rng.unit();
        let half = size * 10f64.powf(rng.range(-3.0, -0.5));
        let query = SegmentQuery {
            ends: PathEnds {
                origin: path.v - half * dir,
                dir,
                light: path.l,
                eta: path.eta,
            },
            range: DepthRange {
                lo: 0.0,
                hi: 2.0 * half,
            },
        };
        let sphere = BoundingSphere {
            center: path.point,
            radius: size * 10f64.powf(rng.range(-4.0, 0.2)),
        };
        let test = ConeTest::new(&query, sphere, cone);
        let (lo, hi) = (query.range.lo, query.range.hi);
        match test.piece(lo, hi) {
            Piece::Certain => {
                certain += 1;
                // The pieces either side of the middle, down to 2^-12 of the range.
                for depth in 1..=12 {
                    let width = (hi - lo) / f64::from(1u32 << depth);
                    let mid = 0.5 * (lo + hi);
                    for piece in [(mid - width, mid), (mid, mid + width)] {
                        assert_ne!(
                            test.piece(piece.0, piece.1),
                            Piece::Culled,
                            "{query:?} {sphere:?} {piece:?}"
                        );
                    }
                }
            }
            Piece::Everywhere => {
                everywhere += 1;
                let width = (hi - lo) / 16.0;
                for i in 0..16 {
                    let start = lo + f64::from(i) * width;
                    assert_ne!(test.piece(start, start + width), Piece::Culled, "{query:?}");
                }
            }
            _ => {}
        }
    }
    println!("{certain} certain and {everywhere} everywhere-kept ranges bisected");
    assert!(certain > 5000 && everywhere > 300, "{certain} {everywhere}");
}

/// `chord_bound` is an upper bound of the exact chord `2 sin(asin(s)/2)` (computed with
/// trigonometry here), and within 0.4 % of it for s ≤ 0.5 (1.2 % up to 0.9).
#[test]
fn chord_bound_is_an_upper_bound() {
    for i in 0..=100_000 {
        let s = f64::from(i) / 100_000.0;
        let exact = 2.0 * (s.asin() / 2.0).sin();
        let bound = chord_bound(s);
        assert!(bound >= exact * (1.0 - 1e-14), "s = {s}: {bound} < {exact}");
        if s <= 0.5 {
            assert!(
                bound <= exact * 1.02 + 1e-300,
                "s = {s}: {bound} vs {exact}"
            );
        }
    }
}

/// The tests must also cull: a light straight behind a far node along the segment's own line
/// is outside the spindle, and a triangle whose normals face away is outside the cone.
#[test]
fn pruning_culls_what_cannot_refract() {
    let query = SegmentQuery {
        ends: PathEnds {
            origin: DVec3::new(0.0, 0.0, 0.0),
            dir: DVec3::X,
            light: DVec3::new(-10.0, 0.0, 0.0),
            eta: 1.5,
        },
        range: DepthRange { lo: 0.0, hi: 1.0 },
    };
    // Node beyond the segment's far end: every ω_V points back toward the light's side
    // (deviation near π), far outside the 48° spindle of η = 1.5.
    let far = BoundingSphere {
        center: DVec3::new(5.0, 0.0, 0.0),
        radius: 0.5,
    };
    assert!(!query.spindle_may_contain(far));
    // Node between the light and the segment: a straight path, kept.
    let between = BoundingSphere {
        center: DVec3::new(-3.0, 0.2, 0.0),
        radius: 0.5,
    };
    assert!(query.spindle_may_contain(between));
    // A triangle between them whose normals face +x (away from the light) cannot refract
    // light coming from −x: Ĥ ≈ −x must equal −N̂s.
    let tri = [
        DVec3::new(-3.0, -0.1, -0.1),
        DVec3::new(-3.0, 0.2, -0.1),
        DVec3::new(-3.0, 0.0, 0.2),
    ];
    let sphere = BoundingSphere::of_triangle(tri);
    let away = NormalCone::of_normals([DVec3::X; 3]).unwrap();
    assert_eq!(query.cone_trim(sphere, away), None);
    let toward = NormalCone::of_normals([-DVec3::X; 3]).unwrap();
    assert!(query.cone_trim(sphere, toward).is_some());
}

/// The closed form bounds the cosine to the arc from above (the spindle test stays
/// conservative) and is close to the largest of 4001 sampled directions.
#[test]
fn max_cosine_to_arc_matches_dense_sampling() {
    let mut rng = Rng(3);
    for _ in 0..2000 {
        let (a, b, w) = (rng.unit() * 2.0, rng.unit() * 0.5, rng.unit());
        let exact = max_cosine_to_arc(w, a, b);
        let sampled = (0..=4000)
            .map(|i| {
                let p = a + (b - a) * (i as f64 / 4000.0);
                w.dot(p) / p.length()
            })
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            exact >= sampled - 1e-12,
            "{exact} < {sampled} for {a} {b} {w}"
        );
        assert!(
            exact <= sampled + 1e-3,
            "{exact} >> {sampled} for {a} {b} {w}"
        );
    }
}
