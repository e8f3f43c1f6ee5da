use super::*;

/// The fluence rate at `p` estimated from light points, `mean(I_eff(p) / ‖y − p‖²)`, and the
/// relative error it may have (see [`sampled_mean`]).
fn fluence_estimate(light: &Light, object: BoundingSphere, p: DVec3) -> (Rgb, f64) {
    fluence_estimate_from(light, Receivers::about_centre(object), p)
}

/// The same with the light sampled for `receivers`.
fn fluence_estimate_from(light: &Light, receivers: Receivers, p: DVec3) -> (Rgb, f64) {
    sampled_mean(light, receivers, |point| {
        point.intensity_toward(p) / point.position().distance_squared(p)
    })
}

/// Given numbers: a pair is the first two.
#[derive(Debug, Clone, Copy)]
struct Fixed([f64; 3]);

impl LightNumbers for Fixed {
    fn pair(&mut self) -> [f64; 2] {
        [self.0[0], self.0[1]]
    }

    fn triple(&mut self) -> [f64; 3] {
        self.0
    }
}

/// The light point drawn from the given numbers.
fn draw(light: &Light, receivers: Receivers, u: [f64; 3]) -> LightPoint {
    sample_light(light, receivers, &mut Fixed(u))
}

/// Whether the light takes three numbers for `receivers` (a sphere light sampled inside).
fn takes_a_triple(light: &Light, receivers: Receivers) -> bool {
    struct Probe(bool);
    impl LightNumbers for Probe {
        fn pair(&mut self) -> [f64; 2] {
            [0.5; 2]
        }
        fn triple(&mut self) -> [f64; 3] {
            self.0 = true;
            [0.5; 3]
        }
    }
    let mut probe = Probe(false);
    sample_light(light, receivers, &mut probe);
    probe.0
}

/// The mean of `f` over light points, and the relative error allowed in comparing it with the
/// truth. A light drawn from a pair: a stratified 400×400 grid, allowed 1e-3. A sphere light
/// sampled inside (a triple): a grid converges slowly there (its weights are singular where a
/// line through the point grazes the sphere: 6e-3 at 64³, 2e-3 at 256³), so 2¹⁸ samples'
/// numbers from the renderer's own sampler, allowed four standard errors (from the samples'
/// spread) and 1e-4.
fn sampled_mean(light: &Light, receivers: Receivers, f: impl Fn(LightPoint) -> Rgb) -> (Rgb, f64) {
    if !takes_a_triple(light, receivers) {
        let n = 400;
        let at = |i: usize| (i as f64 + 0.5) / n as f64;
        let mut sum = Rgb::ZERO;
        for i in 0..n {
            for j in 0..n {
                sum += f(draw(light, receivers, [at(i), at(j), 0.5]));
            }
        }
        return (sum / (n * n) as f64, 1e-3);
    }
    let n = 1u32 << 18;
    let (mut sum, mut sum2) = (Rgb::ZERO, Rgb::ZERO);
    for i in 0..n {
        let mut sampler = crate::sampler::Sampler::new(11, 0, 0, i);
        let value = f(sample_light(light, receivers, &mut sampler));
        sum += value;
        sum2 += value * value;
    }
    let mean = sum / f64::from(n);
    let spread = (sum2 / f64::from(n) - mean * mean).max(Rgb::ZERO);
    let standard_error = (spread / f64::from(n)).powf(0.5) / mean;
    (mean, 4.0 * standard_error.max_element() + 1e-4)
}

/// The closed-form fluence rate at `p` of a sphere light (see below), `None` inside it.
fn sphere_fluence(center: DVec3, radius: f64, radiance: Rgb, p: DVec3) -> Option<Rgb> {
    let d = center.distance(p);
    let cos_alpha = (1.0 - (radius / d).powi(2)).sqrt();
    (d > radius).then(|| radiance * std::f64::consts::TAU * (1.0 - cos_alpha))
}

