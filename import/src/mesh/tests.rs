use gltf::mesh::Mode;

use super::triangulate;

/// The glTF 2.0 specification, §3.7.2.1: strips alternate winding so every triangle faces the
/// same way; fans pivot on the first vertex.
#[test]
fn strips_and_fans_follow_the_specification() {
    assert_eq!(
        triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]).unwrap(),
        vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
    );
    assert_eq!(
        triangulate(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(),
        vec![[1, 2, 0], [2, 3, 0]]
    );
    assert_eq!(
        triangulate(Mode::Triangles, &[0, 1, 2, 2, 1, 3]).unwrap(),
        vec![[0, 1, 2], [2, 1, 3]]
    );
    // A strip's degenerate join (a repeated index) is no triangle.
    assert_eq!(
        triangulate(Mode::TriangleStrip, &[0, 1, 2, 2, 3]).unwrap(),
        vec![[0, 1, 2]]
    );
    assert_eq!(triangulate(Mode::Triangles, &[0, 1, 2, 3]), None);
}
