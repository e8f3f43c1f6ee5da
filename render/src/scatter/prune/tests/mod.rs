//! The proofs that pruning is conservative: refraction paths built forward (valid by
//! construction, including grazing exits) are never discarded by the tests, the bounds or the
//! descent; and the tests do cull what cannot refract.

mod beam;
mod bounds;
mod cull;
mod descent;

use glam::DVec3;

use crate::scatter::prune::SegmentQuery;
use crate::scatter::triangle::ends::{DepthRange, PathEnds};

/// A small deterministic generator for test configurations (splitmix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if let Some(u) = v.try_normalize().filter(|_| v.length() <= 1.0) {
                return u;
            }
        }
    }
}

/// An orthonormal pair perpendicular to a unit vector.
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let s = n.any_orthonormal_vector();
    (s, n.cross(s))
}

/// A valid refraction path, built forward so its validity needs no solver: a triangle with
/// curved shading normals, a point P on it, the shading normal there, an inside direction and
/// the refracted outside direction by Snell's law (physics.md §0: `ω_L = η d − μ N̂s`), with the
/// sidedness conditions of physics.md §2.5 item 3 checked.
struct ValidPath {
    p: [DVec3; 3],
    n: [DVec3; 3],
    /// The refraction point, on the triangle.
    point: DVec3,
    v: DVec3,
    l: DVec3,
    eta: f64,
}

fn valid_path(rng: &mut Rng) -> Option<ValidPath> {
    let scale = 10f64.powf(rng.range(-3.0, 3.0));
    let offset = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0) * scale * 5.0;
    let p = [
        offset
            + scale
                * DVec3::new(
                    rng.range(-1.5, -0.5),
                    rng.range(-1.0, 0.0),
                    rng.range(-0.1, 0.1),
                ),
        offset
            + scale
                * DVec3::new(
                    rng.range(0.5, 1.5),
                    rng.range(-1.0, 0.0),
                    rng.range(-0.1, 0.1),
                ),
        offset
            + scale
                * DVec3::new(
                    rng.range(-0.5, 0.5),
                    rng.range(0.5, 1.5),
                    rng.range(-0.1, 0.1),
                ),
    ];
    let ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    let tilt = rng.range(0.0, 0.6);
    let n = [0, 1, 2].map(|_| (ng + tilt * rng.unit()).normalize());
    let etas = [1.0, 1.0 + 1e-6, 1.001, 1.33, 1.5, 2.42, 4.0];
    let eta = etas[(rng.next() * etas.len() as f64) as usize % etas.len()];
    // A point in the triangle (occasionally on an edge) and its shading normal.
    let (mut a, mut b) = (rng.next(), rng.next());
    if a + b > 1.0 {
        (a, b) = (1.0 - a, 1.0 - b);
    }
    if rng.next() < 0.1 {
        b = 0.0;
    }
    let point = p[0] + a * (p[1] - p[0]) + b * (p[2] - p[0]);
    let normal = (n[0] + a * (n[1] - n[0]) + b * (n[2] - n[0])).normalize();
    // The exit cosine, often grazing, then the inside cosine from Snell's law.
    let cos_l = if rng.next() < 0.3 {
        10f64.powf(rng.range(-6.0, -1.0))
    } else {
        rng.next()
    };
    let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
    let cos_v = (1.0 - sin_v * sin_v).sqrt();
    let phi = rng.range(0.0, std::f64::consts::TAU);
    let (s, t) = basis(normal);
    let tangent = phi.cos() * s + phi.sin() * t;
    // d is the direction V → P (outward); ω_V = −d.
    let d = cos_v * normal + sin_v * tangent;
    let mu = eta * cos_v - cos_l;
    let omega_l = (eta * d - mu * normal).normalize();
    let v = point - scale * rng.range(0.01, 3.0) * d;
    let l = point + scale * 10f64.powf(rng.range(-2.0, 3.0)) * omega_l;
    // Sidedness against the geometric normal too (physics.md §2.5 item 3).
    if (l - point).dot(ng) <= 0.0 || (v - point).dot(ng) >= 0.0 {
        return None;
    }
    Some(ValidPath {
        p,
        n,
        point,
        v,
        l,
        eta,
    })
}

/// A segment through `v`, with `v` at a random `t` of `[t_lo, t_hi]` (or the single point).
fn segment_through(rng: &mut Rng, path: &ValidPath) -> (SegmentQuery, f64) {
    let scale = path.p[1].distance(path.p[0]);
    let dir = rng.unit();
    let t_v = rng.range(0.0, 3.0) * scale;
    let length = if rng.next() < 0.2 {
        0.0
    } else {
        rng.range(0.0, 3.0) * scale
    };
    let t_lo = (t_v - rng.next() * length).max(0.0);
    let t_hi = t_lo.max(t_v) + rng.next() * length;
    let query = SegmentQuery {
        ends: PathEnds {
            origin: path.v - t_v * dir,
            dir,
            light: path.l,
            eta: path.eta,
        },
        range: DepthRange {
            lo: t_lo.min(t_v),
            hi: t_hi.max(t_v),
        },
    };
    (query, t_v)
}
