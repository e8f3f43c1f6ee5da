//! A triangle mesh as Wavefront OBJ text: how an imported mesh becomes a scene asset that every
//! spindle process already reads (an `obj` shape names it; the farm uploads it by hash).
//!
//! Coordinates are written with Rust's shortest round-trip formatting, so reading the text
//! back (`str::parse::<f64>`, as tobj does) gives the same bits: the OBJ loses nothing.

use std::fmt::Write;

use glam::DVec3;

/// `v` lines, `vn` lines when `normals` is given (one per vertex), then one `f` line per
/// triangle (1-based; `a//a` when there are normals).
pub fn obj_text(positions: &[DVec3], normals: Option<&[DVec3]>, triangles: &[[u32; 3]]) -> String {
    let mut text = String::with_capacity(32 * (positions.len() * 2 + triangles.len()));
    // Writing to a String cannot fail.
    for p in positions {
        let _ = writeln!(text, "v {} {} {}", p.x, p.y, p.z);
    }
    if let Some(normals) = normals {
        for n in normals {
            let _ = writeln!(text, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| u64::from(i) + 1);
        let _ = if normals.is_some() {
            writeln!(text, "f {a}//{a} {b}//{b} {c}//{c}")
        } else {
            writeln!(text, "f {a} {b} {c}")
        };
    }
    text
}

#[cfg(test)]
mod tests;
