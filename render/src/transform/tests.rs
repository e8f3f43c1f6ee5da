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

#[test]
fn the_matrix_and_the_placed_points_are_the_bits_of_glams_own_construction() {
    // Rz·Ry·Rx·S built with glam, as the renderer did before it took its matrix from
    // `Affine`: the same bits, so no pixel moved; and `Affine::point`, which the coordinator's
    // extent check uses, lands every vertex where the renderer does.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = |lo: f64, hi: f64| {
        // splitmix64
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        lo + (hi - lo) * (z >> 11) as f64 / (1u64 << 53) as f64
    };
    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
    for _ in 0..2000 {
        let scale =
            [0; 3].map(|_| uniform(0.1, 5.0) * if uniform(0.0, 1.0) < 0.3 { -1.0 } else { 1.0 });
        let desc = desc::Transform {
            scale,
            rotate_deg: [0; 3].map(|_| uniform(-400.0, 400.0)),
            translate: [0; 3].map(|_| uniform(-1e5, 1e5)),
        };
        let rot = DVec3::from_array(desc.rotate_deg);
        let glam = DMat3::from_rotation_z(rot.z.to_radians())
            * DMat3::from_rotation_y(rot.y.to_radians())
            * DMat3::from_rotation_x(rot.x.to_radians())
            * DMat3::from_diagonal(DVec3::from_array(scale));
        let t = Transform::new(&desc).unwrap();
        assert_eq!(
            t.linear.to_cols_array().map(f64::to_bits),
            glam.to_cols_array().map(f64::to_bits),
            "{desc:?}"
        );
        let p = DVec3::new(uniform(-1e3, 1e3), uniform(-1e3, 1e3), uniform(-1e3, 1e3));
        let placed = glam * p + DVec3::from_array(desc.translate);
        assert_eq!(bits(t.point(p)), bits(placed), "{desc:?} {p}");
        assert_eq!(
            bits(DVec3::from_array(Affine::new(&desc).point(p.to_array()))),
            bits(placed),
            "{desc:?} {p}"
        );
    }
}
