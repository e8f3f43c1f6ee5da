use super::*;

/// The solid angle of the parallelogram `corner, corner + u, corner + u + v, corner + v` seen
/// from `origin`, as two triangles.
pub(crate) fn quad_solid_angle(origin: DVec3, corner: DVec3, u: DVec3, v: DVec3) -> f64 {
    let (a, b, c, d) = (
        corner - origin,
        corner + u - origin,
        corner + u + v - origin,
        corner + v - origin,
    );
    triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d)
}

/// The solid angle of the triangle `a, b, c` seen from the origin (Van Oosterom and Strackee).
fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c)).abs();
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

/// Rectangles (corner, edge_u, edge_v) and origins in front of, behind, beside and close to them.
fn cases() -> Vec<(DVec3, DVec3, DVec3, DVec3)> {
    let tilted_u = DVec3::new(1.0, 0.3, -0.2).normalize() * 1.7;
    let tilted_v = tilted_u.cross(DVec3::new(0.2, 1.0, 0.4)).normalize() * 0.6;
    let mut cases = Vec::new();
    for origin in [
        DVec3::new(0.5, 0.5, 2.0),
        DVec3::new(0.5, 0.5, -0.3),
        DVec3::new(3.0, -2.0, 0.7),
        DVec3::new(0.01, 0.02, 0.01),
        DVec3::new(-0.4, 1.3, -5.0),
    ] {
        cases.push((
            origin,
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ));
        cases.push((origin, DVec3::new(-0.5, 0.2, 0.1), tilted_u, tilted_v));
    }
    cases
}

#[test]
fn the_solid_angle_matches_the_closed_form() {
    for (origin, corner, u, v) in cases() {
        let rect = SphericalRectangle::new(origin, corner, u, v).expect("a visible rectangle");
        let expected = quad_solid_angle(origin, corner, u, v);
        let err = (rect.solid_angle() - expected).abs() / expected;
        assert!(
            err < 1e-10,
            "origin {origin}: {} vs {expected}",
            rect.solid_angle()
        );
    }
    // On the axis of a 2a × 2b rectangle at distance h: 4 asin(ab / √((a²+h²)(b²+h²))).
    let (a, b, h) = (0.5f64, 1.5f64, 0.8f64);
    let rect = SphericalRectangle::new(
        DVec3::new(a, b, h),
        DVec3::ZERO,
        DVec3::new(2.0 * a, 0.0, 0.0),
        DVec3::new(0.0, 2.0 * b, 0.0),
    )
    .unwrap();
    let expected = 4.0 * (a * b / ((a * a + h * h) * (b * b + h * h)).sqrt()).asin();
    assert!((rect.solid_angle() - expected).abs() < 1e-12 * expected);
    // In the plane, or too small to sample by angle: declined.
    assert!(
        SphericalRectangle::new(DVec3::new(3.0, 0.5, 0.0), DVec3::ZERO, DVec3::X, DVec3::Y)
            .is_none()
    );
    assert!(
        SphericalRectangle::new(DVec3::new(0.0, 0.0, 100.0), DVec3::ZERO, DVec3::X, DVec3::Y)
            .is_none()
    );
}

/// Samples lie on the rectangle, and they are uniform in solid angle: over a stratified grid,
/// `Ω · mean f(ω)` matches `∫ f dω` computed by brute force over the rectangle's area (a 1500²
/// midpoint grid, `dω = cos_y dA / r²`), for a smooth non-linear `f`.
#[test]
fn samples_are_uniform_in_solid_angle() {
    let f = |w: DVec3| {
        let a = w.dot(DVec3::new(0.3, -0.5, 0.8));
        a * a + 0.2 * w.x
    };
    for (origin, corner, u, v) in cases() {
        let rect = SphericalRectangle::new(origin, corner, u, v).unwrap();
        let normal = u.cross(v).normalize();
        let n = 300;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let s = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                let p = rect.sample(s);
                let (a, b) = (
                    (p - corner).dot(u) / u.length_squared(),
                    (p - corner).dot(v) / v.length_squared(),
                );
                assert!((p - corner).dot(normal).abs() < 1e-9, "off the plane: {p}");
                assert!(
                    (-1e-9..=1.0 + 1e-9).contains(&a) && (-1e-9..=1.0 + 1e-9).contains(&b),
                    "off the rectangle: {a}, {b}"
                );
                sum += f((p - origin).normalize());
            }
        }
        let by_angle = rect.solid_angle() * sum / (n * n) as f64;
        let m = 1500;
        let mut brute = 0.0;
        let da = u.length() * v.length() / (m * m) as f64;
        for i in 0..m {
            for j in 0..m {
                let y =
                    corner + u * ((i as f64 + 0.5) / m as f64) + v * ((j as f64 + 0.5) / m as f64);
                let r = y - origin;
                let r2 = r.length_squared();
                let w = r / r2.sqrt();
                brute += f(w) * w.dot(normal).abs() / r2 * da;
            }
        }
        let err = (by_angle - brute).abs() / brute.abs();
        assert!(
            err < 2e-3,
            "origin {origin}: {by_angle} by solid angle vs {brute} by area ({err:.1e})"
        );
    }
}
