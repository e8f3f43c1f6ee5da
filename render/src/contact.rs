//! Shared interfaces: where the surfaces of two media coincide (a liquid against a glass's
//! wall, water against an aquarium's pane), they are one interface between the two media, not
//! two interfaces with a film of air between them.
//!
//! A user models such a contact by giving both objects the shared part exactly: the same
//! vertices, or the same planes (a water box against a glass box). The two objects' insides
//! must be apart: the liquid is not inside the glass's mesh, it fills the glass's cavity. Every
//! place a path meets a dielectric surface then asks which medium lies beyond it *at that
//! point* ([`Contacts::across`]): the partner's, where the partner's surface passes through the
//! point, else the medium around the object (`nesting`). The index across is the ratio of the
//! two media's.
//!
//! [`Contacts::find`] sorts every pair of dielectric objects whose surfaces touch over an area
//! (`containment::surfaces_touch`) into one of:
//! * coincident, insides apart: partners, one interface;
//! * one inside the other (an object resting against the inside of the medium around it), or
//!   surfaces that come within [`containment::TOUCHING`] of each other without coinciding to
//!   [`COINCIDENT`]: refused naming both objects, since a ray would meet either surface at random.

use glam::DVec3;
use spindle_common::validate::SceneError;

use crate::containment;
use crate::scene::{Material, Object};

/// Two surfaces closer than this share of the scene's scale coincide. It lies below the ray
/// offset (`ray::OFFSET_SCALE`, 1e-8), so a path that crossed one of them starts beyond both.
pub const COINCIDENT: f64 = 1e-9;

/// Per object, the dielectric objects whose surfaces coincide with part of its own.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Contacts {
    partners: Vec<Vec<usize>>,
}

impl Contacts {
    /// The shared interfaces of `objects` (module doc), or the error naming the first pair in
    /// contact that is not one. `scale` is the scene's size.
    pub fn find(objects: &[Object], scale: f64) -> Result<Contacts, SceneError> {
        let mut partners = vec![Vec::new(); objects.len()];
        let dielectric = |o: &Object| matches!(o.material, Material::Dielectric(_));
        for (i, a) in objects.iter().enumerate().filter(|(_, o)| dielectric(o)) {
            for (k, b) in objects.iter().enumerate().take(i) {
                if !dielectric(b) || !containment::surfaces_touch(&a.mesh, &a.bvh, &b.mesh, &b.bvh)
                {
                    continue;
                }
                let nested = |inner: &Object, outer: &Object| {
                    containment::interior_point(&inner.mesh)
                        .is_none_or(|q| containment::holds(&outer.mesh, q))
                };
                if nested(a, b) || nested(b, a) {
                    return Err(SceneError::new(
                        a.name.clone(),
                        format!(
                            "its surface touches the surface of {} from inside: an object \
                             resting against the inside of the medium around it is not \
                             modelled; leave a gap between them (the inner object slightly \
                             smaller), which renders as a thin film of the outer medium",
                            b.name
                        ),
                    ));
                }
                let gap = containment::contact_gap(&a.mesh, &b.mesh, &b.bvh)
                    .max(containment::contact_gap(&b.mesh, &a.mesh, &a.bvh));
                if gap > COINCIDENT * scale {
                    return Err(SceneError::new(
                        a.name.clone(),
                        format!(
                            "its surface comes within {gap:.1e} of the surface of {} without \
                             coinciding with it: where two media meet, give both objects the \
                             shared part exactly (the same vertices, or the same planes), which \
                             makes it one interface between them; or leave a clear gap, which \
                             renders as a thin film of air",
                            b.name
                        ),
                    ));
                }
                partners[i].push(k);
                partners[k].push(i);
            }
        }
        Ok(Contacts { partners })
    }

    /// The objects whose surfaces coincide with part of object `o`'s.
    pub fn partners(&self, o: usize) -> &[usize] {
        self.partners.get(o).map_or(&[], Vec::as_slice)
    }

    /// The dielectric object whose medium lies beyond object `o`'s surface at `p` (on it, with
    /// the unit geometric normal `normal` there): the partner whose surface passes through `p`,
    /// else `around`, the medium around `o`.
    pub fn across(
        &self,
        objects: &[Object],
        o: usize,
        p: DVec3,
        normal: DVec3,
        around: Option<usize>,
        scale: f64,
    ) -> Option<usize> {
        let tolerance = COINCIDENT * scale;
        self.partners(o)
            .iter()
            .copied()
            .find(|&k| {
                objects[k]
                    .bvh
                    .any_hit(p - tolerance * normal, normal, 2.0 * tolerance)
            })
            .or(around)
    }
}
