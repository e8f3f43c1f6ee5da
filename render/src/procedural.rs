//! Procedural meshes: the icosphere and the bumpy sphere (the classic test object of this field).
//!
//! Both start from the icosahedron and split every triangle into four, `s` times (20·4^s
//! triangles), with a midpoint cache keyed by edge so shared edges share vertices and the mesh is
//! closed. Subdividing to millions of triangles takes a fraction of a second.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::TriangleMesh;

/// The most subdivisions accepted (20·4^11 ≈ 84 million triangles would not fit a worker's memory).
pub const MAX_SUBDIVISIONS: u32 = 10;

/// Unit-sphere vertices and outward-wound triangles of an icosahedron subdivided `s` times.
fn unit_icosphere(subdivisions: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions.min(MAX_SUBDIVISIONS) {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 2);
        let mut next = Vec::with_capacity(triangles.len() * 4);
        let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(p);
                positions.len() as u32 - 1
            })
        };
        for &[a, b, c] in &triangles {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (positions, triangles)
}

/// An icosphere of `radius` centred at the origin: 20·4^s triangles, vertex normals exactly
/// the normalised positions. `subdivisions` is capped at [`MAX_SUBDIVISIONS`].
pub fn icosphere(radius: f64, subdivisions: u32) -> TriangleMesh {
    let (unit, triangles) = unit_icosphere(subdivisions);
    let positions = unit.iter().map(|&p| p * radius).collect();
    TriangleMesh::new(positions, Some(unit), triangles)
        .expect("an icosphere of finite radius is a valid mesh")
}

/// Smooth noise on the sphere in [-1, 1]: the mean of six sinusoids `sin(F·kᵢ·q + φᵢ)` with
/// seeded unit directions `kᵢ`, wave numbers in [1, 2) and phases.
#[derive(Debug, Clone)]
pub struct SphereNoise {
    waves: [(DVec3, f64); 6],
}

impl SphereNoise {
    pub fn new(frequency: f64, seed: u64) -> SphereNoise {
        let mut rng = crate::sampler::Sampler::new(seed, u32::MAX, u32::MAX, u32::MAX);
        let waves = std::array::from_fn(|_| {
            let z = 2.0 * rng.next_f64() - 1.0;
            let a = 2.0 * std::f64::consts::PI * rng.next_f64();
            let r = (1.0 - z * z).sqrt();
            let k = DVec3::new(r * a.cos(), r * a.sin(), z) * frequency * (1.0 + rng.next_f64());
            (k, 2.0 * std::f64::consts::PI * rng.next_f64())
        });
        SphereNoise { waves }
    }

    /// The noise at unit direction `q`.
    pub fn at(&self, q: DVec3) -> f64 {
        self.waves
            .iter()
            .map(|(k, phase)| (k.dot(q) + phase).sin())
            .sum::<f64>()
            / 6.0
    }
}

/// A bumpy sphere: the icosphere with each vertex moved to radius
/// `radius · (1 + amplitude · noise(frequency · p̂, seed))`; normals angle-weighted from the
/// displaced mesh. `|amplitude| < 1` keeps every radius positive (checked by the caller).
pub fn bumpy_sphere(
    radius: f64,
    subdivisions: u32,
    amplitude: f64,
    frequency: f64,
    seed: u64,
) -> TriangleMesh {
    let (unit, triangles) = unit_icosphere(subdivisions);
    let noise = SphereNoise::new(frequency, seed);
    let positions = unit
        .iter()
        .map(|&q| q * radius * (1.0 + amplitude * noise.at(q)))
        .collect();
    TriangleMesh::new(positions, None, triangles)
        .expect("a bumpy sphere of finite radius is a valid mesh")
}

#[cfg(test)]
mod tests;
