//! Checking a scene's time (`animation`): its tracks well formed, and every frame of it a scene
//! the rules of a still accept, so [`SceneDescription::at_frame`] never makes a still that
//! [`SceneDescription::validate`] would refuse.
//!
//! Two ways to know a rule holds at every frame. Rules on a convex set (a coordinate within the
//! extent, a scale factor's sign and size, a field of view in (0, 180), a bounding sphere's
//! reach) hold wherever they hold on the track's [`hull_points`]: its keys, which suffice for
//! linear and step tracks (a linear value is a convex combination of two keys), and for smooth
//! tracks the Bézier control points of each segment as well (the curve stays in their convex
//! hull). Rules that are not convex (the camera's view direction not zero and `up` not along
//! it, a light's direction not zero) are checked at every whole frame from the first key to
//! the last, at most [`MAX_FRAME`] + 1 of them — the frames a farm can render; before and after
//! the keys the values are the end keys'.

use std::collections::BTreeSet;

use super::{
    Check, MAX_COORDINATE, MAX_FRAME, MAX_KEYS, MAX_SCALE, MIN_LENGTH, SceneError, check_camera,
    check_direction, check_finite, check_open_range, check_point, check_vec3, procedural_radius,
    surely_within_extent,
};
use crate::animation::{Components, camera_at, hull_points, light_at, smooth_rotation_segment};
use crate::scene::{
    Animation, CameraAnimation, Interpolation, Light, LightAnimation, ObjectAnimation, Quat,
    SceneDescription, Track, Transform, Vec3,
};

/// The most frames a second accepted in `animation.frame_rate`.
pub const MAX_FRAME_RATE: f64 = 1000.0;

/// Checks `scene.animation` (at `path`).
pub(super) fn check(path: &str, animation: &Animation, scene: &SceneDescription) -> Check {
    if let Some(rate) = animation.frame_rate {
        let field = format!("{path}.frame_rate");
        check_finite(&field, rate)?;
        if !(rate > 0.0 && rate <= MAX_FRAME_RATE) {
            return Err(SceneError::new(
                field,
                format!("must be in (0, {MAX_FRAME_RATE}] frames a second, got {rate}"),
            ));
        }
    }
    if let Some(range) = animation.frames {
        for (name, frame) in [("start", range.start), ("end", range.end)] {
            if frame > MAX_FRAME {
                return Err(SceneError::new(
                    format!("{path}.frames.{name}"),
                    format!("must be at most {MAX_FRAME}, got {frame}"),
                ));
            }
        }
        if range.end < range.start {
            return Err(SceneError::new(
                format!("{path}.frames.end"),
                format!(
                    "must be at least frames.start ({}), got {}: a range runs forward",
                    range.start, range.end
                ),
            ));
        }
    }
    if let Some(camera) = &animation.camera {
        check_camera_tracks(&format!("{path}.camera"), camera, scene)?;
    }
    let mut seen = BTreeSet::new();
    for (k, tracks) in animation.objects.iter().enumerate() {
        let at = format!("{path}.objects[{k}]");
        if tracks.object >= scene.objects.len() {
            return Err(SceneError::new(
                format!("{at}.object"),
                format!(
                    "names objects[{}], but the scene has {} objects",
                    tracks.object,
                    scene.objects.len()
                ),
            ));
        }
        if !seen.insert(tracks.object) {
            return Err(SceneError::new(
                format!("{at}.object"),
                format!(
                    "objects[{}] is animated by an earlier entry already: one entry an object",
                    tracks.object
                ),
            ));
        }
        check_object_tracks(&at, tracks, scene)?;
    }
    let mut seen = BTreeSet::new();
    for (k, tracks) in animation.lights.iter().enumerate() {
        let at = format!("{path}.lights[{k}]");
        let Some(light) = scene.lights.get(tracks.light) else {
            return Err(SceneError::new(
                format!("{at}.light"),
                format!(
                    "names lights[{}], but the scene has {} lights",
                    tracks.light,
                    scene.lights.len()
                ),
            ));
        };
        if !seen.insert(tracks.light) {
            return Err(SceneError::new(
                format!("{at}.light"),
                format!(
                    "lights[{}] is animated by an earlier entry already: one entry a light",
                    tracks.light
                ),
            ));
        }
        check_light_tracks(&at, tracks, light)?;
    }
    Ok(())
}