/// A quad light of the scene description's fields around the unit sphere at the origin.
fn quad_light(corner: DVec3, edge_u: DVec3, edge_v: DVec3, radiance: Rgb) -> Light {
    Light::new(
        &spindle_common::scene::Light::Quad {
            corner: corner.to_array(),
            edge_u: edge_u.to_array(),
            edge_v: edge_v.to_array(),
            radiance: radiance.to_array(),
        },
        crate::light::SceneSphere {
            center: DVec3::ZERO,
            radius: 1.0,
        },
    )
    .unwrap()
}

/// The estimate's error at `p` relative to a quad light's fluence there, `L_e · Ω(p)` in front
/// of it (Ω the solid angle of the rectangle, in closed form) and 0 behind, in units of `L_e · Ω`.
fn quad_fluence_error(
    estimate: Rgb,
    (corner, edge_u, edge_v): (DVec3, DVec3, DVec3),
    radiance: Rgb,
    p: DVec3,
) -> f64 {
    let omega = crate::light::rectangle::tests::quad_solid_angle(p, corner, edge_u, edge_v);
    let in_front = (p - corner).dot(edge_u.cross(edge_v)) > 0.0;
    let truth = if in_front {
        radiance * omega
    } else {
        Rgb::ZERO
    };
    ((estimate - truth).abs() / radiance).max_element() / omega
}

/// Ground truth: the fluence rate (scalar irradiance) at a point `p` at distance `d` from the
/// centre of a sphere of uniform radiance `L_e` and radius `R` is `∫ L dω = L_e · 2π(1 − cos α)`
/// with `sin α = R/d`. The estimator of it from light points is
/// `mean(I_eff(p) / ‖y − p‖²)`. A stratified 400×400 grid of samples must match to 1e-3
/// relative, for receivers anywhere in the object's bounding sphere, near and far lights.
#[test]
fn sphere_light_points_estimate_the_fluence() {
    let radiance = DVec3::new(1.0, 2.0, 0.5);
    for (light_center, light_radius, object_radius) in [
        (DVec3::new(5.0, 1.0, -2.0), 1.0, 1.0),
        (DVec3::new(0.0, 0.0, 3.2), 1.5, 1.0),
        (DVec3::new(300.0, 0.0, 0.0), 0.5, 2.0),
        (DVec3::new(0.0, 1.9, 0.0), 0.5, 1.0),
    ] {
        let light = Light::Sphere {
            center: light_center,
            radius: light_radius,
            radiance,
        };
        let object = BoundingSphere {
            center: DVec3::ZERO,
            radius: object_radius,
        };
        for p in [
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, object_radius * 0.99),
            DVec3::new(-object_radius * 0.7, 0.5 * object_radius, 0.0),
        ] {
            let (estimate, allowed) = fluence_estimate(&light, object, p);
            let truth = sphere_fluence(light_center, light_radius, radiance, p).unwrap();
            let err = ((estimate - truth) / truth).abs().max_element();
            assert!(
                err < allowed,
                "light {light_center} p {p}: {estimate} vs {truth} ({err})"
            );
        }
    }
}

/// Sampled for a camera segment (by solid angle from its ends and middle), the light points
/// still estimate the fluence anywhere in the object, on the segment or not: segments through
/// the object's middle, along its edge, and one that ends inside the light.
#[test]
fn sphere_light_points_for_a_segment_estimate_the_fluence_anywhere() {
    let radiance = DVec3::new(1.0, 2.0, 0.5);
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    for (light_center, light_radius) in [
        (DVec3::new(0.0, 1.2, -3.8), 0.1),
        (DVec3::new(0.0, 1.2, -3.8), 0.5),
        (DVec3::new(0.0, 1.9, 0.0), 0.5),
    ] {
        let light = Light::Sphere {
            center: light_center,
            radius: light_radius,
            radiance,
        };
        for (origin, end) in [
            (DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -1.0)),
            (DVec3::new(0.6, 0.7, 0.3), DVec3::new(-0.7, 0.6, -0.2)),
            (DVec3::new(0.0, 0.2, 0.0), DVec3::new(0.0, 1.6, 0.0)),
        ] {
            let dir = (end - origin).normalize();
            let receivers = Receivers::of_segment(object, origin, dir, origin.distance(end));
            for p in [
                DVec3::ZERO,
                DVec3::new(0.0, 0.0, -0.99),
                DVec3::new(0.0, 0.99, 0.0),
                DVec3::new(-0.7, -0.5, 0.4),
                0.5 * (origin + end),
            ] {
                let Some(truth) = sphere_fluence(light_center, light_radius, radiance, p) else {
                    continue;
                };
                let (estimate, allowed) = fluence_estimate_from(&light, receivers, p);
                let err = ((estimate - truth) / truth).abs().max_element();
                assert!(
                    err < allowed,
                    "light {light_center} r {light_radius}, segment {origin}..{end}, p {p}: \
                     {estimate} vs {truth} ({err})"
                );
            }
        }
    }
}

