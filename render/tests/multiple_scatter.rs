//! Multiple scattering (issue 33) against ground truths that share nothing with the estimator
//! but the scene's geometry:
//! * η = 1: a thick slab of an isotropic medium under the sun is Chandrasekhar's semi-infinite
//!   atmosphere, whose reflected radiance is known exactly through the H-function; the
//!   `multiple_scatter` layer must be the exact law minus its first order, the
//!   `single_scatter` layer that first order.
//! * η = 1.5: a glass ball of a scattering medium under a large sphere light, against the
//!   brute-force volumetric path tracer `multiple_scatter::phase_sampling`, which finds the light
//!   only when a path leaving the ball happens to hit it (phase sampling, stochastic Fresnel,
//!   its own optics), counting the same paths (two scatterings or more, the last connection to
//!   the light by one refraction): image means within their standard errors and per-pixel
//!   χ² ≈ 1.

use std::f64::consts::PI;

use glam::DVec3;
use serde_json::{Value, json};
use spindle_common::stats::RenderStats;
use spindle_render::multiple_scatter::{onto_surface, phase_sampling};
use spindle_render::ray::Ray;
use spindle_render::sampler::Sampler;
use spindle_render::scatter::receiver::Receiver;
use spindle_render::transport::radiance;
use spindle_render::{Assets, Rgb, Scene};

fn build(scene: Value) -> Scene {
    let desc = serde_json::from_value(scene).expect("test scene parses");
    Scene::build(&desc, &Assets::new()).expect("test scene builds")
}

/// Mean and standard error of a list of samples.
fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// The `n`-point Gauss–Legendre rule mapped to [0, 1]: (node, weight) pairs, by Newton on P_n.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut nodes = Vec::new();
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes.push(((x + 1.0) / 2.0, w / 2.0));
    }
    nodes
}

/// Chandrasekhar's H-function of isotropic scattering with albedo `albedo`, on Gauss–Legendre
/// nodes of [0, 1], by iterating `1/H(μ) = 1 − (ϖ/2) μ ∫₀¹ H(μ')/(μ + μ') dμ'` (the form that
/// converges for ϖ < 1); returns a function of μ by the same quadrature (Nyström).
fn h_function(albedo: f64) -> impl Fn(f64) -> f64 {
    let n = 48;
    let nodes = gauss_legendre(n);
    let mut h = vec![1.0; n];
    for _ in 0..500 {
        let next: Vec<f64> = nodes
            .iter()
            .map(|&(mu, _)| {
                let integral: f64 = nodes
                    .iter()
                    .zip(&h)
                    .map(|(&(m, w), &hv)| w * hv / (mu + m))
                    .sum();
                1.0 / (1.0 - albedo / 2.0 * mu * integral)
            })
            .collect();
        h = next;
    }
    move |mu: f64| {
        let integral: f64 = nodes
            .iter()
            .zip(&h)
            .map(|(&(m, w), &hv)| w * hv / (mu + m))
            .sum();
        1.0 / (1.0 - albedo / 2.0 * mu * integral)
    }
}

/// The H-function solver itself against two exact identities: its zeroth moment
/// `∫₀¹ H dμ = (2/ϖ)(1 − √(1 − ϖ))`, and `H(1) = 2.9078` at ϖ = 1 (Chandrasekhar's table).
#[test]
fn h_function_meets_its_identities() {
    for albedo in [0.5, 0.9, 0.99] {
        let h = h_function(albedo);
        let n = 20_000;
        let moment: f64 = (0..n).map(|i| h((i as f64 + 0.5) / n as f64)).sum::<f64>() / n as f64;
        let exact = 2.0 / albedo * (1.0 - (1.0 - albedo).sqrt());
        assert!(
            (moment - exact).abs() < 1e-5,
            "ϖ {albedo}: {moment} vs {exact}"
        );
    }
}

