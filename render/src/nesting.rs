//! Which medium surrounds each object: media nest (a jade bunny in water, an air bubble in
//! resin, a pebble on a pool's floor), and a surface is the interface between the medium it
//! bounds and the one around it.
//!
//! Dielectric surfaces never cross (`Scene::build` refuses that), so the dielectric objects form
//! a forest: an object's *outer* medium is the innermost other dielectric whose mesh holds it
//! (`containment::holds` of one of its vertices; of several holders, the innermost is the one
//! with the smallest bounding box, since a holder's box contains the boxes of everything inside
//! it), or the air. The transport crosses an object's surface with the index of its medium
//! relative to the outer one ([`relative_eta`]), and single scattering and the receivers inside a
//! nested medium see the lights of the outer medium through the one interface between them.

use glam::DVec3;

use crate::contact::Contacts;
use crate::containment;
use crate::flat_face::FlatFaces;
use crate::light::Light;
use crate::scene::{Material, Object};

/// How a light reaches a medium (`Scene::route`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// The light is inside the medium: straight paths, no interface.
    Inside,
    /// The light is in the medium around the object (the air, or the medium it is nested in):
    /// one interface, the object's own.
    Around,
    /// A directional light in the air and the object nested in `outer`, one level down: the light
    /// enters `outer`'s medium through its flat faces (`flat_face`, exact), then crosses the
    /// object's own interface.
    FlatFaces { outer: usize },
    /// Two interfaces or more that are not modelled: the light gives nothing there.
    Unmodelled,
}

/// How `light`, inside the medium of `light_medium` (if any), reaches the medium of object `o`.
pub fn route(
    o: usize,
    light: &Light,
    light_medium: Option<usize>,
    outer: &[Option<usize>],
    flat_faces: &[FlatFaces],
) -> Route {
    if light_medium == Some(o) {
        return Route::Inside;
    }
    if light_medium == outer[o] {
        return Route::Around;
    }
    match (light_medium, outer[o], light) {
        (None, Some(q), Light::Directional { .. })
            if outer[q].is_none() && !flat_faces[q].faces.is_empty() =>
        {
            Route::FlatFaces { outer: q }
        }
        _ => Route::Unmodelled,
    }
}

/// `outer[o]`: the dielectric object whose medium surrounds object `o` (dielectric or not), if
/// any. An object's partners in a shared interface (`contact`) are beside it, not around it,
/// though its vertices lie on their surfaces.
pub fn outer_media(objects: &[Object], contacts: &Contacts) -> Vec<Option<usize>> {
    objects
        .iter()
        .enumerate()
        .map(|(i, inner)| {
            let vertex = *inner.mesh.positions().first()?;
            innermost_holding_but(objects, vertex, |k| {
                k == i || contacts.partners(i).contains(&k)
            })
        })
        .collect()
}

/// The innermost dielectric object (but `except`) whose medium holds `p`
/// (`containment::holds`: inside or on its surface): of several, the one with the smallest
/// bounding box (module doc).
pub fn innermost_holding(objects: &[Object], p: DVec3, except: Option<usize>) -> Option<usize> {
    innermost_holding_but(objects, p, |k| Some(k) == except)
}

/// [`innermost_holding`] among the objects `k` for which `skip(k)` is false.
fn innermost_holding_but(
    objects: &[Object],
    p: DVec3,
    skip: impl Fn(usize) -> bool,
) -> Option<usize> {
    let volume = |o: &Object| {
        let (lo, hi) = o.mesh.bounds();
        (hi - lo).element_product()
    };
    objects
        .iter()
        .enumerate()
        .filter(|&(k, outer)| {
            !skip(k)
                && matches!(outer.material, Material::Dielectric(_))
                && containment::holds(&outer.mesh, p)
        })
        .min_by(|a, b| volume(a.1).total_cmp(&volume(b.1)).then(a.0.cmp(&b.0)))
        .map(|(k, _)| k)
}

/// The index of object `o`'s medium over the index of the medium around it (`outer`); 1 for an
/// object that is not a dielectric.
pub fn relative_eta(objects: &[Object], outer: &[Option<usize>], o: usize) -> f64 {
    absolute_eta(objects, Some(o)) / absolute_eta(objects, outer[o])
}

/// The refractive index of the medium of `object` (the air's is 1).
pub fn absolute_eta(objects: &[Object], object: Option<usize>) -> f64 {
    match object.map(|o| objects[o].material) {
        Some(Material::Dielectric(d)) => d.eta,
        _ => 1.0,
    }
}