/// The same for a quad light sampled for a segment: the fluence anywhere in the object, in front
/// of the quad or behind it, with apexes in front of it, behind it, or some of each.
#[test]
fn quad_light_points_for_a_segment_estimate_the_fluence_anywhere() {
    let radiance = DVec3::new(1.0, 2.0, 0.5);
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let (corner, edge_u, edge_v) = (
        DVec3::new(-1.0, 0.4, -1.0),
        DVec3::new(0.0, 0.0, 2.0),
        DVec3::new(2.0, 0.0, 0.0),
    );
    let light = quad_light(corner, edge_u, edge_v, radiance);
    for (origin, end) in [
        (DVec3::new(0.0, -0.9, 0.3), DVec3::new(0.2, 0.3, -0.3)),
        (DVec3::new(0.0, 0.9, 0.3), DVec3::new(0.2, 0.6, -0.3)),
        (DVec3::new(-0.6, -0.7, 0.0), DVec3::new(0.7, 0.6, 0.1)),
    ] {
        let dir = (end - origin).normalize();
        let receivers = Receivers::of_segment(object, origin, dir, origin.distance(end));
        for p in [
            DVec3::ZERO,
            DVec3::new(0.0, -0.99, 0.0),
            DVec3::new(0.3, 0.35, 0.1),
            DVec3::new(-0.7, -0.5, 0.4),
            DVec3::new(0.1, 0.8, 0.0),
        ] {
            let (estimate, _) = fluence_estimate_from(&light, receivers, p);
            let err = quad_fluence_error(estimate, (corner, edge_u, edge_v), radiance, p);
            assert!(
                err < 2e-3,
                "segment {origin}..{end}, p {p}: {estimate} ({err})"
            );
        }
    }
}

/// The same for a quad light: the fluence at `p` is `L_e · Ω(p)` in front of it (Ω the solid
/// angle of the rectangle, in closed form) and 0 behind. Quads near the object (sampled mostly by
/// solid angle), far away (by area), and one whose plane cuts the object (centre behind it).
#[test]
fn quad_light_points_estimate_the_fluence() {
    let radiance = DVec3::new(1.0, 2.0, 0.5);
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    for (corner, edge_u, edge_v) in [
        (
            DVec3::new(-1.0, 1.5, -1.0),
            DVec3::new(0.0, 0.0, 2.0),
            DVec3::new(2.0, 0.0, 0.0),
        ),
        (
            DVec3::new(-0.5, -0.5, -40.0),
            DVec3::new(0.3, 0.0, 0.0),
            DVec3::new(0.0, 0.2, 0.0),
        ),
        (
            DVec3::new(-2.0, 0.4, -2.0),
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 4.0),
        ),
    ] {
        let light = quad_light(corner, edge_u, edge_v, radiance);
        for p in [
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, -0.99),
            DVec3::new(0.3, 0.9, 0.1),
            DVec3::new(-0.7, -0.5, 0.0),
        ] {
            let (estimate, _) = fluence_estimate(&light, object, p);
            let err = quad_fluence_error(estimate, (corner, edge_u, edge_v), radiance, p);
            assert!(err < 2e-3, "quad at {corner}, p {p}: {estimate} ({err})");
        }
    }
}

