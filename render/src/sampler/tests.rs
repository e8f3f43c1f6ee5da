use super::*;

#[test]
fn same_key_same_bits_and_keys_differ() {
    let draw = |seed, x, y, s| {
        let mut r = Sampler::new(seed, x, y, s);
        [r.next_f64(), r.next_f64(), r.next_f64()]
    };
    assert_eq!(draw(1, 2, 3, 4), draw(1, 2, 3, 4));
    let base = draw(1, 2, 3, 4);
    for other in [
        draw(2, 2, 3, 4),
        draw(1, 3, 2, 4),
        draw(1, 2, 3, 5),
        draw(1, 3, 3, 4),
    ] {
        assert_ne!(base, other);
    }
}

#[test]
fn numbers_are_uniform_in_unit_interval() {
    // Mean 1/2 and variance 1/12 within 5 standard errors, over many pixels and dimensions.
    let n = 200_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for i in 0..n / 8 {
        let mut r = Sampler::new(42, i % 640, i / 640, 0);
        for _ in 0..8 {
            let u = r.next_f64();
            assert!((0.0..1.0).contains(&u));
            sum += u;
            sum2 += u * u;
        }
    }
    let mean = sum / n as f64;
    let var = sum2 / n as f64 - mean * mean;
    let se_mean = (1.0f64 / 12.0 / n as f64).sqrt();
    assert!((mean - 0.5).abs() < 5.0 * se_mean, "mean {mean}");
    assert!((var - 1.0 / 12.0).abs() < 1e-3, "variance {var}");
}
