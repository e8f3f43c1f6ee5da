use super::*;

fn camera() -> Camera {
    Camera::new(
        &desc::Camera {
            position: [0.0, 0.0, 5.0],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 90.0,
        },
        200,
        100,
    )
    .unwrap()
}

#[test]
fn image_axes_and_field_of_view() {
    let c = camera();
    // The image centre looks at look_at.
    assert!((c.ray(100.0, 50.0).dir - -DVec3::Z).length() < 1e-15);
    // Top edge of the image is 45° up (fov_y = 90°); y grows downward.
    let top = c.ray(100.0, 0.0).dir;
    assert!((top - DVec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-15);
    // Right edge: x grows rightward, aspect 2.
    let right = c.ray(200.0, 50.0).dir;
    assert!((right - DVec3::new(2.0, 0.0, -1.0).normalize()).length() < 1e-15);
}

#[test]
fn bad_cameras_are_rejected() {
    let ok = desc::Camera {
        position: [0.0, 0.0, 5.0],
        look_at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y: 40.0,
    };
    let bad = |c: desc::Camera| Camera::new(&c, 10, 10).unwrap_err().to_string();
    assert!(
        bad(desc::Camera {
            fov_y: 180.0,
            ..ok.clone()
        })
        .starts_with("fov_y")
    );
    assert!(
        bad(desc::Camera {
            up: [0.0, 0.0, 1.0],
            ..ok.clone()
        })
        .starts_with("up")
    );
    assert!(
        bad(desc::Camera {
            look_at: [0.0, 0.0, 5.0],
            ..ok.clone()
        })
        .starts_with("look_at")
    );
    assert!(Camera::new(&ok, 0, 10).is_err());
}
