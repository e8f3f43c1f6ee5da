use glam::{DVec2, DVec3};
use spindle_common::scene::Waves;
use spindle_common::validate::box_triangles;

use super::{WAVES, WaveField, wavy_box};
use crate::mesh::TriangleMesh;

/// The volume a closed, outward-wound mesh encloses (divergence theorem).
fn volume(mesh: &TriangleMesh) -> f64 {
    (0..mesh.triangle_count())
        .map(|i| {
            let [a, b, c] = mesh.corners(i);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn waves(segments: u32) -> Waves {
    Waves {
        amplitude: 0.1,
        wavelength: 4.0,
        seed: 7,
        segments,
    }
}

#[test]
fn a_box_is_closed_wound_outward_and_counted_as_the_coordinator_counts_it() {
    let size = DVec3::new(2.0, 0.8, 1.5);
    let field = WaveField::new(0.1, 4.0, 7);
    for segments in [1, 2, 5, 16] {
        for wavy in [false, true] {
            let spec = wavy.then(|| waves(segments));
            let mesh = wavy_box(size, wavy.then_some((&field, segments)));
            let report = mesh.report();
            assert!(
                report.closed,
                "{segments} segments, wavy {wavy}: {report:?}"
            );
            assert_eq!(report.degenerate, 0);
            let expected = box_triangles(spec.as_ref());
            assert_eq!(mesh.triangle_count() as u64, expected, "{segments}, {wavy}");
            // Every triangle faces the way its vertices' normals do (outward).
            for i in 0..mesh.triangle_count() {
                let g = mesh.geometric_normal(i).normalize();
                for n in mesh.corner_normals(i) {
                    assert!(g.dot(n) > 0.5, "triangle {i}: {g} against {n}");
                }
            }
        }
    }
}

#[test]
fn a_flat_box_has_its_volume_and_sharp_edges() {
    let size = DVec3::new(2.0, 0.8, 1.5);
    let mesh = wavy_box(size, None);
    let v = volume(&mesh);
    assert!((v - 2.4).abs() < 1e-12, "volume {v}");
    let (lo, hi) = mesh.bounds();
    assert_eq!((lo, hi), (-size / 2.0, size / 2.0));
    // Sharp edges: every vertex normal is its face's axis.
    for n in mesh.normals() {
        let axis = n.abs().max_element();
        assert_eq!(axis, 1.0, "normal {n}");
    }
}

/// ∫∫ sin(a x + b z + φ) over [x0, x1] × [z0, z1], in closed form (a, b ≠ 0).
fn sine_integral(k: DVec2, phase: f64, lo: DVec2, hi: DVec2) -> f64 {
    let s = |x: f64, z: f64| (k.x * x + k.y * z + phase).sin();
    -(s(hi.x, hi.y) - s(lo.x, hi.y) - s(hi.x, lo.y) + s(lo.x, lo.y)) / (k.x * k.y)
}

#[test]
fn a_wavy_box_holds_the_volume_of_its_height_field() {
    let size = DVec3::new(2.0, 0.8, 1.5);
    let field = WaveField::new(0.1, 4.0, 7);
    let segments = 256;
    let mesh = wavy_box(size, Some((&field, segments)));
    let (lo, hi) = (DVec2::new(-1.0, -0.75), DVec2::new(1.0, 0.75));
    let waves_integral: f64 = field
        .waves
        .iter()
        .map(|&(k, phase)| sine_integral(k, phase, lo, hi))
        .sum::<f64>()
        * field.amplitude
        / WAVES as f64;
    let truth = size.x * size.y * size.z + waves_integral;
    // Linear interpolation on a triangle of legs dx, dz misses h by at most M (dx² + dz²) / 2,
    // M the largest second derivative: M <= amplitude · max |kᵢ|².
    let m = field.amplitude
        * field
            .waves
            .iter()
            .map(|(k, _)| k.length_squared())
            .fold(0.0, f64::max);
    let (dx, dz) = (size.x / segments as f64, size.z / segments as f64);
    let bound = size.x * size.z * m * (dx * dx + dz * dz) / 2.0;
    let v = volume(&mesh);
    println!(
        "volume {v:.9} against {truth:.9} (waves add {waves_integral:.6}), error {:.2e}, bound {bound:.2e}",
        v - truth
    );
    assert!(
        (v - truth).abs() <= bound,
        "error {} > bound {bound}",
        v - truth
    );
    assert!(
        waves_integral.abs() > 20.0 * bound,
        "the test must see the waves"
    );
}

#[test]
fn the_top_follows_the_field_with_its_normals() {
    let size = DVec3::new(2.0, 0.8, 1.5);
    let field = WaveField::new(0.1, 0.9, 3);
    let segments = 8;
    let mesh = wavy_box(size, Some((&field, segments)));
    let h = 1e-6;
    let mut seen = 0;
    for (p, n) in mesh.positions().iter().zip(mesh.normals()) {
        if n.y <= 0.5 {
            continue;
        }
        seen += 1;
        let q = DVec2::new(p.x, p.z);
        assert!(
            (p.y - (0.4 + field.height(q))).abs() < 1e-15,
            "height at {p}"
        );
        // The normal against central differences of the height.
        let dx = (field.height(q + DVec2::X * h) - field.height(q - DVec2::X * h)) / (2.0 * h);
        let dz = (field.height(q + DVec2::Y * h) - field.height(q - DVec2::Y * h)) / (2.0 * h);
        let expected = DVec3::new(-dx, 1.0, -dz).normalize();
        assert!(
            (*n - expected).length() < 1e-8,
            "normal {n} against {expected} at {p}"
        );
    }
    assert_eq!(seen, 81);
}

#[test]
fn the_field_is_bounded_by_its_amplitude_with_wavelengths_in_range() {
    for seed in 0..20 {
        let field = WaveField::new(0.3, 2.0, seed);
        for (k, _) in field.waves {
            let wavelength = std::f64::consts::TAU / k.length();
            assert!(
                (1.0 - 1e-12..=2.0 + 1e-12).contains(&wavelength),
                "{wavelength}"
            );
        }
        for i in 0..400 {
            let p = DVec2::new(i as f64 * 0.037 - 7.0, i as f64 * 0.091 - 18.0);
            assert!(field.height(p).abs() <= 0.3);
        }
    }
}
