//! Degenerate configurations of the single-scattering search (issue 32, part 4): symmetric
//! set-ups that users build first — camera, light and object centre on one line; a camera or
//! light exactly on the surface, on a vertex or an edge; a camera segment exactly along the
//! vertex line of the solutions; η → 1; grazing light and grazing camera segments. Each is
//! compared with an independent estimator (point sampling: a fixed-t solve at stratified depths,
//! which shares none of the interval method's edge scans, boundary points and traced arcs) or
//! with a closed form (physics.md §4), with tolerances from the estimators' own noise.
//!
//! Run: `cargo test -p spindle-render --test degenerate -- --nocapture` (prints every error).

#[path = "support/segment.rs"]
mod segment_support;

use glam::DVec3;
use segment_support::{segment_to_surface, single_scatter_mean};
use serde_json::{Value, json};
use spindle_common::tile::TileRect;
use spindle_render::scatter::describe_plan;
use spindle_render::segment::Segment;
use spindle_render::{Assets, Scene, render_tile};

/// A unit icosphere (3 subdivisions: a vertex at each pole (0, 0, ±1), vertex normals exactly
/// radial) of glass, σ_t = 1, albedo 0.9, seen from `camera` looking at the centre, lit by a
/// point light at `light`, with the single-scattering settings `ss`.
fn glass_ball(camera: DVec3, light: DVec3, eta: f64, ss: Value) -> Scene {
    let desc = serde_json::from_value(json!({
        "camera": {"position": camera.to_array(), "look_at": [0, 0, 0], "up": [0, 1, 0],
                   "fov_y": 60},
        "film": {"width": 8, "height": 8, "spp": 1},
        "lights": [{"type": "point", "position": light.to_array(), "intensity": [10, 10, 10]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
            "material": {"type": "dielectric", "eta": eta,
                "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}],
        "integrator": {"single_scatter": ss}
    }))
    .expect("test scene parses");
    Scene::build(&desc, &Assets::new()).expect("test scene builds")
}

/// The red channel of the single-scattering layer of the whole 8×8 film, pixel by pixel.
fn image(scene: &Scene) -> Vec<f64> {
    let rect = TileRect {
        x: 0,
        y: 0,
        width: 8,
        height: 8,
    };
    let tile = render_tile(scene, rect);
    assert!(tile.single_scatter.iter().all(|v| v.is_finite()));
    tile.single_scatter
        .chunks(3)
        .map(|rgb| f64::from(rgb[0]))
        .collect()
}

/// The interval method (K = `k`, midpoint rule) against point sampling (M = 256) on the 8×8
/// image of the glass ball of index `eta` from `camera` with the light at `light`: (relative
/// error of the image's mean, largest relative error of a pixel).
fn interval_against_points(camera: DVec3, light: DVec3, eta: f64, k: u32) -> (f64, f64) {
    let interval = image(&glass_ball(
        camera,
        light,
        eta,
        json!({"method": "interval", "k": k}),
    ));
    let points = image(&glass_ball(
        camera,
        light,
        eta,
        json!({"method": "point_sampling", "samples_per_segment": 256}),
    ));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let worst = interval
        .iter()
        .zip(&points)
        .map(|(i, p)| (i / p - 1.0).abs())
        .fold(0.0, f64::max);
    (mean(&interval) / mean(&points) - 1.0, worst)
}

/// The scene: the camera inside the glass ball on the line through its centre and the
/// light. The path along that line refracts at the pole vertex (0, 0, −1), so the camera point
/// V(0) is reached through a vertex: the curve of every triangle of the vertex's fan starts
/// there, on two edges at once, and was traced twice from the triangle it enters (29 % too
/// bright). A camera 10⁻⁶ off the line puts that point 10⁻⁶ from the vertex, inside one
/// triangle; there the traced arc's chord left the region through an edge the curve misses (it
/// leaves through the range end t = 0 beside the corner), the edge solve failed and the arc was
/// traced again from its real end (21 % too bright on two pixels).
///
/// Measured after the fix: image means within 4e-5 of point sampling, every pixel within 7e-3
/// (point sampling's own noise at M = 256); asserted 2e-3 and 2e-2.
#[test]
fn camera_on_the_light_axis_inside_the_ball() {
    let light = DVec3::new(0.0, 0.0, -4.0);
    for camera in [DVec3::new(0.0, 0.0, 0.5), DVec3::new(1e-6, 0.0, 0.5)] {
        let (mean, worst) = interval_against_points(camera, light, 1.5, 1);
        println!("camera {camera}: image mean {mean:+.2e}, worst pixel {worst:.2e}");
        assert!(
            mean.abs() < 2e-3,
            "camera {camera}: image mean off by {mean}"
        );
        assert!(worst < 2e-2, "camera {camera}: a pixel off by {worst}");
    }
}

/// More images of the same line: the camera exactly on the surface at the pole vertex (0, 0, 1)
/// (inside: the surface holds the medium); the camera outside the ball on the line with the
/// light between it and the ball; and the light's axial caustic inside the ball (η = 4: the rays
/// through the pole's ring of incidence cross the axis within the ball), seen across from the
/// side, so that camera rays pass through and beside it. K = 8: with the light just in front of
/// the ball, K = 1's midpoint rule is 3.3 % dark on this film, and 1.9 % with the light 0.36 off
/// the line; at K = 8, 1.2e-3 and 5.7e-4: a quadrature bias, which K removes.
///
/// Not here: the camera outside on the line looking at the light through the ball (camera
/// (0, 0, 5), light (0, 0, −4)), where the interval method (K = 64) is 5.2e-3 brighter than point
/// sampling at M = 4096 on the image and up to 3 % on a pixel (2.3e-3 and 1 % with the light
/// 0.36 off the line): point sampling keeps one solution per triangle and loses the second near
/// a fold, which this view is full of; only the brute-force reference can decide, and it is too
/// slow for a test of this size.
#[test]
fn symmetric_images() {
    for (camera, light, eta) in [
        (DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -4.0), 1.5),
        (DVec3::new(0.0, 0.0, 5.0), DVec3::new(0.0, 0.0, 3.0), 1.5),
        (DVec3::new(4.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -4.0), 4.0),
    ] {
        let (mean, worst) = interval_against_points(camera, light, eta, 8);
        println!(
            "camera {camera}, light {light}, eta {eta}: image mean {mean:+.2e}, worst pixel \
             {worst:.2e}"
        );
        assert!(
            mean.abs() < 2e-3,
            "camera {camera}: image mean off by {mean}"
        );
        assert!(worst < 2e-2, "camera {camera}: a pixel off by {worst}");
    }
}

/// The segment of the ball from `origin` (inside it or on its surface) along `dir` to the
/// surface: the boundary is looked for from 0.1 along it, so an origin on the surface is not
/// taken for the segment's end.
fn segment(scene: &Scene, origin: DVec3, dir: DVec3) -> Segment {
    let dir = dir.normalize();
    let far = segment_to_surface(scene, origin + 0.1 * dir, dir);
    Segment {
        origin,
        length: far.length + 0.1,
        ..far
    }
}

/// The interval method, jittered with K = 2: unbiased, so its camera samples' spread is its noise.
fn interval() -> Value {
    json!({"method": "interval", "k": 2, "jitter": true})
}

/// An estimator (`tested`, the single-scattering settings) on one camera segment of the glass
/// ball, and point sampling (M = 64) on the `reference` segment, over `n` camera samples each:
/// `(tested, its stderr, points, its stderr)`.
fn on_segment(
    tested: Value,
    light: DVec3,
    eta: f64,
    (origin, dir): (DVec3, DVec3),
    reference: (DVec3, DVec3),
    n: u32,
) -> (f64, f64, f64, f64) {
    let camera = DVec3::new(0.0, 0.0, 5.0);
    let interval = glass_ball(camera, light, eta, tested);
    let points = glass_ball(
        camera,
        light,
        eta,
        json!({"method": "point_sampling", "samples_per_segment": 64}),
    );
    let seg = segment(&interval, origin, dir);
    let reference_seg = segment(&points, reference.0, reference.1);
    let (i, i_err) = single_scatter_mean(&interval, &seg, n, (1, 2, 3));
    let (p, p_err) = single_scatter_mean(&points, &reference_seg, n, (4, 5, 6));
    (i, i_err, p, p_err)
}

/// Asserts that two estimates agree within four standard errors of their difference plus
/// `slack` relative, and prints the relative difference.
fn assert_agree(name: &str, (a, a_err, b, b_err): (f64, f64, f64, f64), slack: f64) {
    let diff = a - b;
    let noise = (a_err * a_err + b_err * b_err).sqrt();
    println!(
        "{name}: {a:.6e} vs {b:.6e}: relative difference {:+.2e} (noise {:.1e})",
        diff / b,
        noise / b
    );
    assert!(b > 0.0, "{name}: the reference is black");
    assert!(
        diff.abs() <= 4.0 * noise + slack * b.abs(),
        "{name}: {a} vs {b} ({:+.2e} relative, noise {:.1e})",
        diff / b,
        noise / b
    );
}

/// Camera segments along the line through the light and the ball's centre: every camera point
/// is reached by the straight path through the pole vertex (0, 0, −1), so the solution curve
/// runs along a vertex of six triangles for the whole segment. Compared with point sampling on
/// the same segment 10⁻⁷ to the side, where the path refracts inside one triangle. Each of the
/// six triangles counted the path (interval method and point sampling alike: 6.005 times the
/// reference) until a point on an edge or a vertex was given to one triangle
/// (`TrianglePatch::owns`).
#[test]
fn segments_along_the_light_axis() {
    let light = DVec3::new(0.0, 0.0, -4.0);
    let side = DVec3::new(1e-7, 0.0, 0.0);
    for (name, origin, dir) in [
        (
            "inside, toward the light",
            DVec3::new(0.0, 0.0, 0.5),
            -DVec3::Z,
        ),
        (
            "inside, away from the light",
            DVec3::new(0.0, 0.0, 0.5),
            DVec3::Z,
        ),
        (
            "from the far pole vertex",
            DVec3::new(0.0, 0.0, 1.0),
            -DVec3::Z,
        ),
    ] {
        let result = on_segment(
            interval(),
            light,
            1.5,
            (origin, dir),
            (origin + side, dir),
            16,
        );
        assert_agree(&format!("interval, {name}"), result, 1e-3);
        let points = json!({"method": "point_sampling", "samples_per_segment": 64});
        let result = on_segment(points, light, 1.5, (origin, dir), (origin + side, dir), 16);
        assert_agree(&format!("point sampling, {name}"), result, 1e-3);
    }
}

/// Grazing light: a light in the tangent plane of the pole vertex (its normal's incidence is
/// exactly grazing) and a light in the plane of one of the pole's faces (edge-on to it); camera
/// segments through the region those paths light, compared with point sampling on the same
/// segment.
#[test]
fn grazing_light() {
    let mesh = spindle_render::procedural::icosphere(1.0, 3);
    // The face of the pole (0, 0, −1) that the +x axis crosses.
    let face = (0..mesh.triangle_count())
        .find(|&i| {
            let c = mesh.corners(i);
            c[0] == -DVec3::Z && c[1].x > 0.0 && c[2].x > 0.0 && c[1].y * c[2].y < 0.0
        })
        .expect("a face of the pole");
    let c = mesh.corners(face);
    let in_plane = ((c[1] + c[2]) / 2.0 - c[0]).normalize();
    let segments = [
        (DVec3::new(0.0, 0.0, -0.5), DVec3::new(0.3, 0.2, -1.0)),
        (DVec3::new(-0.2, 0.1, 0.0), DVec3::new(1.0, -0.1, -0.3)),
    ];
    for (name, light) in [
        ("light on the pole's horizon", DVec3::new(4.0, 0.0, -1.0)),
        ("light in a face's plane", c[0] + 4.0 * in_plane),
    ] {
        for (i, &(origin, dir)) in segments.iter().enumerate() {
            let result = on_segment(interval(), light, 1.5, (origin, dir), (origin, dir), 16);
            assert_agree(&format!("{name}, segment {i}"), result, 1e-3);
        }
    }
}

/// Grazing camera segments: just under the surface, nearly tangent to it, at the pole vertex
/// and across a face, lit from above and from the side.
#[test]
fn grazing_camera_segments() {
    for light in [DVec3::new(0.0, 0.0, 4.0), DVec3::new(3.0, 1.0, 2.5)] {
        for (i, (origin, dir)) in [
            (DVec3::new(-0.1, 0.0, 0.99), DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(0.0, -0.1, 0.985), DVec3::new(0.1, 1.0, 0.05)),
        ]
        .into_iter()
        .enumerate()
        {
            let result = on_segment(interval(), light, 1.5, (origin, dir), (origin, dir), 16);
            assert_agree(&format!("light {light}, grazing segment {i}"), result, 1e-3);
        }
    }
}

/// `∫ f` over `[a, b]` by the composite midpoint rule with `n` panels.
fn midpoint(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    (0..n).map(|i| f(a + (i as f64 + 0.5) * h)).sum::<f64>() * h
}

/// The straight-path integral of physics.md §4 along `seg` for the ball's medium (σ_t = 1,
/// albedo 0.9, isotropic) and a point light of intensity 10 at `light`:
/// `∫ σ_s/(4π) I e^{−σ_t (t + d_in)}/d² dt`, where `d_in` is the part of `V → L` inside the
/// ball (`inside(V)`).
fn straight_path(seg: &Segment, light: DVec3, inside: impl Fn(DVec3) -> f64) -> f64 {
    let (sigma_t, sigma_s, intensity) = (1.0, 0.9, 10.0);
    midpoint(
        |t| {
            let v = seg.origin + t * seg.dir;
            let d2 = v.distance_squared(light);
            sigma_s / (4.0 * std::f64::consts::PI) * intensity * (-sigma_t * (t + inside(v))).exp()
                / d2
        },
        0.0,
        seg.length,
        20_000,
    )
}

/// A point light exactly on the surface — on the pole vertex (0, 0, 1), on the middle of an
/// edge of that vertex, at the centroid of one of its faces — is inside the medium (the
/// containment test counts the surface as inside), so the light reaches every camera point on
/// the straight line through the medium: the airlight integral (physics.md §4), with the whole
/// of `V → L` inside. The shadow ray must not stop at the surface the light sits on.
#[test]
fn light_on_the_surface() {
    let mesh = spindle_render::procedural::icosphere(1.0, 3);
    let face = (0..mesh.triangle_count())
        .find(|&i| mesh.corners(i)[0] == DVec3::Z)
        .expect("a face of the pole");
    let c = mesh.corners(face);
    for (name, light) in [
        ("vertex", c[0]),
        ("edge", (c[0] + c[1]) / 2.0),
        ("face", (c[0] + c[1] + c[2]) / 3.0),
    ] {
        let scene = glass_ball(
            DVec3::new(0.0, 0.0, 5.0),
            light,
            1.5,
            json!({"samples_per_segment": 256}),
        );
        assert_eq!(scene.light_medium(0), Some(0), "{name}");
        let seg = segment(
            &scene,
            DVec3::new(0.1, -0.2, -0.3),
            DVec3::new(0.2, 1.0, 0.4),
        );
        let truth = straight_path(&seg, light, |v| v.distance(light));
        let (value, stderr) = single_scatter_mean(&scene, &seg, 4, (1, 2, 3));
        let err = value / truth - 1.0;
        println!(
            "light on a {name}: {value:.7e} vs airlight {truth:.7e}: {err:+.2e} (noise {:.1e})",
            stderr / truth
        );
        assert!(
            err.abs() < 4.0 * stderr / truth + 1e-4,
            "light on a {name}: {err}"
        );
    }
}

/// η → 1 from above: `interval` at η = 1 + 2·10⁻⁷, 1 + 10⁻⁸, 1 + 10⁻⁹ and 1 + 10⁻¹² against the
/// straight-path integral of η = 1 (physics.md §4; `d_in` by a ray cast to the surface). Physics
/// moves the value by about 0.4·(η − 1), far below the tolerance. Before, the interval method
/// lost its precision there (−1.5 % at 1 + 10⁻¹⁰, black at 1 + 10⁻¹¹ and 10⁻¹²): within
/// `INDEX_MATCHED` = 10⁻⁷ of 1 every method now runs the straight path, as at η = 1. From
/// below: η < 1 is refused, naming the field.
#[test]
fn eta_tends_to_one() {
    let light = DVec3::new(0.3, 2.5, 0.4);
    for eta in [1.0 + 2e-7, 1.0 + 1e-8, 1.0 + 1e-9, 1.0 + 1e-12] {
        let scene = glass_ball(
            DVec3::new(0.0, 0.0, 5.0),
            light,
            eta,
            json!({"method": "interval", "k": 16, "samples_per_segment": 4096}),
        );
        let model = if eta > 1.0 + 1e-7 {
            "interval"
        } else {
            "straight_line"
        };
        let plan = describe_plan(&scene);
        assert!(plan[0].contains(model), "eta {eta}: {plan:?}");
        for (origin, dir) in [
            (DVec3::new(-0.6, 0.1, 0.05), DVec3::new(1.0, 0.2, -0.1)),
            (DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, -1.0)),
        ] {
            let seg = segment(&scene, origin, dir);
            let d_in = |v: DVec3| {
                let to_light = (light - v).normalize();
                segment_to_surface(&scene, v, to_light).length
            };
            let truth = straight_path(&seg, light, d_in);
            let (value, stderr) = single_scatter_mean(&scene, &seg, 4, (1, 2, 3));
            let (err, noise) = (value / truth - 1.0, stderr / truth);
            println!(
                "eta = 1 + {:.0e}, segment from {origin}: {value:.7e} vs straight path \
                 {truth:.7e}: {err:+.2e} (noise {noise:.1e})",
                eta - 1.0
            );
            assert!(err.abs() < 4.0 * noise + 1e-5, "eta {eta}: {err}");
        }
    }
    for eta in [1.0 - 1e-12, 0.5] {
        let desc: spindle_common::scene::SceneDescription = serde_json::from_value(json!({
            "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 60},
            "film": {"width": 8, "height": 8, "spp": 1},
            "lights": [{"type": "point", "position": [0, 0, 4], "intensity": [1, 1, 1]}],
            "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 1},
                "material": {"type": "dielectric", "eta": eta,
                    "medium": {"sigma_t": [1, 1, 1], "albedo": [0.9, 0.9, 0.9]}}}]
        }))
        .expect("parses");
        let err = Scene::build(&desc, &Assets::new())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.starts_with("objects[0].material.eta:"),
            "eta {eta}: {err:?}"
        );
    }
}
