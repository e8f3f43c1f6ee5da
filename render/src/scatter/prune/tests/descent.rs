//! The pruned descent keeps every triangle with a valid path, and yields every triangle when
//! pruning is off.

use glam::DVec3;
use spindle_common::scene::Pruning;
use spindle_common::stats::RenderStats;

use crate::bvh::Bvh;
use crate::medium::{Medium, PhaseFunction};
use crate::procedural::bumpy_sphere;
use crate::scatter::prune::SegmentQuery;
use crate::scatter::prune::beam::BeamBound;
use crate::scatter::prune::beam_table::{BeamTable, Beams};
use crate::scatter::prune::bounds::PruneBounds;
use crate::scatter::prune::descent::{DescentStack, for_each_candidate};
use crate::scatter::triangle::ends::{DepthRange, PathEnds};
use crate::scene::{Dielectric, Material, Object};

fn object() -> Object {
    let mesh = bumpy_sphere(1.0, 3, 0.15, 2.0, 7);
    let triangles: Vec<[DVec3; 3]> = (0..mesh.triangle_count())
        .map(|i| mesh.corners(i))
        .collect();
    let report = mesh.report();
    let bvh = Bvh::build(&triangles);
    Object {
        name: "objects[0]".into(),
        bounds: PruneBounds::build(&mesh, &bvh),
        bvh,
        mesh,
        material: Material::Dielectric(Dielectric {
            eta: 1.5,
            medium: Medium {
                sigma_t: DVec3::ONE,
                sigma_s: DVec3::ONE,
                phase: PhaseFunction::Isotropic,
            },
        }),
        report,
    }
}

/// splitmix64 numbers in [0, 1) for test configurations.
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// Through the whole descent (spindle on BVH nodes, cone on triangles): for valid refraction
/// paths built forward on random triangles of a bumpy sphere (Snell's law at the interpolated
/// normal, sidedness checked), the path's triangle is always a candidate and its trimmed range
/// holds the path's t. The counters add up, and pruning culls most of the tree.
#[test]
fn descent_keeps_every_triangle_with_a_valid_path() {
    let object = object();
    let mesh = &object.mesh;
    let mut state = 11;
    let mut stack = DescentStack::default();
    let mut stats = RenderStats::default();
    let (mut checked, mut tabled_checked) = (0, 0);
    for _ in 0..3000 {
        let triangle = (uniform(&mut state) * mesh.triangle_count() as f64) as usize;
        let (mut a, mut b) = (uniform(&mut state), uniform(&mut state));
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let p = mesh.point(triangle, a, b);
        let normal = mesh.shading_normal(triangle, a, b);
        let eta = 1.5;
        let cos_l = uniform(&mut state).max(1e-6);
        let sin_v = (1.0 - cos_l * cos_l).sqrt() / eta;
        let cos_v = (1.0 - sin_v * sin_v).sqrt();
        let phi = std::f64::consts::TAU * uniform(&mut state);
        let (s, t) = normal.any_orthonormal_pair();
        let d = cos_v * normal + sin_v * (phi.cos() * s + phi.sin() * t);
        let omega_l = (eta * d - (eta * cos_v - cos_l) * normal).normalize();
        let v = p - 0.5 * uniform(&mut state) * d;
        let light = p + (0.1 + 10.0 * uniform(&mut state)) * omega_l;
        let ng = mesh.geometric_normal(triangle).normalize();
        if (light - p).dot(ng) <= 0.0 || (v - p).dot(ng) >= 0.0 {
            continue;
        }
        let dir = DVec3::new(uniform(&mut state) - 0.5, uniform(&mut state) - 0.5, 0.3).normalize();
        let t_v = uniform(&mut state);
        let query = SegmentQuery {
            ends: PathEnds {
                origin: v - t_v * dir,
                dir,
                light,
                eta,
            },
            range: DepthRange {
                lo: 0.0,
                hi: 1.0 + uniform(&mut state),
            },
        };
        let mut found = false;
        let before = stats;
        let mut candidates = Vec::new();
        for_each_candidate(
            &object,
            &query,
            Beams::computed(),
            &Pruning::default(),
            &mut stack,
            &mut stats,
            |c, _| {
                if c.triangle as usize == triangle {
                    assert!(c.range.contains(t_v), "{c:?} misses t = {t_v}");
                    found = true;
                }
                candidates.push(c);
            },
        );
        assert!(
            found,
            "triangle {triangle} culled for a valid path: {query:?}"
        );
        assert!(stats.bvh_nodes_visited > before.bvh_nodes_visited);
        // One query in ten again with the beams from a table built for its light: the same
        // candidates, with the same ranges.
        if checked % 10 == 0 {
            let table = BeamTable::build(&object.bounds, light, eta);
            let beams = Beams::for_ends(Some(&table), &query.ends);
            let mut tabled = Vec::new();
            for_each_candidate(
                &object,
                &query,
                beams,
                &Pruning::default(),
                &mut stack,
                &mut RenderStats::default(),
                |c, _| tabled.push(c),
            );
            assert_eq!(tabled, candidates, "{query:?}");
            tabled_checked += 1;
        }
        checked += 1;
    }
    let nodes = object.bvh.nodes().len() as u64;
    println!(
        "{checked} paths; per query: {:.1} of {nodes} nodes visited, {:.1} culled by the spindle, \
         {:.1} triangles tested, {:.1} culled by the cone",
        stats.bvh_nodes_visited as f64 / checked as f64,
        stats.nodes_culled_spindle as f64 / checked as f64,
        stats.triangles_tested as f64 / checked as f64,
        stats.triangles_culled_cone as f64 / checked as f64,
    );
    assert!(checked > 1000 && tabled_checked > 100);
    assert!(stats.nodes_culled_spindle > 0 && stats.triangles_culled_cone > 0);
    assert!(stats.triangles_tested < checked * mesh.triangle_count() as u64);
}

