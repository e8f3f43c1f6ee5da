//! Tests of the refraction solve against Snell's law and the §1.5 reference values.

use super::*;
use crate::scatter::triangle::ends::DepthRange;
use crate::scatter::triangle::ground_truth::{curved_patch, flat_cases, flat_refraction_point};

const TIGHT: f64 = 1e-14;

fn flat_patch(size: f64) -> TrianglePatch {
    TrianglePatch::new(
        [
            DVec3::new(-size, -size, 0.0),
            DVec3::new(2.0 * size, -size, 0.0),
            DVec3::new(-size, 2.0 * size, 0.0),
        ],
        [DVec3::Z; 3],
    )
    .unwrap()
}

/// Test (1): on a flat triangle the Newton refraction point equals the safeguarded
/// Newton/bisection root of Snell's law in the plane of incidence (physics.md §5) to 1e-12,
/// from the straight-line guess and from a point near it, for the §1.5 configuration and
/// 200 seeded random ones. The plane-refraction starting guess (an independent implementation
/// of the same §5 root) also lands on it to 1e-12.
#[test]
fn flat_newton_matches_snell_bisection() {
    let patch = flat_patch(4.0);
    let cases = flat_cases(1, 200, 2.0);
    let mut worst = 0.0f64;
    for (case, &(v, l, eta)) in cases.iter().enumerate() {
        let truth = flat_refraction_point(DVec3::ZERO, DVec3::Z, v, l, eta);
        let ends = PathEnds {
            origin: v,
            dir: DVec3::X,
            light: l,
            eta,
        };
        let settings = NewtonSettings::new(TIGHT, DepthRange::new(0.0, 0.0));
        let straight = straight_line_guess(&patch, &ends, 0.0).unwrap();
        let plane = plane_refraction_guess(&patch, &ends, 0.0).unwrap();
        let start = patch.point(plane.0, plane.1);
        assert!(
            (start - truth).length() < 1e-12,
            "case {case}: plane guess {start} vs {truth}"
        );
        // Near η = 1 the half vector is short and f's basin of convergence shrinks with η − 1,
        // so the displaced start (by 0.3 times V's depth) is only used for clearly refracting
        // cases.
        let displaced = patch.barycentric(start + 0.3 * v.z.abs() * DVec3::new(0.6, -0.8, 0.0));
        let guesses = if eta > 1.2 {
            vec![straight, displaced]
        } else {
            vec![straight]
        };
        for guess in guesses {
            let (path, _) = solve_at(&patch, &ends, 0.0, guess, &settings);
            let path =
                path.unwrap_or_else(|| panic!("case {case}: no path for V={v}, L={l}, η={eta}"));
            let err = (path.p - truth).length();
            worst = worst.max(err);
            assert!(
                err < 1e-12,
                "case {case}: P={} vs {truth} (err {err:e}), V={v}, L={l}, η={eta}",
                path.p
            );
        }
    }
    println!("worst |P - P_snell| = {worst:e}");
}

/// The §1.5 flat-plane reference values: P, d_V, d_L, the cosines and T_P to 1e-12.
#[test]
fn flat_reference_values() {
    let patch = flat_patch(4.0);
    let ends = PathEnds {
        origin: DVec3::new(0.3, -0.2, -0.8),
        dir: DVec3::X,
        light: DVec3::new(1.7, 0.9, 1.3),
        eta: 1.5,
    };
    let settings = NewtonSettings::new(TIGHT, DepthRange::new(0.0, 0.0));
    let guess = straight_line_guess(&patch, &ends, 0.0).unwrap();
    let path = solve_at(&patch, &ends, 0.0, guess, &settings).0.unwrap();
    let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
    assert!((path.p - DVec3::new(0.643387768259381, 0.069804675060942, 0.0)).length() < 1e-12);
    assert!(close(path.d_v, 0.911432785275413), "d_v {}", path.d_v);
    assert!(close(path.d_l, 1.869666731215637), "d_l {}", path.d_l);
    assert!(close(path.cos_v, 0.877738888620579), "cos_v {}", path.cos_v);
    assert!(close(path.cos_l, 0.695311083144082), "cos_l {}", path.cos_l);
    assert!(
        close(path.fresnel_t, 0.948618634715956),
        "T_P {}",
        path.fresnel_t
    );
    assert!(
        (path.d_factor / 15.83847645183 - 1.0).abs() < 1e-11,
        "D {}",
        path.d_factor
    );
}

/// The §1.5 curved-triangle reference values: (a, b), d_V, d_L and T_P to 1e-12, D to 1e-11
/// relative (the table gives 12 digits).
#[test]
fn curved_reference_values() {
    let (patch, ends) = curved_patch();
    let settings = NewtonSettings::new(TIGHT, DepthRange::new(0.0, 0.0));
    let guess = straight_line_guess(&patch, &ends, 0.0).unwrap();
    let (path, evaluations) = solve_at(&patch, &ends, 0.0, guess, &settings);
    let path = path.expect("curved reference path");
    println!("curved solve: {evaluations} evaluations");
    let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
    assert!(
        close(path.a, 0.376357699627954) && close(path.b, 0.448262971074044),
        "(a,b) = ({}, {})",
        path.a,
        path.b
    );
    assert!(close(path.d_v, 0.662327251689634), "d_v {}", path.d_v);
    assert!(close(path.d_l, 1.734245779563802), "d_l {}", path.d_l);
    assert!(
        close(path.fresnel_t, 0.959021342658680),
        "T_P {}",
        path.fresnel_t
    );
    assert!(
        (path.d_factor / 10.0582729142 - 1.0).abs() < 1e-10,
        "D {}",
        path.d_factor
    );
}

/// Spurious zeros are rejected: with V and L on the same side the solver may find f = 0
/// but no path is returned; a light behind the plane gives no path.
#[test]
fn no_path_when_light_is_behind() {
    let patch = flat_patch(4.0);
    let ends = PathEnds {
        origin: DVec3::new(0.3, -0.2, -0.8),
        dir: DVec3::X,
        light: DVec3::new(1.7, 0.9, -1.3),
        eta: 1.5,
    };
    let settings = NewtonSettings::new(1e-12, DepthRange::new(0.0, 0.0));
    for guess in [(0.1, 0.1), (0.5, 0.2), (0.3, 0.6)] {
        assert!(solve_at(&patch, &ends, 0.0, guess, &settings).0.is_none());
    }
}
