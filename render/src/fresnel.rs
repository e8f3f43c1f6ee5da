//! Smooth dielectric interfaces: exact unpolarised Fresnel reflectance, mirror reflection and
//! Snell refraction.
//!
//! Convention, stated once: `eta` is the **relative** index `n_transmitted / n_incident` across
//! the interface in the direction the light (or the traced ray) crosses it; `n` is the unit
//! normal on the incident side (`d·n < 0` for an incident direction `d`).

use glam::DVec3;

/// Unpolarised Fresnel reflectance for light arriving at `cos_incident` (≥ 0, against the normal
/// on its own side) onto a medium of relative index `eta`. Total internal reflection gives 1.
pub fn reflectance(cos_incident: f64, eta: f64) -> f64 {
    let cos_i = cos_incident.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Mirror reflection of direction `d` about unit normal `n` (either orientation).
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` through an interface with unit normal `n` facing the
/// incoming ray (`d·n < 0`) into relative index `eta`; `None` on total internal reflection.
/// The result is a unit vector in the plane of `d` and `n` with `sin θ_i = eta · sin θ_t`.
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((d / eta + (cos_i / eta - cos_t) * n).normalize())
}

#[cfg(test)]
mod tests;
