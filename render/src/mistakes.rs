//! Likely mistakes in a scene that still renders: a quad light turned away from every object, a
//! camera inside an object by accident (units off by 1000), a mesh with flipped faces. Each is a
//! warning of [`crate::Scene::warnings`], said before any work and written to the EXR header,
//! naming the light or object and what to change; none refuses the scene, since each can be
//! meant (a light for a later frame, a camera in a room or under water). Checked in
//! `render/tests/mistakes.rs`.

use glam::DVec3;

use crate::containment;
use crate::light::Light;
use crate::mesh::MeshReport;
use crate::scene::{Material, Object};

/// A dielectric holding the camera whose bounding box's diagonal is at least this many times
/// that of all the other objects' box looks like a unit mistake (a model in millimetres among
/// metres is 1000 times too large) rather than a sea around a subject.
pub const SUSPICIOUS_SIZE_RATIO: f64 = 100.0;

/// Each quad light whose emitting side faces away from every object: all eight corners of each
/// object's bounding box lie behind (or in) the light's plane, so it lights nothing.
pub fn lights_facing_away(objects: &[Object], lights: &[Light]) -> Vec<String> {
    if objects.is_empty() {
        return Vec::new();
    }
    let mut warnings = Vec::new();
    for (j, light) in lights.iter().enumerate() {
        let Light::Quad { corner, normal, .. } = *light else {
            continue;
        };
        let lit = objects.iter().any(|o| {
            let (lo, hi) = o.mesh.bounds();
            box_corners(lo, hi)
                .iter()
                .any(|&p| (p - corner).dot(normal) > 0.0)
        });
        if !lit {
            warnings.push(format!(
                "lights[{j}]: the quad light faces away from every object (it emits toward \
                 edge_u × edge_v = ({:.3}, {:.3}, {:.3}), and every object's bounding box is \
                 behind it), so it lights nothing; swap edge_u and edge_v to turn it around",
                normal.x, normal.y, normal.z
            ));
        }
    }
    warnings
}

/// The camera inside an object by accident: inside a closed diffuse (opaque) object that holds
/// no light (it sees only the object's unlit inside), or inside a dielectric at least
/// [`SUSPICIOUS_SIZE_RATIO`] times the size of everything else (everything is seen through its
/// medium). A closed diffuse room with a light in it, or a sea around smaller objects, is fine.
pub fn camera_inside(objects: &[Object], camera: DVec3, light_centers: &[DVec3]) -> Vec<String> {
    let mut warnings = Vec::new();
    let position = format!("({}, {}, {})", camera.x, camera.y, camera.z);
    for (i, o) in objects.iter().enumerate() {
        if !o.report.closed || !containment::holds(&o.mesh, camera) {
            continue;
        }
        match o.material {
            Material::Diffuse { .. } => {
                if !light_centers
                    .iter()
                    .any(|&c| containment::holds(&o.mesh, c))
                {
                    warnings.push(format!(
                        "camera: the camera at {position} is inside {} (diffuse, opaque), which \
                         holds no light: the image shows only its unlit inside; move the camera \
                         out (is the object in the scene's units?)",
                        o.name
                    ));
                }
            }
            Material::Dielectric(_) => {
                let others = objects
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| k != i)
                    .map(|(_, other)| other.mesh.bounds())
                    .reduce(|(lo, hi), (l, h)| (lo.min(l), hi.max(h)));
                let Some((lo, hi)) = others else { continue };
                let (own_lo, own_hi) = o.mesh.bounds();
                let ratio = (own_hi - own_lo).length() / (hi - lo).length();
                if ratio >= SUSPICIOUS_SIZE_RATIO {
                    warnings.push(format!(
                        "camera: the camera at {position} is inside {} (a dielectric {ratio:.0} \
                         times the size of all other objects together): everything is seen \
                         through its medium; if that is not meant, check its units (a model in \
                         millimetres among metres is 1000 times too large) or move the camera",
                        o.name
                    ));
                }
            }
        }
    }
    warnings
}

/// A mesh with flipped faces, named `what`: closed but wound inside-out (spindle turned it
/// outward), or without holes yet with edges that two faces traverse in the same direction
/// (some faces wound against their neighbours, so the mesh bounds no volume).
pub fn flipped_faces(what: &str, report: &MeshReport) -> Option<String> {
    const FIX: &str = "recalculate its normals outward in the modelling tool (Blender: Mesh ▸ \
                       Normals ▸ Recalculate Outside) and export it again";
    if report.inside_out {
        Some(format!(
            "{what}: the mesh is inside-out (every face wound inward: its enclosed volume is \
             negative); it is rendered turned outward, but {FIX}"
        ))
    } else if report.boundary_edges == 0 && report.flipped_edges > 0 {
        Some(format!(
            "{what}: the mesh has no holes, but {} of its edges join faces wound in opposite \
             senses: some faces are flipped (their normals point inward), so it bounds no volume \
             and a dielectric is treated as open; {FIX}",
            report.flipped_edges
        ))
    } else {
        None
    }
}

/// The eight corners of the box `lo`–`hi`.
fn box_corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}