/// A track's keys: at least one, at most [`MAX_KEYS`], frames finite within ±[`MAX_FRAME`] and
/// strictly increasing, each value checked by `value`.
fn check_keys<V>(path: &str, track: &Track<V>, value: impl Fn(&str, &V) -> Check) -> Check {
    let keys = &track.keys;
    if keys.is_empty() {
        return Err(SceneError::new(
            format!("{path}.keys"),
            "must hold at least one key",
        ));
    }
    if keys.len() > MAX_KEYS {
        return Err(SceneError::new(
            format!("{path}.keys"),
            format!("must hold at most {MAX_KEYS} keys, got {}", keys.len()),
        ));
    }
    for (i, key) in keys.iter().enumerate() {
        let frame = format!("{path}.keys[{i}].frame");
        check_finite(&frame, key.frame)?;
        if key.frame.abs() > f64::from(MAX_FRAME) {
            return Err(SceneError::new(
                frame,
                format!("must be within ±{MAX_FRAME}, got {}", key.frame),
            ));
        }
        if i > 0 {
            let previous = keys[i - 1].frame;
            if key.frame == previous {
                return Err(SceneError::new(
                    frame,
                    format!(
                        "repeats keys[{}].frame ({previous}): one key a frame",
                        i - 1
                    ),
                ));
            }
            if key.frame < previous {
                return Err(SceneError::new(
                    frame,
                    format!(
                        "must come after keys[{}].frame ({previous}), got {}: keys go in frame \
                         order",
                        i - 1,
                        key.frame
                    ),
                ));
            }
        }
        value(&format!("{path}.keys[{i}].value"), &key.value)?;
    }
    Ok(())
}

/// A track of positions: keys within the extent, and a smooth track's curve too.
fn check_point_track(path: &str, track: &Track<Vec3>) -> Check {
    check_keys(path, track, check_point)?;
    check_hull(path, track, |p| p.iter().all(|x| x.abs() <= MAX_COORDINATE))
        .map_err(|e| e.with_problem("the scene's extent (±1e6 per coordinate)"))
}

/// A track of vectors: finite keys, and a smooth track's curve finite.
fn check_vector_track(path: &str, track: &Track<Vec3>) -> Check {
    check_keys(path, track, check_vec3)?;
    check_hull(path, track, |p| p.iter().all(|x| x.is_finite()))
        .map_err(|e| e.with_problem("finite numbers"))
}

/// The error of a smooth segment whose control points break a convex rule.
struct HullError {
    path: String,
    i: usize,
}

impl HullError {
    fn with_problem(self, rule: &str) -> SceneError {
        SceneError::new(
            self.path,
            format!(
                "the smooth curve from keys[{i}] to keys[{j}] may leave {rule} between them (a \
                 control point of its Bézier form does): add a key between them or make the track \
                 linear",
                i = self.i,
                j = self.i + 1
            ),
        )
    }
}

/// `ok` at every hull point of a smooth track (the keys are checked already); the first
/// segment whose control point fails.
fn check_hull<V: Components>(
    path: &str,
    track: &Track<V>,
    ok: impl Fn(V) -> bool,
) -> Result<(), HullError> {
    if track.interpolation != Interpolation::Smooth {
        return Ok(());
    }
    let points = hull_points(track);
    let keys = track.keys.len();
    // After the keys, two control points a segment, in segment order.
    for (n, point) in points.iter().enumerate().skip(keys) {
        if !ok(*point) {
            return Err(HullError {
                path: path.to_string(),
                i: (n - keys) / 2,
            });
        }
    }
    Ok(())
}