/// A quad light's sample weights never exceed `L_e · A / (1 − share)`.
#[test]
fn quad_light_weights_are_bounded_by_the_area_share() {
    let light = Light::new(
        &spindle_common::scene::Light::Quad {
            corner: [-1.0, 1.2, -1.0],
            edge_u: [0.0, 0.0, 2.0],
            edge_v: [2.0, 0.0, 0.0],
            radiance: [1.0, 1.0, 1.0],
        },
        crate::light::SceneSphere {
            center: DVec3::ZERO,
            radius: 1.0,
        },
    )
    .unwrap();
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let bound = 4.0 / (1.0 - SOLID_ANGLE_SHARE);
    let mut sampler = crate::sampler::Sampler::new(3, 0, 0, 0);
    for _ in 0..20_000 {
        let LightPoint::Area {
            radiance_over_pdf, ..
        } = sample_light(&light, Receivers::about_centre(object), &mut sampler)
        else {
            panic!("a quad light gives area points");
        };
        assert!(radiance_over_pdf.max_element() <= bound * (1.0 + 1e-12));
        assert!(radiance_over_pdf.min_element() > 0.0);
    }
}

#[test]
fn point_lights_are_used_as_they_are() {
    let light = Light::Point {
        position: DVec3::new(1.0, 2.0, 3.0),
        intensity: DVec3::splat(4.0),
    };
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let point = draw(&light, Receivers::about_centre(object), [0.3, 0.7, 0.5]);
    assert_eq!(point.position(), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(point.intensity_toward(DVec3::X), DVec3::splat(4.0));
}

/// The per-sample spread of the fluence estimate `I_eff(p) / ‖y − p‖²` over a stratified grid.
fn fluence_spread(light: &Light, object: BoundingSphere, p: DVec3) -> f64 {
    let n = 64;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let at = |i: usize| (i as f64 + 0.5) / n as f64;
                let point = draw(
                    light,
                    Receivers::about_centre(object),
                    [at(i), at(j), at(k)],
                );
                let e = point.intensity_toward(p).x / point.position().distance_squared(p);
                sum += e;
                sum2 += e * e;
            }
        }
    }
    let count = (n * n * n) as f64;
    let mean = sum / count;
    (sum2 / count - mean * mean).max(0.0).sqrt() / mean
}

/// A small distant sphere light (radius 0.1 at distance 4 from a unit object) seen from the
/// object's centre and from points on its lit side. Uniform sampling of the visible cap spreads
/// each sample's estimate by 0.84 of the mean (the cosine at the light). Sampled inside, every
/// point sends `π R² L_e` toward every receiver, so all that is left is the spread of
/// `1/‖y − p‖²` over the light's points, about `2R/d`: 0.025–0.033 measured, wherever the
/// receiver is (drawn on the surface by solid angle from the segment, it was 0.2 at 60°).
#[test]
fn small_sphere_lights_are_sampled_nearly_like_point_lights() {
    let light = Light::Sphere {
        center: DVec3::new(0.0, 0.0, 4.0),
        radius: 0.1,
        radiance: DVec3::ONE,
    };
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let at = |deg: f64| DVec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
    for (p, bound) in [(DVec3::ZERO, 0.05), (at(0.0), 0.05), (at(60.0), 0.05)] {
        let spread = fluence_spread(&light, object, p);
        assert!(spread < bound, "receiver {p}: spread {spread} ≥ {bound}");
    }
}

