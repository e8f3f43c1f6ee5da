//! Tests of the edge scans and of the crossing classification against brute force.

use super::*;
use crate::scatter::triangle::ground_truth::SplitMix;
use glam::DVec3;

/// The batched scan is `skew_sign` point by point, to the bit: on random points and normals
/// around random camera lines and lights, including normals facing away from the light
/// (None), η below 1 (total reflection, None) and lines parallel to the refracted ray.
#[test]
fn batched_scan_is_skew_sign_exactly() {
    let mut rng = SplitMix(5);
    let (mut some, mut none) = (0, 0);
    for case in 0..400 {
        let mut v = |r: f64| DVec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r));
        let p = [v(1.0), v(1.0)];
        let n = [v(1.0), v(1.0)];
        let light = v(3.0);
        let origin = v(2.0);
        let dir = if case % 10 == 0 {
            // Along the light's direction: nearly parallel to some refracted rays.
            (p[0] - light).normalize()
        } else {
            v(1.0).normalize()
        };
        let eta = if case % 7 == 0 { 0.7 } else { 1.5 };
        let ends = PathEnds {
            origin,
            dir,
            light,
            eta,
        };
        let scan = scan_edge(p, n, &ends);
        for (i, got) in scan.iter().enumerate() {
            let s = i as f64 / LINE_SCAN as f64;
            let want = skew_sign(p[0] + s * (p[1] - p[0]), n[0] + s * (n[1] - n[0]), &ends);
            assert_eq!(*got, want, "case {case}, point {i}");
            if want.is_some() {
                some += 1;
            } else {
                none += 1;
            }
        }
    }
    assert!(some > 1000 && none > 1000, "{some} {none}");
}

/// Test (8), second half: at every edge crossing the lower/upper classification from the
/// tangent agrees with brute force — re-solving at t ± dt from the crossing and checking
/// which side of the edge the solution moved to — on 40 seeded curved configurations.
#[test]
fn classification_agrees_with_brute_force() {
    let mut rng = SplitMix(11);
    let mut checked = 0;
    let mut configurations = 0;
    while configurations < 40 {
        let n = [0, 1, 2]
            .map(|_| DVec3::new(rng.range(-0.4, 0.4), rng.range(-0.4, 0.4), 1.0).normalize());
        let patch = TrianglePatch::new(
            [
                DVec3::new(-0.6, -0.5, 0.0),
                DVec3::new(0.7, -0.4, 0.05),
                DVec3::new(-0.2, 0.6, -0.03),
            ],
            n,
        )
        .unwrap();
        let origin = DVec3::new(
            rng.range(-1.5, 1.5),
            rng.range(-1.5, 1.5),
            rng.range(-1.5, -0.3),
        );
        let target = DVec3::new(
            rng.range(-1.5, 1.5),
            rng.range(-1.5, 1.5),
            rng.range(-1.5, -0.3),
        );
        let Some(dir) = (target - origin).try_normalize() else {
            continue;
        };
        let ends = PathEnds {
            origin,
            dir,
            light: DVec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(0.5, 3.0),
            ),
            eta: rng.range(1.1, 2.0),
        };
        let length = (target - origin).length();
        configurations += 1;
        let mut out: SmallList<Crossing, 8> = SmallList::default();
        let mut stats = RenderStats::default();
        let search = CrossingSearch {
            patch: &patch,
            ends: &ends,
            range: DepthRange::new(0.0, length),
            tolerance: 1e-13,
        };
        for edge in Edge::ALL {
            search.edge_crossings(
                edge,
                &scan_line(&patch, &ends, &edge.line()),
                &mut out,
                &mut stats,
            );
        }
        for c in out.iter() {
            let dt = 1e-5;
            let settings = NewtonSettings::new(1e-13, DepthRange::new(0.0, length));
            let inside_after = |t: f64| {
                let (zero, _) =
                    newton(&patch, &ends, &Slice::fixed_t(t), (c.x.a, c.x.b), &settings);
                zero.map(|z| c.edge.inward(z.x.minus(c.x)) > 0.0)
            };
            let (Some(up), Some(down)) = (inside_after(c.x.t + dt), inside_after(c.x.t - dt))
            else {
                continue;
            };
            let brute = match (down, up) {
                (false, true) => Bound::Lower,
                (true, false) => Bound::Upper,
                _ => continue, // tangent to the edge: no decision by brute force either
            };
            assert_eq!(
                brute, c.bound,
                "crossing {c:?}, patch {patch:?}, ends {ends:?}"
            );
            checked += 1;
        }
    }
    println!("classified {checked} crossings");
    assert!(checked >= 20, "only {checked} crossings checked");
}
