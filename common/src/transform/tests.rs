//! Placements against points worked out by hand.

use super::*;

fn transform(scale: Vec3, rotate_deg: Vec3, translate: Vec3) -> Transform {
    Transform {
        scale,
        rotate_deg,
        translate,
    }
}

fn close(a: Vec3, b: Vec3) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
}

#[test]
fn the_identity_leaves_points_where_they_are() {
    let p = [1.5, -2.0, 3.25];
    assert_eq!(Affine::new(&Transform::default()).point(p), p);
}

#[test]
fn scale_comes_first_then_x_y_z_rotations_then_the_translation() {
    // (1, 0, 0) scaled by 2 along x is (2, 0, 0); 90° about z takes x to y: (0, 2, 0); then +t.
    let a = Affine::new(&transform(
        [2.0, 1.0, 1.0],
        [0.0, 0.0, 90.0],
        [0.0, 0.0, 5.0],
    ));
    assert!(close(a.point([1.0, 0.0, 0.0]), [0.0, 2.0, 5.0]), "{a:?}");
    // 90° about x takes y to z, then 90° about y takes z to x: the x rotation comes first.
    let a = Affine::new(&transform([1.0; 3], [90.0, 90.0, 0.0], [0.0; 3]));
    assert!(close(a.point([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]), "{a:?}");
    // Had y come first, y would stay y under 90° about y and go to z.
    assert!(!close(a.point([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
    // 45° about z: (1, 1, 0) goes to (0, √2, 0).
    let a = Affine::new(&transform([1.0; 3], [0.0, 0.0, 45.0], [0.0; 3]));
    assert!(close(a.point([1.0, 1.0, 0.0]), [0.0, 2f64.sqrt(), 0.0]));
}

#[test]
fn the_matrix_is_rotation_times_scale() {
    // Columns of Rz(90°)·S for S = diag(2, 3, 4): x ↦ 2y, y ↦ −3x, z ↦ 4z.
    let m = Affine::new(&transform([2.0, 3.0, 4.0], [0.0, 0.0, 90.0], [7.0; 3])).columns();
    let expected = [[0.0, 2.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 0.0, 4.0]];
    for (column, want) in m.iter().zip(expected) {
        assert!(close(*column, want), "{m:?}");
    }
}
