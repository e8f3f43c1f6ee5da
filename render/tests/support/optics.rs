//! Snell's law and the Fresnel factor written out for the ground truths of the media tests, so
//! that no closed form leans on the renderer's own. Included with `#[path]` by the tests that use
//! it.

/// Unpolarised Fresnel reflectance from index `n1` onto `n2` at incidence cosine `c` (1 on total
/// internal reflection).
pub fn fresnel(n1: f64, n2: f64, c: f64) -> f64 {
    let s = n1 / n2 * (1.0 - c * c).sqrt();
    if s >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s * s).sqrt();
    let rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct);
    let rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct);
    0.5 * (rs * rs + rp * rp)
}

/// The cosine of the angle to the normal in a medium of index `n`, for a ray whose invariant
/// `n sin θ` is `invariant` (Snell).
pub fn cos_in(n: f64, invariant: f64) -> f64 {
    (1.0 - (invariant / n).powi(2)).sqrt()
}