/// Sampled on its surface (the object's bounding sphere reaches the light), no sample weighs
/// more than the cap's share alone allows: `L_e / ((1 − share) · pdf_cap)`, so receivers the
/// centre cannot see behind its horizon never get an unbounded weight.
#[test]
fn sphere_light_weights_are_bounded_by_the_cap_share() {
    let radiance = DVec3::ONE;
    for (light_center, radius, object_radius) in [
        (DVec3::new(0.0, 0.0, 1.9), 1.0, 1.0),
        (DVec3::new(0.0, 1.4, 0.0), 0.5, 1.0),
        (DVec3::new(0.3, 0.0, 0.0), 1.0, 1.0),
    ] {
        let light = Light::Sphere {
            center: light_center,
            radius,
            radiance,
        };
        let object = BoundingSphere {
            center: DVec3::ZERO,
            radius: object_radius,
        };
        let d = light_center.length();
        let one_minus_cos = if d > object_radius + radius {
            let gamma = (radius / (d + object_radius)).acos() + (object_radius / d).asin();
            (1.0 - gamma.cos()).min(2.0)
        } else {
            2.0
        };
        let share = if d > radius {
            1.0 - SOLID_ANGLE_SHARE
        } else {
            1.0
        };
        let bound = std::f64::consts::TAU * radius * radius * one_minus_cos / share;
        let n = 200;
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                let LightPoint::Area {
                    radiance_over_pdf, ..
                } = draw(&light, Receivers::about_centre(object), [u[0], u[1], 0.5])
                else {
                    panic!("a sphere light gives area points");
                };
                let w = radiance_over_pdf.x;
                assert!(
                    w > 0.0 && w <= bound * (1.0 + 1e-6),
                    "light {light_center} r {radius}: weight {w} vs bound {bound}"
                );
            }
        }
    }
}

/// The inside points follow the density `1/(π² R² √(R² − r²))`: the distribution of their
/// distance from the centre, `P(r ≤ xR) = (2/π)(asin x − x√(1 − x²))`, against 2¹⁶ of the
/// sampler's draws (largest gap of the two distribution functions below 0.01; 0.27 is what the
/// uniform ball would give at worst), and every direction alike (each axis's mean of `y − c`
/// near 0).
#[test]
fn inside_points_follow_the_three_sphere_density() {
    let (center, radius) = (DVec3::new(0.0, 1.2, -3.8), 0.5);
    let light = Light::Sphere {
        center,
        radius,
        radiance: DVec3::ONE,
    };
    let object = BoundingSphere {
        center: DVec3::ZERO,
        radius: 1.0,
    };
    let n = 1usize << 16;
    let mut distances = Vec::with_capacity(n);
    let mut mean = DVec3::ZERO;
    for s in 0..n as u32 {
        let mut sampler = crate::sampler::Sampler::new(5, 0, 0, s);
        let point = sample_light(&light, Receivers::about_centre(object), &mut sampler);
        let LightPoint::Ball { position, .. } = point else {
            panic!("sampled inside: {point:?}");
        };
        distances.push(position.distance(center) / radius);
        mean += (position - center) / radius / n as f64;
    }
    distances.sort_by(f64::total_cmp);
    let cdf = |x: f64| 2.0 / std::f64::consts::PI * (x.asin() - x * (1.0 - x * x).sqrt());
    let gap = distances
        .iter()
        .enumerate()
        .map(|(i, &x)| (cdf(x.min(1.0)) - (i as f64 + 0.5) / n as f64).abs())
        .fold(0.0, f64::max);
    assert!(gap < 0.01, "gap {gap}");
    assert!(mean.abs().max_element() < 0.01, "mean offset {mean}");
}

/// The density's integral along a line through the sphere is `1/(π R²)` whatever the line's
/// distance `ρ` from the centre (quadrature with `s = h sin φ`, which takes the `1/√` ends
/// away): why every inside point is a point light of intensity `π R² L_e`.
#[test]
fn the_inside_density_integrates_alike_along_every_line() {
    let radius = 0.7;
    let density = |d2: f64| {
        1.0 / (std::f64::consts::PI.powi(2) * radius * radius * (radius * radius - d2).sqrt())
    };
    for rho in [0.0, 0.1, 0.35, 0.6, 0.69, 0.699_999] {
        let h = (radius * radius - rho * rho).sqrt();
        let steps = 10_000;
        let mut sum = 0.0;
        for i in 0..steps {
            let phi = -std::f64::consts::FRAC_PI_2
                + std::f64::consts::PI * (i as f64 + 0.5) / steps as f64;
            let s = h * phi.sin();
            let ds = h * phi.cos() * std::f64::consts::PI / steps as f64;
            sum += density(rho * rho + s * s) * ds;
        }
        let expected = 1.0 / (std::f64::consts::PI * radius * radius);
        assert!(
            (sum / expected - 1.0).abs() < 1e-6,
            "rho {rho}: {sum} vs {expected}"
        );
    }
}
