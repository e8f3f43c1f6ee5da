use super::*;

/// s-polarised reflectance from angles alone (Fresnel's sine law), independent of the code
/// above: R_s = sin²(θi − θt) / sin²(θi + θt).
fn r_s_sine_law(theta_i: f64, eta: f64) -> f64 {
    let theta_t = (theta_i.sin() / eta).asin();
    ((theta_i - theta_t).sin() / (theta_i + theta_t).sin()).powi(2)
}

#[test]
fn reflectance_plus_transmittance_is_one_and_within_bounds() {
    // R + T = 1 by energy conservation; checked through the independent form
    // T = (η cos θt / cos θi)(t_s² + t_p²)/2 with Fresnel's amplitude transmission
    // coefficients t_s = 2 cos θi/(cos θi + η cos θt), t_p = 2 cos θi/(η cos θi + cos θt).
    for &eta in &[1.0 / 1.7, 1.0 / 1.33, 1.0001, 1.2, 1.33, 1.5, 2.4] {
        for k in 0..=200 {
            let cos_i = k as f64 / 200.0;
            let r = reflectance(cos_i, eta);
            assert!((0.0..=1.0).contains(&r));
            let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
            if sin2_t >= 1.0 || cos_i == 0.0 {
                continue;
            }
            let cos_t = (1.0 - sin2_t).sqrt();
            let t_s = 2.0 * cos_i / (cos_i + eta * cos_t);
            let t_p = 2.0 * cos_i / (eta * cos_i + cos_t);
            let t = eta * cos_t / cos_i * 0.5 * (t_s * t_s + t_p * t_p);
            assert!(
                (r + t - 1.0).abs() < 1e-12,
                "eta {eta} cos {cos_i}: R {r} T {t}"
            );
        }
    }
}

#[test]
fn normal_incidence_value() {
    for &eta in &[1.33f64, 1.5, 2.0, 1.0 / 1.5] {
        let expected = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((reflectance(1.0, eta) - expected).abs() < 1e-15);
    }
    assert!((reflectance(1.0, 1.5) - 0.04).abs() < 1e-15);
}

#[test]
fn brewster_angle_reflects_only_s_polarisation() {
    for &eta in &[1.33f64, 1.5, 2.4, 1.0 / 1.5] {
        let brewster = eta.atan();
        let r = reflectance(brewster.cos(), eta);
        let r_s = r_s_sine_law(brewster, eta);
        assert!(
            (r - 0.5 * r_s).abs() < 1e-14,
            "eta {eta}: R {r} vs Rs/2 {}",
            r_s / 2.0
        );
        // Away from Brewster the p part is not zero, so R > Rs/2 there.
        let off = brewster - 0.2;
        assert!(reflectance(off.cos(), eta) > 0.5 * r_s_sine_law(off, eta) + 1e-6);
    }
}

#[test]
fn total_internal_reflection_beyond_the_critical_angle() {
    let eta = 1.0 / 1.5; // glass → air
    let critical = (1.0f64 / 1.5).asin();
    let n = DVec3::Z;
    for k in 1..50 {
        let theta = critical + (std::f64::consts::FRAC_PI_2 - critical) * k as f64 / 50.0;
        assert_eq!(reflectance(theta.cos(), eta), 1.0);
        let d = DVec3::new(theta.sin(), 0.0, -theta.cos());
        assert!(refract(d, n, eta).is_none());
    }
    let below = critical - 1e-6;
    assert!(reflectance(below.cos(), eta) < 1.0);
    assert!(refract(DVec3::new(below.sin(), 0.0, -below.cos()), n, eta).is_some());
}

#[test]
fn refraction_obeys_snell_and_stays_in_the_plane_of_incidence() {
    let mut s = crate::sampler::Sampler::new(3, 0, 0, 0);
    for _ in 0..1000 {
        let n = DVec3::new(s.next_f64() - 0.5, s.next_f64() - 0.5, s.next_f64() - 0.5).normalize();
        let mut d =
            DVec3::new(s.next_f64() - 0.5, s.next_f64() - 0.5, s.next_f64() - 0.5).normalize();
        if d.dot(n) > 0.0 {
            d = -d;
        }
        let (n1, n2) = (1.0 + s.next_f64(), 1.0 + s.next_f64());
        let eta = n2 / n1;
        let sin_i = d.cross(n).length();
        match refract(d, n, eta) {
            Some(t) => {
                assert!((t.length() - 1.0).abs() < 1e-12);
                assert!(t.dot(n) < 0.0, "transmitted ray must cross the interface");
                let sin_t = t.cross(n).length();
                assert!((n1 * sin_i - n2 * sin_t).abs() < 1e-12);
                assert!(t.dot(d.cross(n)).abs() < 1e-12, "coplanar with d and n");
                // Same tangential direction as the incident ray.
                assert!((t - t.dot(n) * n).dot(d - d.dot(n) * n) >= 0.0);
            }
            None => assert!(n1 * sin_i > n2),
        }
        let r = reflect(d, n);
        assert!((r.dot(n) + d.dot(n)).abs() < 1e-12 && (r.length() - 1.0).abs() < 1e-12);
    }
}
