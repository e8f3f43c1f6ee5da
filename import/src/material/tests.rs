use super::extinction;

/// Beer–Lambert: after the distance d, exp(−σt·d) = c, so σt = −ln(c)/d; checked in closed form
/// for halving (ln 2), a quarter (2 ln 2), and the limits.
#[test]
fn extinction_keeps_the_attenuation_colour_after_the_attenuation_distance() {
    let ln2 = std::f64::consts::LN_2;
    assert!((extinction(0.5, 2.0) - ln2 / 2.0).abs() < 1e-15);
    assert!((extinction(0.25, 2.0) - ln2).abs() < 1e-15);
    assert!((extinction(0.25, 0.5) - 4.0 * ln2).abs() < 1e-14);
    assert_eq!(extinction(1.0, 3.0), 0.0);
    assert_eq!(extinction(0.3, f64::INFINITY), 0.0);
    // And the defining property, for an awkward colour and distance.
    let (c, d) = (0.8125, 0.37);
    assert!(((-extinction(c, d) * d).exp() - c).abs() < 1e-15);
}