fn check_camera_tracks(path: &str, tracks: &CameraAnimation, scene: &SceneDescription) -> Check {
    if let Some(track) = &tracks.position {
        check_point_track(&format!("{path}.position"), track)?;
    }
    if let Some(track) = &tracks.look_at {
        check_point_track(&format!("{path}.look_at"), track)?;
    }
    if let Some(track) = &tracks.up {
        check_vector_track(&format!("{path}.up"), track)?;
    }
    if let Some(track) = &tracks.fov_y {
        let field = format!("{path}.fov_y");
        check_keys(&field, track, |p, v| check_open_range(p, *v, 0.0, 180.0))?;
        check_hull(&field, track, |v| v > 0.0 && v < 180.0)
            .map_err(|e| e.with_problem("(0, 180) degrees"))?;
    }
    // The view direction and `up` at every frame the tracks change.
    let spans = [
        tracks.position.as_ref().map(span),
        tracks.look_at.as_ref().map(span),
        tracks.up.as_ref().map(span),
        tracks.fov_y.as_ref().map(span),
    ];
    for frame in frames_of(spans.into_iter().flatten()) {
        let camera = camera_at(&scene.camera, tracks, f64::from(frame));
        check_camera("camera", &camera)
            .map_err(|e| SceneError::new(path, format!("at frame {frame}, {e}")))?;
    }
    Ok(())
}

/// The first and last key's frames.
fn span<V>(track: &Track<V>) -> (f64, f64) {
    (track.keys[0].frame, track.keys[track.keys.len() - 1].frame)
}

/// The whole frames a farm can render (0 ..= [`MAX_FRAME`]) from the earliest first key to the
/// latest last key, widened to whole frames: every distinct value the tracks take at a
/// whole frame is taken at one of these.
fn frames_of(spans: impl Iterator<Item = (f64, f64)>) -> impl Iterator<Item = u32> {
    let (first, last) = spans.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (f, l)| {
        (a.min(f), b.max(l))
    });
    let clamp = |f: f64| f.clamp(0.0, f64::from(MAX_FRAME)) as u32;
    (first <= last)
        .then(|| clamp(first.floor())..=clamp(last.ceil()))
        .into_iter()
        .flatten()
}

fn check_object_tracks(path: &str, tracks: &ObjectAnimation, scene: &SceneDescription) -> Check {
    if let Some(track) = &tracks.translate {
        check_point_track(&format!("{path}.translate"), track)?;
    }
    if let Some(track) = &tracks.rotation {
        check_rotation_track(&format!("{path}.rotation"), track)?;
    }
    if let Some(track) = &tracks.scale {
        check_scale_track(&format!("{path}.scale"), track)?;
    }
    // A procedural shape's bounding sphere within the extent at every frame: placed by the
    // largest scale and the farthest translation any frame can have (rotation keeps lengths).
    let object = &scene.objects[tracks.object];
    if let Some(radius) = procedural_radius(&object.shape) {
        let largest = |points: Vec<Vec3>| -> Vec3 {
            points.iter().fold([0.0; 3], |m, p| {
                std::array::from_fn(|c| m[c].max(p[c].abs()))
            })
        };
        let worst = Transform {
            scale: tracks
                .scale
                .as_ref()
                .map_or(object.transform.scale, |t| largest(hull_points(t))),
            rotate_deg: [0.0; 3],
            translate: tracks
                .translate
                .as_ref()
                .map_or(object.transform.translate, |t| largest(hull_points(t))),
        };
        if !surely_within_extent(&worst, radius) {
            return Err(SceneError::new(
                path,
                format!(
                    "may place objects[{}]'s bounding sphere (radius {radius:e} about its origin) \
                     past the scene's extent of ±{MAX_COORDINATE:e} per coordinate at some frame \
                     (with its largest scale {:?} and farthest translation {:?})",
                    tracks.object, worst.scale, worst.translate
                ),
            ));
        }
    }
    Ok(())
}

/// A quaternion key: finite and not zero.
fn check_quat(path: &str, q: &Quat) -> Check {
    for (i, c) in q.iter().enumerate() {
        check_finite(&format!("{path}[{i}]"), *c)?;
    }
    if q.iter().all(|&c| c == 0.0) {
        return Err(SceneError::new(
            path,
            "must not be the zero quaternion (it is no rotation; the identity is [0, 0, 0, 1])",
        ));
    }
    Ok(())
}

