//! The beam against brute force: refracted rays built forward from points of a sphere with
//! normals in a cone (node-sized spheres, cones up to 80°, grazing light) always lie in the beam
//! the test trims to; its half-angle is the largest deviation, not a loose bound of it; and its
//! trimmed range is the set of depths inside the cone, found by dense sampling.

use glam::DVec3;

use super::{Rng, basis};
use crate::scatter::geometry::{BoundingSphere, NormalCone, angle_between};
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::beam::BeamBound;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};

/// A unit vector within `angle` of `axis`, at a uniformly drawn angle and azimuth.
fn in_cone(rng: &mut Rng, axis: DVec3, angle: f64) -> DVec3 {
    let (s, t) = basis(axis);
    let (theta, phi) = (rng.range(0.0, angle), rng.range(0.0, std::f64::consts::TAU));
    theta.cos() * axis + theta.sin() * (phi.cos() * s + phi.sin() * t)
}

/// The direction from the refraction point into the medium for shading normal `n` (outward)
/// and direction to the light `l`, by Snell's law in angles (an independent construction from
/// the beam's `η ω_V + ω_L = −μ N`); None if the light is behind the normal.
fn refracted(n: DVec3, l: DVec3, eta: f64) -> Option<DVec3> {
    let cos_l = n.dot(l);
    if cos_l <= 1e-9 {
        return None;
    }
    let tangent = l - cos_l * n;
    let sin_v = (1.0 - cos_l * cos_l).max(0.0).sqrt() / eta;
    let cos_v = (1.0 - sin_v * sin_v).sqrt();
    // Into the medium (against n), bent toward the normal, on the far side from the light.
    let along = tangent.try_normalize().unwrap_or(DVec3::ZERO);
    Some(-cos_v * n - sin_v * along)
}

fn query_through(
    v: DVec3,
    dir: DVec3,
    t_v: f64,
    range: DepthRange,
    light: DVec3,
    eta: f64,
) -> SegmentQuery {
    SegmentQuery {
        ends: PathEnds {
            origin: v - t_v * dir,
            dir,
            light,
            eta,
        },
        range,
    }
}

/// Every ray refracted at a point of the sphere through a normal of the cone, from a light
/// outside it, passes only through depths the beam keeps (or the beam is unbounded).
#[test]
fn beam_holds_every_refracted_ray() {
    let mut rng = Rng(11);
    let etas = [1.0015, 1.33, 1.5, 2.42, 4.0];
    let (mut checked, mut bounded) = (0, 0);
    for _ in 0..60_000 {
        let scale = 10f64.powf(rng.range(-3.0, 2.0));
        let sphere = BoundingSphere {
            center: rng.unit() * scale * rng.range(0.0, 10.0),
            radius: scale,
        };
        let light_dir = rng.unit();
        let light = sphere.center + light_dir * scale * 10f64.powf(rng.range(0.001, 3.0));
        // Cones up to 80°, their axis anywhere from toward the light to grazing it.
        let half_angle = rng.range(0.0, 1.4);
        let tilt = rng.range(0.0, 1.7);
        let axis = in_cone(&mut rng, light_dir, tilt);
        let Some(cone) = NormalCone::convex(axis, half_angle) else {
            continue;
        };
        let eta = etas[(rng.next() * etas.len() as f64) as usize % etas.len()];
        let p = sphere.center + rng.unit() * sphere.radius * rng.next().cbrt();
        // Half of the normals on the cone's rim, where the deviation is largest.
        let n = if rng.next() < 0.5 {
            in_cone(&mut rng, axis, half_angle)
        } else {
            let (u, w) = basis(axis);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            half_angle.cos() * axis + half_angle.sin() * (phi.cos() * u + phi.sin() * w)
        };
        let Some(omega_v) = refracted(n, (light - p).normalize(), eta) else {
            continue;
        };
        let s = scale * 10f64.powf(rng.range(-4.0, 3.0));
        let v = p + s * omega_v;
        let dir = rng.unit();
        let t_v = rng.range(-2.0, 2.0) * scale;
        let range = DepthRange {
            lo: t_v - rng.next() * scale,
            hi: t_v + rng.next() * scale,
        };
        let query = query_through(v, dir, t_v, range, light, eta);
        checked += 1;
        match query.beam(sphere, cone) {
            BeamBound::Empty => panic!("beam empty for a valid ray: {query:?} {sphere:?} {cone:?}"),
            BeamBound::Unbounded => {}
            BeamBound::Beam(beam) => {
                bounded += 1;
                let kept = beam.trim(&query);
                assert!(
                    kept.is_some_and(|k| k.lo <= t_v && t_v <= k.hi),
                    "beam trimmed {kept:?} misses t = {t_v}: {query:?} {sphere:?} {cone:?}"
                );
            }
        }
    }
    println!("{checked} refracted rays, {bounded} of them with a bounded beam, all kept");
    assert!(
        checked > 20_000 && bounded > 10_000,
        "{checked} / {bounded}"
    );
}