/// A slab 60 mean free paths wide and 30 deep (σ_t = 10, isotropic, η = 1) under the sun from
/// straight above, seen at 30° from its normal: the reflected radiance of a semi-infinite
/// medium is `I(μ) = (E/4π) ϖ μ₀/(μ + μ₀) H(μ) H(μ₀)` (Chandrasekhar 1960, §26), E the sun's
/// irradiance; its first order is the same without the H factors.
#[test]
fn a_thick_slab_reflects_chandrasekhars_law() {
    let irradiance = 2.0;
    let theta = 30f64.to_radians();
    let distance = 40.0;
    let top = 1.5;
    for albedo in [0.5, 0.9] {
        let scene = build(json!({
            "camera": {"position": [0, top + distance * theta.cos(), distance * theta.sin()],
                       "look_at": [0, top, 0], "fov_y": 0.5},
            "film": {"width": 4, "height": 4, "spp": 1},
            "lights": [{"type": "directional", "direction": [0, -1, 0],
                        "irradiance": [irradiance, irradiance, irradiance]}],
            "objects": [{"shape": {"type": "box", "size": [6, 3, 6]},
                         "material": {"type": "dielectric", "eta": 1.0, "medium": {
                             "sigma_t": [10, 10, 10], "albedo": [albedo, albedo, albedo]}}}],
            "integrator": {"multiple_scatter": {"max_order": 1024}}
        }));
        let (mut single, mut multiple) = (Vec::new(), Vec::new());
        let mut stats = RenderStats::default();
        for s in 0..4096 {
            let (x, y) = (s % 4, (s / 4) % 4);
            let mut sampler = Sampler::new(3, x, y, s / 16);
            let [u, v] = sampler.next_2d();
            let ray = scene.camera().ray(x as f64 + u, y as f64 + v);
            let r = radiance(&scene, &ray, &mut sampler, &mut stats);
            single.push(r.single_scatter.x);
            multiple.push(r.multiple_scatter.x);
        }
        let (mu, mu0) = (theta.cos(), 1.0);
        let h = h_function(albedo);
        let first = irradiance / (4.0 * PI) * albedo * mu0 / (mu + mu0);
        let higher = first * (h(mu) * h(mu0) - 1.0);
        let (s, s_err) = mean_and_error(&single);
        let (m, m_err) = mean_and_error(&multiple);
        println!(
            "ϖ {albedo}: single {s:.6} ± {s_err:.1e} (exact {first:.6}); multiple {m:.6} ± \
             {m_err:.1e} (exact {higher:.6}, {:+.2} %); {} secondary segments per sample",
            100.0 * (m / higher - 1.0),
            stats.secondary_segments as f64 / 4096.0
        );
        assert!(
            (s - first).abs() < 4.0 * s_err + 1e-3 * first,
            "single scattering"
        );
        assert!(
            (m - higher).abs() < 4.0 * m_err + 2e-3 * higher,
            "multiple scattering"
        );
    }
}

const ETA: f64 = 1.5;
const SIGMA_T: f64 = 2.0;
const ALBEDO: f64 = 0.8;
const G: f64 = 0.3;
const LIGHT_RADIUS: f64 = 2.0;
const RADIANCE: f64 = 1.0;

/// A glass ball (η 1.5, radius 1, an HG medium) and a large sphere light beside it; point
/// sampling with 4 stratified points per segment (unbiased, and 16 times cheaper than its
/// default 64, which make it ten times slower than the interval method here).
fn ball(method: &str) -> Scene {
    ball_up_to(1024, method)
}

/// [`ball`] with orders up to `max_order`.
fn ball_up_to(max_order: u32, method: &str) -> Scene {
    build(json!({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 18},
        "film": {"width": 6, "height": 6, "spp": 1},
        "lights": [{"type": "sphere", "center": [3, 3, 0], "radius": LIGHT_RADIUS,
                    "radiance": [RADIANCE, RADIANCE, RADIANCE]}],
        "objects": [{"shape": {"type": "icosphere", "radius": 1, "subdivisions": 3},
                     "material": {"type": "dielectric", "eta": ETA, "medium": {
                         "sigma_t": [SIGMA_T, SIGMA_T, SIGMA_T],
                         "albedo": [ALBEDO, ALBEDO, ALBEDO],
                         "phase": {"type": "hg", "g": G}}}}],
        "integrator": {"internal_reflections": 2,
                       "single_scatter": {"samples_per_segment": 4},
                       "multiple_scatter": {"max_order": max_order, "method": method}}
    }))
}