/// A rotation track: quaternion keys, and a smooth curve that stays away from the zero
/// quaternion (so it can be normalised at every frame): each segment's control points all on
/// one side of a hyperplane through 0 (that of the segment's end keys' sum).
fn check_rotation_track(path: &str, track: &Track<Quat>) -> Check {
    check_keys(path, track, check_quat)?;
    if track.interpolation != Interpolation::Smooth {
        return Ok(());
    }
    for i in 0..track.keys.len() - 1 {
        let [a, ma, b, mb] = smooth_rotation_segment(&track.keys, i);
        let h = track.keys[i + 1].frame - track.keys[i].frame;
        let c1 = a.zip_with(ma, |x, m| x + h * m / 3.0);
        let c2 = b.zip_with(mb, |x, m| x - h * m / 3.0);
        let normal = a.zip_with(b, |x, y| x + y);
        let side = |p: Quat| p.iter().zip(normal).map(|(x, n)| x * n).sum::<f64>();
        if ![a, c1, c2, b].into_iter().all(|p| side(p) > 1e-9) {
            return Err(SceneError::new(
                path,
                format!(
                    "the smooth rotation from keys[{i}] to keys[{}] turns too far to be \
                     interpolated (its curve may pass the zero quaternion): add a key between \
                     them or make the track linear",
                    i + 1
                ),
            ));
        }
    }
    Ok(())
}

/// A scale factor: not zero, within [[`MIN_LENGTH`], [`MAX_SCALE`]] in absolute value.
fn scale_ok(s: f64) -> bool {
    s.is_finite() && (MIN_LENGTH..=MAX_SCALE).contains(&s.abs())
}

/// A scale track: each key's factors as a static scale's, and between two keys (linear or
/// smooth) no factor that changes sign or leaves the range: every hull point of the segment
/// with the sign of its first key.
fn check_scale_track(path: &str, track: &Track<Vec3>) -> Check {
    check_keys(path, track, |p, v| {
        for (c, s) in v.iter().enumerate() {
            if !scale_ok(*s) {
                return Err(SceneError::new(
                    format!("{p}[{c}]"),
                    format!(
                        "must be between {MIN_LENGTH:e} and {MAX_SCALE:e} in absolute value (not \
                         0), got {s}"
                    ),
                ));
            }
        }
        Ok(())
    })?;
    if track.interpolation == Interpolation::Step {
        return Ok(());
    }
    let keys = &track.keys;
    let smooth = hull_points(track);
    for i in 0..keys.len() - 1 {
        let (a, b) = (keys[i].value, keys[i + 1].value);
        let mut points = vec![a, b];
        if track.interpolation == Interpolation::Smooth {
            points.extend_from_slice(&smooth[keys.len() + 2 * i..keys.len() + 2 * i + 2]);
        }
        for c in 0..3 {
            let fits = points
                .iter()
                .all(|p| scale_ok(p[c]) && p[c].signum() == a[c].signum());
            if !fits {
                return Err(SceneError::new(
                    path,
                    format!(
                        "scale[{c}] from keys[{i}] to keys[{}] would pass through 0 or leave \
                         {MIN_LENGTH:e} … {MAX_SCALE:e} between them (a mirror must be a step, \
                         or within one key)",
                        i + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn check_light_tracks(path: &str, tracks: &LightAnimation, light: &Light) -> Check {
    let directional = matches!(light, Light::Directional { .. });
    if let Some(track) = &tracks.position {
        let field = format!("{path}.position");
        if directional {
            return Err(SceneError::new(
                field,
                format!(
                    "lights[{}] is directional, which has no position: animate its direction",
                    tracks.light
                ),
            ));
        }
        check_point_track(&field, track)?;
        if let Light::Quad { edge_u, edge_v, .. } = light {
            // The far corner moves with the corner.
            for p in hull_points(track) {
                let far = std::array::from_fn(|c| p[c] + edge_u[c] + edge_v[c]);
                check_point(&format!("{field} + edge_u + edge_v"), &far)?;
            }
        }
    }
    if let Some(track) = &tracks.direction {
        let field = format!("{path}.direction");
        if !directional {
            return Err(SceneError::new(
                field,
                format!(
                    "lights[{}] is not directional: animate its position",
                    tracks.light
                ),
            ));
        }
        check_vector_track(&field, track)?;
        for frame in frames_of(std::iter::once(span(track))) {
            if let Light::Directional { direction, .. } = light_at(light, tracks, f64::from(frame))
            {
                check_direction(&field, &direction).map_err(|e| {
                    SceneError::new(&field, format!("at frame {frame}, {}", e.problem))
                })?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
