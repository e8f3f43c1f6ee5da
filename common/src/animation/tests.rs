use super::*;
use crate::camera_matrices::CameraMatrices;
use crate::transform::Affine;
use glam::{DMat3, DVec3};
use serde_json::json;

fn track<V>(interpolation: Interpolation, keys: &[(f64, V)]) -> Track<V>
where
    V: Copy,
{
    Track {
        interpolation,
        keys: keys
            .iter()
            .map(|&(frame, value)| Key { frame, value })
            .collect(),
    }
}

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance
}

#[test]
fn linear_midpoints_and_thirds() {
    let t = track(
        Interpolation::Linear,
        &[(0.0, [0.0, 0.0, 0.0]), (10.0, [2.0, 4.0, -6.0])],
    );
    assert_eq!(sample(&t, 5.0), [1.0, 2.0, -3.0]);
    let third = sample(&t, 10.0 / 3.0);
    assert!(close(third[1], 4.0 / 3.0, 1e-15), "{third:?}");
    assert_eq!(sample(&t, 0.0), [0.0, 0.0, 0.0]);
    assert_eq!(sample(&t, 10.0), [2.0, 4.0, -6.0]);
}

#[test]
fn frames_outside_the_keys_hold_the_end_values() {
    let t = track(
        Interpolation::Smooth,
        &[(2.0, 1.0), (4.0, 3.0), (9.0, -1.0)],
    );
    assert_eq!(sample(&t, 0.0), 1.0);
    assert_eq!(sample(&t, -50.0), 1.0);
    assert_eq!(sample(&t, 9.0), -1.0);
    assert_eq!(sample(&t, 1000.0), -1.0);
}

#[test]
fn step_holds_each_key_until_the_next() {
    let t = track(
        Interpolation::Step,
        &[(1.0, 10.0), (3.0, 20.0), (6.0, 30.0)],
    );
    assert_eq!(sample(&t, 1.0), 10.0);
    assert_eq!(sample(&t, 2.999), 10.0);
    assert_eq!(sample(&t, 3.0), 20.0);
    assert_eq!(sample(&t, 5.5), 20.0);
    assert_eq!(sample(&t, 6.0), 30.0);
}

#[test]
fn smooth_passes_through_its_keys_with_the_stated_slopes() {
    // Keys (0, 0), (2, 4), (6, 12): the slope at the middle key is the chord of its
    // neighbours, (12 − 0) / (6 − 0) = 2 per frame; zero at the ends.
    let t = track(
        Interpolation::Smooth,
        &[(0.0, 0.0), (2.0, 4.0), (6.0, 12.0)],
    );
    for (frame, value) in [(0.0, 0.0), (2.0, 4.0), (6.0, 12.0)] {
        assert_eq!(sample(&t, frame), value);
    }
    let derivative = |f: f64| (sample(&t, f + 1e-6) - sample(&t, f - 1e-6)) / 2e-6;
    assert!(close(derivative(2.0), 2.0, 1e-6), "{}", derivative(2.0));
    let start = (sample(&t, 1e-6) - sample(&t, 0.0)) / 1e-6;
    let end = (sample(&t, 6.0) - sample(&t, 6.0 - 1e-6)) / 1e-6;
    assert!(
        close(start, 0.0, 1e-5) && close(end, 0.0, 1e-5),
        "{start} {end}"
    );
    // Halfway through the first segment, by hand: h = 2, s = 1/2, h00 = h01 = 1/2, h10 = 1/8,
    // h11 = −1/8: 0·½ + 4·½ + 2·0·⅛ + 2·2·(−⅛) = 1.5.
    assert_eq!(sample(&t, 1.0), 1.5);
}

