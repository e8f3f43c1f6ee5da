use super::*;

#[test]
fn order_is_scale_then_rotate_xyz_then_translate() {
    let t = Transform::new(&desc::Transform {
        scale: [2.0, 1.0, 1.0],
        rotate_deg: [90.0, 90.0, 0.0],
        translate: [0.0, 0.0, 10.0],
    })
    .unwrap();
    // (1,0,0) → scale (2,0,0) → Rx(90) (2,0,0) → Ry(90) (0,0,-2) → translate (0,0,8).
    assert!((t.point(DVec3::X) - DVec3::new(0.0, 0.0, 8.0)).length() < 1e-12);
    // (0,1,0) → (0,1,0) → Rx(90) (0,0,1) → Ry(90) (1,0,0) → (1,0,10).
    assert!((t.point(DVec3::Y) - DVec3::new(1.0, 0.0, 10.0)).length() < 1e-12);
}

#[test]
fn normals_stay_perpendicular_under_non_uniform_scale() {
    let t = Transform::new(&desc::Transform {
        scale: [3.0, 0.5, 1.0],
        rotate_deg: [10.0, 20.0, 30.0],
        translate: [1.0, 2.0, 3.0],
    })
    .unwrap();
    // A tangent plane spanned by u, v with normal u × v.
    let (u, v) = (DVec3::new(1.0, 2.0, 0.5), DVec3::new(-0.3, 0.2, 1.0));
    let n = t.normal(u.cross(v).normalize());
    let (tu, tv) = (
        t.point(u) - t.point(DVec3::ZERO),
        t.point(v) - t.point(DVec3::ZERO),
    );
    assert!(n.dot(tu).abs() < 1e-12 && n.dot(tv).abs() < 1e-12);
    assert!(n.dot(tu.cross(tv)) > 0.0);
}

#[test]
fn zero_scale_is_rejected() {
    let e = Transform::new(&desc::Transform {
        scale: [1.0, 0.0, 1.0],
        ..Default::default()
    })
    .unwrap_err();
    assert!(e.to_string().starts_with("scale:"));
}