/// Per-pixel means and standard errors of `estimate` over `spp` samples per pixel.
fn per_pixel(
    scene: &Scene,
    spp: u32,
    mut estimate: impl FnMut(Ray, &mut Sampler) -> f64,
) -> Vec<(f64, f64)> {
    let mut pixels = Vec::new();
    for y in 0..6 {
        for x in 0..6 {
            let values: Vec<f64> = (0..spp)
                .map(|s| {
                    let mut sampler = Sampler::new(17, x, y, s);
                    let [u, v] = sampler.next_2d();
                    let ray = scene.camera().ray(x as f64 + u, y as f64 + v);
                    estimate(ray, &mut sampler)
                })
                .collect();
            pixels.push(mean_and_error(&values));
        }
    }
    pixels
}

/// Image means, and χ² per pixel, of the renderer's `multiple_scatter` layer against the brute
/// force, for the secondary segments' light by the interval method and by point sampling; the
/// straight-line approximation, which is dark through a curved boundary, is told apart.
#[test]
fn a_glass_ball_matches_a_brute_force_path_tracer() {
    let reference = ball("auto");
    let clock = std::time::Instant::now();
    let brute = per_pixel(&reference, 16_384, |ray, rng| {
        phase_sampling::estimate(&reference, ray, rng).x
    });
    println!("brute force: {:.1} s", clock.elapsed().as_secs_f64());
    let (b_mean, b_err) = image_mean(&brute);
    for (method, agrees) in [
        ("auto", true),
        ("point_sampling", true),
        ("straight_line", false),
    ] {
        let scene = ball(method);
        let mut stats = RenderStats::default();
        let clock = std::time::Instant::now();
        let ours = per_pixel(&scene, 128, |ray, sampler| {
            radiance(&scene, &ray, sampler, &mut stats)
                .multiple_scatter
                .x
        });
        println!("{method}: {:.1} s", clock.elapsed().as_secs_f64());
        let (o_mean, o_err) = image_mean(&ours);
        let chi2 = ours
            .iter()
            .zip(&brute)
            .map(|(&(a, ae), &(b, be))| (a - b).powi(2) / (ae * ae + be * be).max(1e-300))
            .sum::<f64>()
            / ours.len() as f64;
        let z = (o_mean - b_mean) / (o_err * o_err + b_err * b_err).sqrt();
        println!(
            "{method}: image mean {o_mean:.5} ± {o_err:.1e}, brute force {b_mean:.5} ± \
             {b_err:.1e} (z {z:+.2}, {:+.2} %), χ²/pixel {chi2:.2}; {:.1} secondary segments \
             per sample",
            100.0 * (o_mean / b_mean - 1.0),
            stats.secondary_segments as f64 / (36.0 * 128.0)
        );
        if agrees {
            assert!(
                z.abs() < 4.0,
                "{method}: image means differ by {z:.2} standard errors"
            );
            assert!((0.4..1.9).contains(&chi2), "{method}: χ²/pixel {chi2:.2}");
        } else {
            assert!(z.abs() > 4.0, "{method}: the test cannot tell it apart");
        }
    }
}

/// The mean over pixels, and its standard error.
fn image_mean(pixels: &[(f64, f64)]) -> (f64, f64) {
    let n = pixels.len() as f64;
    let mean = pixels.iter().map(|p| p.0).sum::<f64>() / n;
    let err = pixels.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt() / n;
    (mean, err)
}

/// With multiple scattering off (`max_order` 1, or albedo 0) the layer is black, and the other
/// layers are the same bits as with it on (its numbers come from a sampler of its own).
#[test]
fn the_other_layers_do_not_depend_on_multiple_scattering() {
    let on = ball("auto");
    let off = ball_up_to(1, "auto");
    for s in 0..64 {
        let ray = on.camera().ray(2.5 + (s % 8) as f64 / 8.0, 3.1);
        let mut stats = RenderStats::default();
        let a = radiance(&on, &ray, &mut Sampler::new(5, 1, 2, s), &mut stats);
        let b = radiance(&off, &ray, &mut Sampler::new(5, 1, 2, s), &mut stats);
        assert_eq!(b.multiple_scatter, Rgb::ZERO);
        assert_eq!(
            (a.surface, a.single_scatter),
            (b.surface, b.single_scatter),
            "sample {s}"
        );
    }
}

