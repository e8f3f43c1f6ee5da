use glam::DVec3;

use super::{FlatFaces, through_face};
use crate::fresnel::reflectance;
use crate::procedural::icosphere;
use crate::wavy_box::{WaveField, wavy_box};

#[test]
fn a_box_has_six_faces_of_its_sides_areas_and_a_wavy_top_is_not_flat() {
    let size = DVec3::new(2.0, 0.8, 1.5);
    let flat = FlatFaces::of(&wavy_box(size, None), 2.0);
    assert_eq!(flat.faces.len(), 6);
    let mut areas: Vec<f64> = flat.faces.iter().map(|f| f.area).collect();
    areas.sort_by(f64::total_cmp);
    let expected = [
        0.8 * 1.5,
        0.8 * 1.5,
        2.0 * 0.8,
        2.0 * 0.8,
        2.0 * 1.5,
        2.0 * 1.5,
    ];
    for (a, e) in areas.iter().zip(expected) {
        assert!((a - e).abs() < 1e-12, "areas {areas:?}");
    }
    // Each face's plane holds its triangles and its normal points away from the centre (the
    // box's centre is the origin).
    for face in &flat.faces {
        assert!(face.offset > 0.0, "{face:?}");
    }

    let field = WaveField::new(0.05, 1.0, 3);
    let mesh = wavy_box(size, Some((&field, 8)));
    let wavy = FlatFaces::of(&mesh, 2.0);
    // The sides and the bottom stay flat; the top's triangles bend and belong to no face.
    assert_eq!(wavy.faces.len(), 5, "{:?}", wavy.faces);
    for t in 0..mesh.triangle_count() {
        let up = mesh.geometric_normal(t).normalize().y > 0.5;
        assert_eq!(wavy.face_of(t).is_none(), up, "triangle {t}");
    }
}

#[test]
fn a_smooth_sphere_has_no_flat_face() {
    assert!(FlatFaces::of(&icosphere(1.0, 2), 1.0).faces.is_empty());
}

#[test]
fn the_refracted_sun_keeps_snells_law_and_the_power_through_the_face() {
    let box_mesh = wavy_box(DVec3::new(2.0, 1.0, 2.0), None);
    let flat = FlatFaces::of(&box_mesh, 2.0);
    let top = flat
        .faces
        .iter()
        .find(|f| f.normal.y > 0.5)
        .expect("a top face");
    for (deg, eta) in [
        (0.0f64, 1.33),
        (30.0, 1.33),
        (75.0, 1.5),
        (60.0, 1.5 / 1.33),
    ] {
        let theta = deg.to_radians();
        let toward = DVec3::new(theta.sin(), theta.cos(), 0.0);
        let r = through_face(top, toward, eta).unwrap();
        let inside = r.toward_light_inside;
        // Snell: sin θ_i = η sin θ_t, in the plane of incidence, on the same side.
        assert!((inside.length() - 1.0).abs() < 1e-12);
        assert!(
            (theta.sin() - eta * inside.x).abs() < 1e-12,
            "{deg}°: {inside}"
        );
        assert!(inside.z.abs() < 1e-15 && inside.y > 0.0);
        // The power per unit of the face: E cos θ_i (1 − F) = E_t cos θ_t.
        let expected = theta.cos() * (1.0 - reflectance(theta.cos(), eta));
        assert!(
            (r.factor * inside.y - expected).abs() < 1e-12,
            "{deg}°: {r:?}"
        );
    }
    // From below the face's horizon: nothing.
    assert!(through_face(top, DVec3::new(1.0, -0.1, 0.0).normalize(), 1.33).is_none());
}
