use super::*;

/// Camera at (0, 0, 5) looking at the origin, 90° vertically, a 200 × 100 film: at unit depth
/// the image spans x ∈ [−2, 2], y ∈ [−1, 1]. By hand:
/// - the origin is 5 in front, on the axis: camera (0, 0, 5), NDC (0.5, 0.5), pixel (100, 50);
/// - (1, 1, 4) is 1 in front, 1 right, 1 up: camera (1, 1, 1), NDC (0.5 + 1/4, 0.5 − 1/2) =
///   (0.75, 0), the top edge at pixel x 150;
/// - (−3, −0.5, 2) is 3 in front: camera (−3, −0.5, 3), on the plane at unit depth (−1, −1/6),
///   NDC (0.25, 0.5 + 1/12), pixel (50, 58.33…).
fn camera() -> Camera {
    Camera {
        position: [0.0, 0.0, 5.0],
        look_at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y: 90.0,
    }
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
}

#[test]
fn known_points_land_on_their_hand_computed_pixels() {
    let m = CameraMatrices::of(&camera(), 200, 100).unwrap();
    for (world, in_camera, ndc) in [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 5.0], [0.5, 0.5]),
        ([1.0, 1.0, 4.0], [1.0, 1.0, 1.0], [0.75, 0.0]),
        (
            [-3.0, -0.5, 2.0],
            [-3.0, -0.5, 3.0],
            [0.25, 0.5 + 1.0 / 12.0],
        ),
    ] {
        let c = transform_point(&m.world_to_camera, world);
        assert!(close(c, in_camera), "{world:?} → camera {c:?}");
        let n = transform_point(&m.world_to_ndc, world);
        assert!(
            close(n, [ndc[0], ndc[1], 1.0 / in_camera[2]]),
            "{world:?} → NDC {n:?}"
        );
    }
    // The translation is the last row (row vectors, Imath), written row after row.
    assert_eq!(m.world_to_camera[3], [0.0, 0.0, 5.0, 1.0]);
    let flat = to_m44f(&m.world_to_camera);
    assert_eq!(&flat[12..16], &[0.0, 0.0, 5.0, 1.0]);
    assert_eq!(from_m44f(&flat), m.world_to_camera);
}

/// Camera space is left-handed whatever the scene's orientation: x right, y up, z forward, so
/// (right × up) = −forward in the right-handed world, and the determinant of the rotation is −1.
#[test]
fn camera_space_is_left_handed_with_z_forward() {
    let tilted = Camera {
        position: [2.0, 3.0, -1.0],
        look_at: [0.5, 0.0, 4.0],
        up: [0.3, 1.0, 0.1],
        fov_y: 35.0,
    };
    let m = CameraMatrices::of(&tilted, 64, 48).unwrap();
    let r = &m.world_to_camera;
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    assert!((det + 1.0).abs() < 1e-12, "{det}");
    // The point looked at is straight ahead at its distance, in the middle of the frame.
    let c = transform_point(&m.world_to_camera, tilted.look_at);
    let distance = (1.5f64 * 1.5 + 3.0 * 3.0 + 5.0 * 5.0).sqrt();
    assert!(close(c, [0.0, 0.0, distance]), "{c:?}");
    let n = transform_point(&m.world_to_ndc, tilted.look_at);
    assert!(close(n, [0.5, 0.5, 1.0 / distance]), "{n:?}");
}

#[test]
fn a_camera_the_scene_refuses_has_no_matrices() {
    let mut c = camera();
    c.look_at = c.position;
    assert_eq!(CameraMatrices::of(&c, 10, 10), None);
    let mut c = camera();
    c.up = [0.0, 0.0, 1.0];
    assert_eq!(CameraMatrices::of(&c, 10, 10), None);
    assert_eq!(CameraMatrices::of(&camera(), 0, 10), None);
}