#[test]
fn smooth_stays_in_the_hull_of_its_control_points() {
    let t = track(
        Interpolation::Smooth,
        &[(0.0, 0.0), (1.0, 10.0), (2.0, -3.0), (7.0, 4.0)],
    );
    let hull = hull_points(&t);
    assert_eq!(hull.len(), 4 + 2 * 3);
    for i in 0..=700 {
        let f = f64::from(i) / 100.0;
        let v = sample(&t, f);
        // Within the segment's own four Bézier points.
        let segment = place(&t.keys, f);
        let i = match segment {
            Place::Key(_) => continue,
            Place::Between { i, .. } => i,
        };
        let points = [hull[i], hull[4 + 2 * i], hull[4 + 2 * i + 1], hull[i + 1]];
        let (lo, hi) = points
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &p| (l.min(p), h.max(p)));
        assert!(
            lo - 1e-12 <= v && v <= hi + 1e-12,
            "frame {f}: {v} not in [{lo}, {hi}]"
        );
    }
}

#[test]
fn slerp_of_a_quarter_turn_at_one_half_is_an_eighth_turn() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let t = track(
        Interpolation::Linear,
        &[(0.0, [0.0, 0.0, 0.0, 1.0]), (10.0, [0.0, h, 0.0, h])],
    );
    let q = sample_rotation(&t, 5.0);
    let half = 22.5_f64.to_radians();
    assert!(
        close(q.y, half.sin(), 1e-15) && close(q.w, half.cos(), 1e-15),
        "{q:?}"
    );
    assert!(close(q.x, 0.0, 1e-15) && close(q.z, 0.0, 1e-15), "{q:?}");
    let deg = rotate_deg(q);
    assert!(close(deg[1], 45.0, 1e-12) && close(deg[0], 0.0, 1e-12) && close(deg[2], 0.0, 1e-12));
    // Keys not of unit length, and the second written as its negative: the same rotations.
    let t = track(
        Interpolation::Linear,
        &[(0.0, [0.0, 0.0, 0.0, 3.0]), (10.0, [0.0, -2.0, 0.0, -2.0])],
    );
    let q = sample_rotation(&t, 5.0);
    assert!(
        close(q.y, half.sin(), 1e-15) && close(q.w, half.cos(), 1e-15),
        "{q:?}"
    );
}

#[test]
fn smooth_rotation_passes_through_its_keys() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let keys = [
        (0.0, [0.0, 0.0, 0.0, 1.0]),
        (4.0, [0.0, h, 0.0, h]),
        (8.0, [0.0, 1.0, 0.0, 0.0]),
    ];
    let t = track(Interpolation::Smooth, &keys);
    for (frame, q) in keys {
        let got = sample_rotation(&t, frame);
        assert!(
            got.abs_diff_eq(DQuat::from_array(q), 1e-15),
            "{frame}: {got:?}"
        );
    }
    // About one axis the curve stays about it, and at the middle of a symmetric track it is
    // the middle rotation.
    let q = sample_rotation(&t, 2.0);
    assert!(close(q.x, 0.0, 1e-15) && close(q.z, 0.0, 1e-15));
    assert!(close(q.length(), 1.0, 1e-15));
}

/// `rotate_deg` of a quaternion gives, through the scene transform's own arithmetic, the
/// quaternion's rotation matrix (glam's), gimbal lock included.
#[test]
fn euler_angles_rebuild_the_rotation() {
    let cases = [
        DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.1),
        DQuat::from_axis_angle(DVec3::new(-0.3, 0.1, 0.9).normalize(), -2.9),
        DQuat::from_axis_angle(DVec3::Y, std::f64::consts::FRAC_PI_2),
        DQuat::from_axis_angle(DVec3::Y, -std::f64::consts::FRAC_PI_2)
            * DQuat::from_axis_angle(DVec3::X, 0.7),
        DQuat::IDENTITY,
    ];
    for q in cases {
        let transform = Transform {
            rotate_deg: rotate_deg(q),
            ..Transform::default()
        };
        let columns = Affine::new(&transform).columns();
        let expected = DMat3::from_quat(q);
        for (c, column) in columns.iter().enumerate() {
            let want = expected.col(c);
            for (r, x) in column.iter().enumerate() {
                assert!(
                    close(*x, want[r], 1e-12),
                    "{q:?}: column {c}: {column:?} vs {want:?}"
                );
            }
        }
    }
}