/// The half-angle is the largest deviation of the refracted directions over the cone, for a
/// far light (its own spread negligible) and cones whose normals all face it: the largest of
/// dense samples on the cone's rim is at most α and within 0.2 % of it.
#[test]
fn beam_half_angle_is_the_largest_deviation() {
    let mut rng = Rng(5);
    let mut tried = 0;
    for _ in 0..400 {
        let light_dir = rng.unit();
        let half_angle = rng.range(0.01, 0.6);
        let axis = in_cone(&mut rng, light_dir, 1.5 - half_angle);
        let cone = NormalCone::convex(axis, half_angle).unwrap();
        let eta = [1.33, 1.5, 2.42][tried % 3];
        let sphere = BoundingSphere {
            center: DVec3::ZERO,
            radius: 1e-9,
        };
        let light = light_dir * 1e3;
        let query = query_through(
            DVec3::ZERO,
            DVec3::X,
            0.0,
            DepthRange { lo: 0.0, hi: 1.0 },
            light,
            eta,
        );
        let BeamBound::Beam(beam) = query.beam(sphere, cone) else {
            panic!("no beam for a cone facing the light: {cone:?}");
        };
        let (alpha, beam_axis) = beam.cone();
        let central = refracted(axis, light_dir, eta).unwrap();
        assert!(angle_between(central, beam_axis) < 1e-12);
        let (s, t) = basis(axis);
        let largest = (0..20_000)
            .map(|i| {
                let phi = i as f64 * std::f64::consts::TAU / 20_000.0;
                let n =
                    half_angle.cos() * axis + half_angle.sin() * (phi.cos() * s + phi.sin() * t);
                angle_between(refracted(n, light_dir, eta).unwrap(), central)
            })
            .fold(0.0, f64::max);
        assert!(largest <= alpha, "sampled {largest} > α = {alpha}");
        assert!(
            largest >= 0.998 * alpha,
            "α = {alpha} loose: sampled {largest}"
        );
        tried += 1;
    }
    assert_eq!(tried, 400);
}

/// The trimmed range is the set of depths inside the beam's cone: against 4,001 samples of the
/// segment, each tested directly (inside the cone tangent to the sphere and ahead of the plane a
/// radius behind the centre), the range holds every inside sample and ends within a sample step
/// of the outermost ones.
#[test]
fn beam_trim_matches_sampled_membership() {
    let mut rng = Rng(23);
    let mut crossed = 0;
    for _ in 0..3_000 {
        let light_dir = rng.unit();
        let axis = in_cone(&mut rng, light_dir, 1.2);
        let cone = NormalCone::convex(axis, rng.range(0.0, 0.5)).unwrap();
        let sphere = BoundingSphere {
            center: DVec3::ZERO,
            radius: rng.range(0.01, 0.3),
        };
        let query = SegmentQuery {
            ends: PathEnds {
                origin: rng.unit() * rng.range(0.0, 3.0),
                dir: rng.unit(),
                light: light_dir * rng.range(2.0, 20.0),
                eta: 1.5,
            },
            range: DepthRange { lo: -4.0, hi: 4.0 },
        };
        let BeamBound::Beam(beam) = query.beam(sphere, cone) else {
            continue;
        };
        let (alpha, beam_axis) = beam.cone();
        let r = sphere.radius;
        let inside = |t: f64| {
            let w = query.ends.camera_point(t) - sphere.center;
            let p = w.dot(beam_axis);
            let across = (w - p * beam_axis).length();
            p >= -r && across * alpha.cos() <= r + p * alpha.sin()
        };
        let step = 8.0 / 4000.0;
        let samples: Vec<f64> = (0..=4000)
            .map(|i| -4.0 + i as f64 * step)
            .filter(|&t| inside(t))
            .collect();
        let kept = beam.trim(&query);
        match (samples.first(), samples.last(), kept) {
            (None, None, None) => {}
            (None, None, Some(k)) => assert!(k.hi - k.lo <= step, "kept {k:?}, no sample inside"),
            (Some(&first), Some(&last), Some(k)) => {
                crossed += 1;
                assert!(
                    k.lo <= first && last <= k.hi,
                    "kept {k:?} misses [{first}, {last}]"
                );
                assert!(
                    first - k.lo <= step && k.hi - last <= step,
                    "kept {k:?} wider than [{first}, {last}]"
                );
            }
            (first, last, kept) => panic!("samples {first:?}…{last:?} inside, kept {kept:?}"),
        }
    }
    assert!(crossed > 300, "only {crossed} segments met a beam");
}
