use glam::DVec3;
use spindle_render::obj::parse_obj_with;

use super::obj_text;

/// Coordinates that do not print exactly in few digits, read back by tobj (the renderer's OBJ
/// reader, an independent parser) to the same bits, with the normals used and the corners in
/// order.
#[test]
fn obj_text_reads_back_to_the_same_bits() {
    let third = 1.0 / 3.0;
    let positions = vec![
        DVec3::new(0.1, -2.5e-7, third),
        DVec3::new(1.0 + f64::EPSILON, 0.2, third),
        DVec3::new(0.3, 123_456.789_012_345_67, -7.0 / 11.0),
        DVec3::new(-0.7, 0.9, 2.0_f64.sqrt()),
    ];
    // Two triangles of an open quad-ish patch, wound alike; normals roughly +z (the winding's).
    let triangles = vec![[0, 1, 2], [0, 2, 3]];
    let normal = (positions[1] - positions[0])
        .cross(positions[2] - positions[0])
        .normalize();
    let normals = vec![normal; 4];
    let text = obj_text(&positions, Some(&normals), &triangles);
    let read = parse_obj_with(text.as_bytes(), None).unwrap();
    assert!(read.normals_given);
    let mesh = read.mesh;
    assert_eq!(mesh.triangle_count(), 2);
    for (i, t) in triangles.iter().enumerate() {
        let corners = mesh.corners(i);
        for k in 0..3 {
            assert_eq!(
                corners[k].to_array().map(f64::to_bits),
                positions[t[k] as usize].to_array().map(f64::to_bits),
                "triangle {i} corner {k}"
            );
        }
        let given = mesh.corner_normals(i);
        for n in given {
            assert!((n - normal).length() < 1e-15, "{n} vs {normal}");
        }
    }
}

#[test]
fn obj_text_without_normals_has_plain_faces() {
    let positions = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let text = obj_text(&positions, None, &[[0, 1, 2]]);
    assert_eq!(text, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let read = parse_obj_with(text.as_bytes(), Some(0.0)).unwrap();
    assert!(!read.normals_given);
    assert_eq!(read.mesh.triangle_count(), 1);
}