fn orbit_scene() -> SceneDescription {
    SceneDescription::from_json(
        &json!({
            "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 90 },
            "film": { "width": 100, "height": 100, "spp": 1 },
            "lights": [ { "type": "point", "position": [0, 4, 0], "intensity": [1, 1, 1] } ],
            "objects": [ {
                "shape": { "type": "icosphere", "radius": 1, "subdivisions": 1 },
                "material": { "type": "diffuse", "reflectance": [0.5, 0.5, 0.5] }
            } ],
            "animation": {
                "frames": { "start": 0, "end": 10 },
                "camera": { "position": { "keys": [
                    { "frame": 0, "value": [0, 0, 5] }, { "frame": 10, "value": [5, 0, 0] } ] } },
                "objects": [ { "object": 0,
                    "translate": { "keys": [
                        { "frame": 0, "value": [0, 0, 0] }, { "frame": 4, "value": [0, 2, 0] } ] } } ],
                "lights": [ { "light": 0, "position": { "interpolation": "step", "keys": [
                    { "frame": 0, "value": [0, 4, 0] }, { "frame": 6, "value": [1, 4, 0] } ] } } ]
            }
        })
        .to_string(),
    )
    .unwrap()
}

#[test]
fn a_point_projects_to_the_hand_computed_pixel_at_a_frame() {
    let scene = orbit_scene();
    let still = scene.at_frame(5);
    assert_eq!(still.animation, None);
    still.validate().unwrap();
    // At frame 5 the camera is halfway: (2.5, 0, 2.5), looking at the origin. The point
    // (0, 1, 0) is at depth 5/√2 along the view and 1 above it: with fov_y 90° (tan 45° = 1)
    // on a 100-pixel film its row is 50 − 50 · (1 / (5/√2)) = 50 − 10√2, its column 50.
    assert_eq!(still.camera.position, [2.5, 0.0, 2.5]);
    let m = CameraMatrices::of(&still.camera, 100, 100)
        .unwrap()
        .world_to_ndc;
    let p = [0.0, 1.0, 0.0, 1.0];
    let row = |j: usize| (0..4).map(|i| p[i] * m[i][j]).sum::<f64>();
    let (x, y) = (row(0) / row(3) * 100.0, row(1) / row(3) * 100.0);
    assert!(close(x, 50.0, 1e-9), "{x}");
    assert!(close(y, 50.0 - 10.0 * 2f64.sqrt(), 1e-9), "{y}");
    // The object's translation is held after its last key, the step light has not moved yet.
    assert_eq!(still.objects[0].transform.translate, [0.0, 2.0, 0.0]);
    let Light::Point { position, .. } = still.lights[0] else {
        panic!("a point light")
    };
    assert_eq!(position, [0.0, 4.0, 0.0]);
    let Light::Point { position, .. } = scene.at_frame(6).lights[0] else {
        panic!("a point light")
    };
    assert_eq!(position, [1.0, 4.0, 0.0]);
}

#[test]
fn a_still_is_its_own_every_frame_and_keeps_its_bytes() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/tiny.json"))
        .unwrap();
    let scene = SceneDescription::from_json(&text).unwrap();
    assert_eq!(scene.at_frame(1), scene);
    assert_eq!(scene.at_frame(999), scene);
    assert_eq!(scene.frame_range(), DEFAULT_FRAMES);
    // Serialised without any time field.
    assert!(!serde_json::to_string(&scene).unwrap().contains("animation"));
}

#[test]
fn every_frame_of_a_valid_scene_is_a_valid_still() {
    let scene = orbit_scene();
    assert_eq!(scene.frame_range(), FrameRange { start: 0, end: 10 });
    for frame in 0..=12 {
        scene.at_frame(frame).validate().unwrap();
    }
}
