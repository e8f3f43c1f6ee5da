use super::*;

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
            let n = 400;
            let mut sum = Rgb::ZERO;
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                    let point = sample_light(&light, object, u);
                    let d2 = point.position().distance_squared(p);
                    sum += point.intensity_toward(p) / d2;
                }
            }
            let estimate = sum / (n * n) as f64;
            let d = light_center.distance(p);
            let cos_alpha = (1.0 - (light_radius / d).powi(2)).sqrt();
            let truth = radiance * std::f64::consts::TAU * (1.0 - cos_alpha);
            let err = ((estimate - truth) / truth).abs().max_element();
            assert!(
                err < 1e-3,
                "light {light_center} p {p}: {estimate} vs {truth} ({err})"
            );
        }
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
    let point = sample_light(&light, object, [0.3, 0.7]);
    assert_eq!(point.position(), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(point.intensity_toward(DVec3::X), DVec3::splat(4.0));
}