/// With both stages off, the descent yields every triangle once, with the full range.
#[test]
fn descent_without_pruning_yields_every_triangle() {
    let object = object();
    let query = SegmentQuery {
        ends: PathEnds {
            origin: DVec3::new(0.0, 0.0, -0.5),
            dir: DVec3::Z,
            light: DVec3::new(0.0, 0.0, 5.0),
            eta: 1.5,
        },
        range: DepthRange { lo: 0.0, hi: 1.0 },
    };
    let off = Pruning {
        spindle: false,
        cone: false,
        plane: false,
    };
    let mut seen = vec![0; object.mesh.triangle_count()];
    let mut stats = RenderStats::default();
    for_each_candidate(
        &object,
        &query,
        Beams::computed(),
        &off,
        &mut DescentStack::default(),
        &mut stats,
        |c, _| {
            assert_eq!((c.range.lo, c.range.hi), (0.0, 1.0));
            seen[c.triangle as usize] += 1;
        },
    );
    assert!(seen.iter().all(|&n| n == 1));
    assert_eq!(stats.triangles_tested, object.mesh.triangle_count() as u64);
}

/// A beam table serves only the light point and η it was built for: a query with another light
/// or η computes its beams (a table used for another light would cull that light's solutions).
#[test]
fn a_beam_table_serves_only_its_own_light_and_eta() {
    let object = object();
    let light = DVec3::new(0.3, -0.2, 4.0);
    let table = BeamTable::build(&object.bounds, light, 1.5);
    assert_eq!(
        table.len(),
        object.bounds.nodes().len() + object.bounds.triangles().len()
    );
    let ends = |light, eta| PathEnds {
        origin: DVec3::new(0.0, 0.0, -0.5),
        dir: DVec3::Z,
        light,
        eta,
    };
    assert!(table.serves(&ends(light, 1.5)));
    assert!(!table.serves(&ends(light + DVec3::splat(1e-12), 1.5)));
    assert!(!table.serves(&ends(light, 1.5 + 1e-12)));
    // Built for a light at the far side, the table's beams differ from a near-side light's;
    // `for_ends` does not hand the table over to that light's queries.
    let near = DVec3::new(0.0, 0.0, -4.0);
    let differs = (0..object.bounds.nodes().len() as u32).any(|i| {
        let node = object.bounds.node(i);
        node.cone
            .is_some_and(|cone| table.node(i) != BeamBound::of(near, 1.5, node.sphere, cone))
    });
    assert!(differs);
    let query = SegmentQuery {
        ends: ends(near, 1.5),
        range: DepthRange { lo: 0.0, hi: 1.0 },
    };
    let count = |beams| {
        let mut n = 0;
        for_each_candidate(
            &object,
            &query,
            beams,
            &Pruning::default(),
            &mut DescentStack::default(),
            &mut RenderStats::default(),
            |_, _| n += 1,
        );
        n
    };
    let computed = count(Beams::computed());
    assert!(computed > 0);
    assert_eq!(count(Beams::for_ends(Some(&table), &query.ends)), computed);
}
