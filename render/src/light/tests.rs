use super::*;

const UNIT: SceneSphere = SceneSphere {
    center: DVec3::ZERO,
    radius: 1.0,
};
use crate::sampler::Sampler;

#[test]
fn sphere_light_irradiance_matches_the_analytic_value() {
    // Irradiance on a surface facing a sphere of radiance L at distance d: E = π L (R/d)².
    let light = Light::Sphere {
        center: DVec3::new(0.0, 0.0, 3.0),
        radius: 0.7,
        radiance: DVec3::splat(2.0),
    };
    let mut s = Sampler::new(1, 0, 0, 0);
    let n = 200_000;
    let mut e = 0.0;
    for _ in 0..n {
        let sample = light.sample_incident(DVec3::ZERO, s.next_2d()).unwrap();
        let hit = DVec3::ZERO + sample.dir * sample.distance;
        assert!(((hit - DVec3::new(0.0, 0.0, 3.0)).length() - 0.7).abs() < 1e-6);
        e += sample.weight.x * sample.dir.z;
    }
    e /= n as f64;
    let expected = std::f64::consts::PI * 2.0 * (0.7f64 / 3.0).powi(2);
    assert!((e - expected).abs() < 3e-3 * expected, "{e} vs {expected}");
}

#[test]
fn rays_hit_the_near_side_of_a_sphere_light() {
    let light = Light::Sphere {
        center: DVec3::new(0.0, 0.0, -5.0),
        radius: 1.0,
        radiance: DVec3::ONE,
    };
    let (t, _) = light.intersect(&Ray::new(DVec3::ZERO, -DVec3::Z)).unwrap();
    assert!((t - 4.0).abs() < 1e-14);
    assert!(light.intersect(&Ray::new(DVec3::ZERO, DVec3::Z)).is_none());
    assert!(light.intersect(&Ray::new(DVec3::ZERO, DVec3::X)).is_none());
    let inside = light.intersect(&Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::X));
    assert!((inside.unwrap().0 - 1.0).abs() < 1e-14);
}

#[test]
fn area_samples_lie_on_the_sphere_with_uniform_density() {
    let light = Light::Sphere {
        center: DVec3::new(1.0, 2.0, 3.0),
        radius: 2.0,
        radiance: DVec3::ONE,
    };
    let mut s = Sampler::new(5, 0, 0, 0);
    let mut upper = 0;
    for _ in 0..10_000 {
        let a = light.sample_area(s.next_2d()).unwrap();
        assert!(((a.point - DVec3::new(1.0, 2.0, 3.0)).length() - 2.0).abs() < 1e-12);
        assert!((a.pdf_area * 16.0 * std::f64::consts::PI - 1.0).abs() < 1e-12);
        upper += (a.normal.z > 0.0) as u32;
    }
    assert!((upper as f64 / 10_000.0 - 0.5).abs() < 0.03);
}

#[test]
fn bad_lights_are_rejected_by_field() {
    let e = Light::new(
        &desc::Light::Sphere {
            center: [0.0; 3],
            radius: 0.0,
            radiance: [1.0; 3],
        },
        UNIT,
    );
    assert!(e.unwrap_err().to_string().starts_with("radius:"));
    let e = Light::new(
        &desc::Light::Point {
            position: [0.0; 3],
            intensity: [1.0, f64::NAN, 0.0],
        },
        UNIT,
    );
    assert!(e.unwrap_err().to_string().starts_with("intensity:"));
    let e = Light::new(
        &desc::Light::Directional {
            direction: [0.0; 3],
            irradiance: [1.0; 3],
            angular_diameter: 0.0,
        },
        UNIT,
    );
    assert!(e.unwrap_err().to_string().starts_with("direction:"));
}

fn quad(corner: [f64; 3], edge_u: [f64; 3], edge_v: [f64; 3], radiance: f64) -> Light {
    Light::new(
        &desc::Light::Quad {
            corner,
            edge_u,
            edge_v,
            radiance: [radiance; 3],
        },
        UNIT,
    )
    .unwrap()
}

#[test]
fn quad_lights_are_seen_from_the_front_and_black_from_behind() {
    let light = quad([-1.0, -1.0, 0.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0], 5.0);
    // Normal: (0,2,0) × (2,0,0) = (0,0,-4): emits toward −z.
    let (t, l) = light
        .intersect(&Ray::new(DVec3::new(0.5, 0.5, -3.0), DVec3::Z))
        .unwrap();
    assert!((t - 3.0).abs() < 1e-14 && l == DVec3::splat(5.0));
    let (t, l) = light
        .intersect(&Ray::new(DVec3::new(0.5, 0.5, 2.0), -DVec3::Z))
        .unwrap();
    assert!((t - 2.0).abs() < 1e-14 && l == DVec3::ZERO);
    assert!(
        light
            .intersect(&Ray::new(DVec3::new(1.5, 0.5, -3.0), DVec3::Z))
            .is_none()
    );
    assert!(
        light
            .intersect(&Ray::new(DVec3::new(0.5, 0.5, -3.0), DVec3::X))
            .is_none()
    );
    assert!(
        light
            .intersect(&Ray::new(DVec3::new(0.5, 0.5, -3.0), -DVec3::Z))
            .is_none()
    );
    let a = light.sample_area([0.25, 0.75]).unwrap();
    assert_eq!(a.point, DVec3::new(0.5, -0.5, 0.0));
    assert_eq!(a.normal, -DVec3::Z);
    assert!((a.pdf_area - 0.25).abs() < 1e-15);
    assert!((light.center() - DVec3::ZERO).length() < 1e-15);
}

#[test]
fn bad_quad_lights_are_rejected_by_field() {
    let e = Light::new(
        &desc::Light::Quad {
            corner: [0.0; 3],
            edge_u: [1.0, 0.0, 0.0],
            edge_v: [0.5, 1.0, 0.0],
            radiance: [1.0; 3],
        },
        UNIT,
    );
    assert!(e.unwrap_err().to_string().starts_with("edge_v:"));
    let e = Light::new(
        &desc::Light::Quad {
            corner: [0.0; 3],
            edge_u: [0.0; 3],
            edge_v: [0.0, 1.0, 0.0],
            radiance: [1.0; 3],
        },
        UNIT,
    );
    assert!(e.unwrap_err().to_string().starts_with("edge_u:"));
}