/// Energy, with albedo 1 and nothing absorbed (the white-furnace check for a medium inside
/// a dielectric): a glass slab (η 1.5, σt 1, 1 thick, 200 wide, isotropic, albedo 1) under the
/// sun from straight above. All the light that scatters inside it leaves it, up or down, so the
/// scattered flux out of both faces, `2π ∫₀¹ L(μ) μ dμ` over each hemisphere of directions (by
/// Gauss–Legendre in μ; the set-up is symmetric about the normal), equals the flux the sun's
/// beam leaves in the medium on its way down, `E (1 − R₀)(1 − e^{−τ})`, `R₀ = ((η − 1)/(η + 1))²`.
/// (The beam's share reflected off the bottom face that scatters on its way back up is not in
/// it: each connection to the light refracts once, with no internal reflection on the light's
/// side — the renderer's stated model, so not in the layers either.) A walk that lost light at
/// the boundary (a wrong internal Fresnel, total internal reflection ending a path, a missing
/// n² on the way out) or made some would miss it; so would orders cut short.
#[test]
fn a_slab_that_absorbs_nothing_gives_back_all_the_light_it_scatters() {
    let (eta, tau, irradiance): (f64, f64, f64) = (1.5, 1.0, 1.0);
    let scene = build(json!({
        "camera": {"position": [0, 20, 5], "look_at": [0, 0, 0], "fov_y": 1},
        "film": {"width": 4, "height": 4, "spp": 1},
        "lights": [{"type": "directional", "direction": [0, -1, 0],
                    "irradiance": [irradiance, irradiance, irradiance]}],
        "objects": [{"shape": {"type": "box", "size": [200, 1, 200]},
                     "material": {"type": "dielectric", "eta": eta, "medium": {
                         "sigma_t": [tau, tau, tau], "albedo": [1, 1, 1]}}}],
        "integrator": {"max_depth": 64, "internal_reflections": 16,
                       "multiple_scatter": {"max_order": 1024, "paths": 2}}
    }));
    let (samples, nodes) = (256, 8);
    let mut stats = RenderStats::default();
    let mut flux = [(0.0, 0.0); 2];
    for (side, (up, face)) in [(1.0, 0.5), (-1.0, -0.5)].into_iter().enumerate() {
        for (node, (mu, weight)) in gauss_legendre(nodes).into_iter().enumerate() {
            let out = DVec3::new((1.0 - mu * mu).sqrt(), up * mu, 0.0);
            let values: Vec<f64> = (0..samples)
                .map(|i| {
                    let ray = Ray::new(DVec3::new(0.0, face, 0.0) + 5.0 * out, -out);
                    let mut sampler = Sampler::new(7, node as u32, side as u32, i);
                    let r = radiance(&scene, &ray, &mut sampler, &mut stats);
                    r.single_scatter.x + r.multiple_scatter.x
                })
                .collect();
            let (l, l_err) = mean_and_error(&values);
            let k = 2.0 * PI * weight * mu;
            flux[side].0 += k * l;
            flux[side].1 += (k * l_err).powi(2);
        }
    }
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let deposited = irradiance * (1.0 - r0) * (1.0 - (-tau).exp());
    let total = flux[0].0 + flux[1].0;
    let error = (flux[0].1 + flux[1].1).sqrt();
    println!(
        "scattered out: up {:.5} ± {:.1e}, down {:.5} ± {:.1e}, total {total:.5} ± {error:.1e} \
         against the {deposited:.5} deposited ({:+.2} %); {:.1} secondary segments per sample",
        flux[0].0,
        flux[0].1.sqrt(),
        flux[1].0,
        flux[1].1.sqrt(),
        100.0 * (total / deposited - 1.0),
        stats.secondary_segments as f64 / (2.0 * nodes as f64 * f64::from(samples))
    );
    assert!(
        (total - deposited).abs() < 4.0 * error + 2e-3 * deposited,
        "no more and no less light leaves than the medium scattered"
    );
}

