//! Geometry the whole-scene tests share.

use glam::DVec3;

/// The axis-aligned box `[lo, hi]` as OBJ text, with one normal per face (so the shading normals
/// are exactly the face normals), quads wound counter-clockwise seen from outside. With
/// `open_back` the face at `z = lo.z` (normal −z) is left out.
pub fn box_obj(lo: DVec3, hi: DVec3, open_back: bool) -> String {
    let mut s = String::new();
    for i in 0..8 {
        let x = if i & 1 == 1 { hi.x } else { lo.x };
        let y = if i & 2 == 2 { hi.y } else { lo.y };
        let z = if i & 4 == 4 { hi.z } else { lo.z };
        s += &format!("v {x} {y} {z}\n");
    }
    s += "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n";
    // (normal, quad) with 1-based indices; the back face (z = lo.z) first.
    let faces = [
        (1, [1, 3, 4, 2]),
        (2, [5, 6, 8, 7]),
        (3, [1, 2, 6, 5]),
        (4, [3, 7, 8, 4]),
        (5, [1, 5, 7, 3]),
        (6, [2, 4, 8, 6]),
    ];
    for &(n, q) in &faces[open_back as usize..] {
        s += &format!(
            "f {}//{n} {}//{n} {}//{n} {}//{n}\n",
            q[0], q[1], q[2], q[3]
        );
    }
    s
}
