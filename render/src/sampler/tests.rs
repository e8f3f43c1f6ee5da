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

/// Over the first 16 samples of a pixel, each pair of dimensions `(2i, 2i + 1)` puts exactly one
/// point in each cell of the 4×4 grid (and of the 2×8 and 8×2 grids): the (0, 2)-net property of
/// a scrambled Sobol pair, which independent numbers lack (16 numbers fill all 16 cells with
/// probability 16!/16¹⁶ ≈ 1.2e-6).
#[test]
fn a_pixels_samples_are_stratified_in_pairs_of_dimensions() {
    for (x, y) in [(0, 0), (17, 3), (640, 479)] {
        for pair in [0usize, 1, 2, 5] {
            for (cols, rows) in [(4usize, 4usize), (2, 8), (8, 2)] {
                let mut cells = vec![0u32; 16];
                for s in 0..16 {
                    let mut r = Sampler::new(9, x, y, s);
                    for _ in 0..2 * pair {
                        r.next_f64();
                    }
                    let [u, v] = r.next_2d();
                    let (i, j) = ((u * cols as f64) as usize, (v * rows as f64) as usize);
                    cells[j * cols + i] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 1),
                    "pixel ({x}, {y}) dims {}..{}, {cols}x{rows}: {cells:?}",
                    2 * pair,
                    2 * pair + 1
                );
            }
        }
    }
}

/// Beyond the sequence's dimensions the numbers are still uniform (the hash alone).
#[test]
fn numbers_beyond_the_sequence_are_uniform() {
    let n = 20_000;
    let mut sum = 0.0;
    for i in 0..n {
        let mut r = Sampler::new(3, i % 100, i / 100, 0);
        for _ in 0..300 {
            r.next_f64();
        }
        let u = r.next_f64();
        assert!((0.0..1.0).contains(&u));
        sum += u;
    }
    let mean = sum / n as f64;
    assert!(
        (mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt(),
        "mean {mean}"
    );
}

/// Over the first 64 samples of a pixel, `next_3d` puts exactly two points in each cell of the
/// 4×4×2 grid and its permutations (boxes of volume 1/32: the scrambled Sobol sequence's first
/// three dimensions form a (1, 6, 3)-net), whichever dimension it starts at; independent numbers
/// would fill them so evenly with probability below 1e-9.
#[test]
fn three_numbers_are_stratified_together() {
    for (x, y) in [(0, 0), (17, 3)] {
        for skip in [0usize, 1, 2, 5] {
            for (nx, ny, nz) in [
                (4usize, 4usize, 2usize),
                (4, 2, 4),
                (2, 4, 4),
                (8, 2, 2),
                (2, 2, 8),
            ] {
                let mut cells = vec![0u32; 32];
                for s in 0..64 {
                    let mut r = Sampler::new(9, x, y, s);
                    for _ in 0..skip {
                        r.next_f64();
                    }
                    let [u, v, w] = r.next_3d();
                    let (i, j, k) = (
                        (u * nx as f64) as usize,
                        (v * ny as f64) as usize,
                        (w * nz as f64) as usize,
                    );
                    cells[(k * ny + j) * nx + i] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 2),
                    "pixel ({x}, {y}), skip {skip}, grid {nx}x{ny}x{nz}: {cells:?}"
                );
            }
        }
    }
}

/// A fork leaves its parent's numbers as they were, is the same bits for the same key and fork
/// index, and differs between forks, samples and pixels.
#[test]
fn forks_leave_the_parent_unchanged_and_are_keyed() {
    let draw = |r: &mut Sampler| [r.next_f64(), r.next_f64(), r.next_f64()];
    let mut plain = Sampler::new(7, 3, 4, 5);
    let mut forked = Sampler::new(7, 3, 4, 5);
    let first = draw(&mut plain);
    assert_eq!(draw(&mut forked), first);
    let mut a = forked.fork();
    let mut b = forked.fork();
    assert_eq!(
        draw(&mut plain),
        draw(&mut forked),
        "the parent is unchanged"
    );
    let (fa, fb) = (draw(&mut a), draw(&mut b));
    assert_ne!(fa, fb, "two forks differ");
    let mut again = Sampler::new(7, 3, 4, 5);
    draw(&mut again);
    assert_eq!(
        draw(&mut again.fork()),
        fa,
        "a fork is a pure function of its key"
    );
    assert_ne!(draw(&mut Sampler::new(7, 3, 4, 6).fork()), fa);
    assert_ne!(draw(&mut Sampler::new(7, 4, 4, 5).fork()), fa);
}

/// The first forks of a pixel's first 16 samples fill the 4×4 grid with one point each, as the
/// parent's pairs do: a fork keeps the stratification over samples.
#[test]
fn first_forks_are_stratified_over_samples() {
    let mut cells = [0u32; 16];
    for s in 0..16 {
        let mut fork = Sampler::new(11, 5, 9, s).fork();
        let [u, v] = fork.next_2d();
        cells[(u * 4.0) as usize * 4 + (v * 4.0) as usize] += 1;
    }
    assert_eq!(cells, [1; 16]);
}