/// Light scattered in the water onto a floor inside it: a floor 1 below a calm water surface
/// (η 1.33, isotropic, σt 0.8, albedo 0.6) under the sun from straight above. With `max_order`
/// 2 the floor gets the first order alone (its reflection is the second scattering), whose
/// irradiance is `E₁ = 2π ∫₀¹ μ dμ ∫₀^{H/μ} (σ_s/4π) E_w e^{−σ(H − sμ)} e^{−σ s} ds`,
/// `E_w = E (1 − F₀)` the sun in the water, so the floor sends `ρ E₁ / π` toward the camera; the
/// inner integral is closed (`e^{−σH} (1 − e^{−σH(1−μ)/μ}) / (σ(1 − μ))`), the outer one by
/// Gauss–Legendre. With the default `max_order` the higher orders add light on top.
#[test]
fn light_scattered_in_the_water_reaches_a_floor_inside_it() {
    let (eta, sigma, albedo, depth, irradiance, rho): (f64, f64, f64, f64, f64, f64) =
        (1.33, 0.8, 0.6, 1.0, 2.0, 0.7);
    let scene_up_to = |max_order: u32| {
        build(json!({
            "camera": {"position": [0, -0.5, 0.5], "look_at": [0, -1, 0], "fov_y": 20},
            "film": {"width": 4, "height": 4, "spp": 1},
            "lights": [{"type": "directional", "direction": [0, -1, 0],
                        "irradiance": [irradiance, irradiance, irradiance]}],
            "objects": [
                {"shape": {"type": "box", "size": [100, 2, 100]},
                 "transform": {"translate": [0, -1, 0]},
                 "material": {"type": "dielectric", "eta": eta, "medium": {
                     "sigma_t": [sigma, sigma, sigma], "albedo": [albedo, albedo, albedo]}}},
                {"shape": {"type": "box", "size": [80, 0.5, 80]},
                 "transform": {"translate": [0, -1.25, 0]},
                 "material": {"type": "diffuse", "reflectance": [rho, rho, rho]}}
            ],
            "integrator": {"multiple_scatter": {"max_order": max_order}}
        }))
    };
    let receiver = Receiver {
        p: DVec3::new(0.3, -depth, 0.2),
        normal: DVec3::Y,
        geometric: DVec3::Y,
        reflectance: Rgb::splat(rho),
    };
    let estimate = |scene: &Scene| {
        let mut stats = RenderStats::default();
        let values: Vec<f64> = (0..2048)
            .map(|i| {
                let mut sampler = Sampler::new(11, 0, 0, i);
                onto_surface(scene, 0, &receiver, &mut sampler, &mut stats).x
            })
            .collect();
        mean_and_error(&values)
    };
    let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let e_water = irradiance * (1.0 - f0);
    let sigma_s = albedo * sigma;
    let outer: f64 = gauss_legendre(48)
        .into_iter()
        .map(|(mu, w)| {
            let inner = (-sigma * depth).exp() * (1.0 - (-sigma * depth * (1.0 - mu) / mu).exp())
                / (sigma * (1.0 - mu));
            w * mu * inner
        })
        .sum();
    let e1 = 2.0 * PI * sigma_s / (4.0 * PI) * e_water * outer;
    let first = rho * e1 / PI;
    let (one, one_err) = estimate(&scene_up_to(2));
    let (all, all_err) = estimate(&scene_up_to(64));
    println!(
        "first order {one:.6} ± {one_err:.1e} against {first:.6} ({:+.2} %); all orders \
         {all:.6} ± {all_err:.1e}",
        100.0 * (one / first - 1.0)
    );
    assert!(
        (one - first).abs() < 4.0 * one_err + 1e-3 * first,
        "first order"
    );
    assert!(
        all > one + 4.0 * (one_err + all_err),
        "higher orders add light"
    );
    let off = estimate(&scene_up_to(1));
    assert_eq!(off, (0.0, 0.0), "max_order 1 turns it off");
}
