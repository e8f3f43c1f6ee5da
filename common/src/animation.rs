//! A scene at a frame: keyframed values evaluated, and [`SceneDescription::at_frame`], the one
//! function that turns an animated scene and a frame number into a still.
//!
//! Every process that renders a frame — `spindle render` with or without the local farm, a
//! farm's workers, the benchmarks — calls [`SceneDescription::at_frame`] and renders the still it
//! returns, so a frame is a pure function of (scene, frame) and the same frame is the same bits
//! wherever it is rendered. The renderer never sees time.
//!
//! The rules, which `scenes/README.md` states for users: a frame at or before a track's first
//! key holds the first key's value, at or after its last the last's (Blender's constant
//! extrapolation); between two keys [`Interpolation`] decides. Rotations are quaternions,
//! slerped by glam (the shorter way round, as glTF's LINEAR), and become the static
//! `transform.rotate_deg` through glam's Euler decomposition in the order the transform composes
//! (`Rz·Ry·Rx`).

use glam::{DQuat, EulerRot};

use crate::scene::{
    Camera, CameraAnimation, FrameRange, Interpolation, Key, Light, LightAnimation,
    ObjectAnimation, Quat, SceneDescription, Track, Transform, Vec3,
};

/// The frames rendered when neither the command nor the scene says: frame 1 (Blender's and
/// Nuke's first frame).
pub const DEFAULT_FRAMES: FrameRange = FrameRange { start: 1, end: 1 };

impl SceneDescription {
    /// The scene at `frame`: every keyframed field given its value at that frame, and no
    /// `animation`. A scene without one is returned unchanged, so a still renders the bits it
    /// always did. The scene is expected to be valid ([`SceneDescription::validate`]); then so is
    /// the still.
    pub fn at_frame(&self, frame: u32) -> SceneDescription {
        let mut scene = self.clone();
        let Some(animation) = scene.animation.take() else {
            return scene;
        };
        let frame = f64::from(frame);
        if let Some(camera) = &animation.camera {
            scene.camera = camera_at(&scene.camera, camera, frame);
        }
        for tracks in &animation.objects {
            if let Some(object) = scene.objects.get_mut(tracks.object) {
                object.transform = transform_at(&object.transform, tracks, frame);
            }
        }
        for tracks in &animation.lights {
            if let Some(light) = scene.lights.get_mut(tracks.light) {
                *light = light_at(light, tracks, frame);
            }
        }
        scene
    }

    /// The frames the scene asks for (`animation.frames`), else [`DEFAULT_FRAMES`].
    pub fn frame_range(&self) -> FrameRange {
        self.animation
            .as_ref()
            .and_then(|a| a.frames)
            .unwrap_or(DEFAULT_FRAMES)
    }
}

/// The camera at `frame`: each track replaces its field.
pub fn camera_at(camera: &Camera, tracks: &CameraAnimation, frame: f64) -> Camera {
    let mut camera = camera.clone();
    if let Some(track) = &tracks.position {
        camera.position = sample(track, frame);
    }
    if let Some(track) = &tracks.look_at {
        camera.look_at = sample(track, frame);
    }
    if let Some(track) = &tracks.up {
        camera.up = sample(track, frame);
    }
    if let Some(track) = &tracks.fov_y {
        camera.fov_y = sample(track, frame);
    }
    camera
}

/// An object's transform at `frame`: each track replaces its field (`rotation` replaces
/// `rotate_deg`).
pub fn transform_at(transform: &Transform, tracks: &ObjectAnimation, frame: f64) -> Transform {
    let mut transform = transform.clone();
    if let Some(track) = &tracks.translate {
        transform.translate = sample(track, frame);
    }
    if let Some(track) = &tracks.rotation {
        transform.rotate_deg = rotate_deg(sample_rotation(track, frame));
    }
    if let Some(track) = &tracks.scale {
        transform.scale = sample(track, frame);
    }
    transform
}

/// A light at `frame`: `position` moves a point light's position, a sphere's centre or a
/// quad's corner; `direction` a directional light's direction. A track the light's kind has
/// not is refused by validation and ignored here.
pub fn light_at(light: &Light, tracks: &LightAnimation, frame: f64) -> Light {
    let mut light = light.clone();
    let position = tracks.position.as_ref().map(|t| sample(t, frame));
    let direction_now = tracks.direction.as_ref().map(|t| sample(t, frame));
    match &mut light {
        Light::Point { position: p, .. } => *p = position.unwrap_or(*p),
        Light::Sphere { center, .. } => *center = position.unwrap_or(*center),
        Light::Quad { corner, .. } => *corner = position.unwrap_or(*corner),
        Light::Directional { direction, .. } => *direction = direction_now.unwrap_or(*direction),
    }
    light
}

/// A value made of numbers that interpolate one by one: a number or a fixed-size array.
pub trait Components: Copy {
    /// `f` applied to the components of `self` and `other` pairwise.
    fn zip_with(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self;
    /// The components, in order.
    fn components(self) -> Vec<f64>;
}

impl Components for f64 {
    fn zip_with(self, other: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
        f(self, other)
    }
    fn components(self) -> Vec<f64> {
        vec![self]
    }
}

impl<const N: usize> Components for [f64; N] {
    fn zip_with(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        std::array::from_fn(|i| f(self[i], other[i]))
    }
    fn components(self) -> Vec<f64> {
        self.to_vec()
    }
}

/// Where a frame falls among a track's keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// At or outside the keys, or on a key: that key's value.
    Key(usize),
    /// Strictly between key `i` and key `i + 1`, at the fraction `s` in (0, 1) of the way.
    Between { i: usize, s: f64 },
}

/// Where `frame` falls among `keys` (at least one, in increasing frame order).
pub fn place<V>(keys: &[Key<V>], frame: f64) -> Place {
    let last = keys.len() - 1;
    if frame <= keys[0].frame {
        return Place::Key(0);
    }
    if frame >= keys[last].frame {
        return Place::Key(last);
    }
    // The first key past `frame`: 1 ..= last.
    let next = keys.partition_point(|k| k.frame <= frame);
    let i = next - 1;
    if keys[i].frame == frame {
        return Place::Key(i);
    }
    let s = (frame - keys[i].frame) / (keys[next].frame - keys[i].frame);
    Place::Between { i, s }
}

/// The value of `track` at `frame`.
pub fn sample<V: Components>(track: &Track<V>, frame: f64) -> V {
    let keys = &track.keys;
    match place(keys, frame) {
        Place::Key(k) => keys[k].value,
        Place::Between { i, s } => {
            let (a, b) = (keys[i].value, keys[i + 1].value);
            match track.interpolation {
                Interpolation::Step => a,
                Interpolation::Linear => a.zip_with(b, |x, y| x + (y - x) * s),
                Interpolation::Smooth => {
                    let h = keys[i + 1].frame - keys[i].frame;
                    hermite(a, slope(keys, i), b, slope(keys, i + 1), h, s)
                }
            }
        }
    }
}

/// The smooth curve's slope at key `k`, per frame: the chord of its neighbours, zero at the
/// first and last key.
pub fn slope<V: Components>(keys: &[Key<V>], k: usize) -> V {
    let zero = keys[k].value.zip_with(keys[k].value, |_, _| 0.0);
    if k == 0 || k + 1 >= keys.len() {
        return zero;
    }
    let span = keys[k + 1].frame - keys[k - 1].frame;
    keys[k + 1]
        .value
        .zip_with(keys[k - 1].value, |next, previous| (next - previous) / span)
}

/// The cubic Hermite curve from `a` (slope `ma`) to `b` (slope `mb`) over `h` frames, at the
/// fraction `s`.
fn hermite<V: Components>(a: V, ma: V, b: V, mb: V, h: f64, s: f64) -> V {
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    let values = a.zip_with(b, |x, y| x * h00 + y * h01);
    let slopes = ma.zip_with(mb, |x, y| x * (h * h10) + y * (h * h11));
    values.zip_with(slopes, |x, y| x + y)
}

/// Every value the track takes at some frame lies in the convex hull of these points: its keys
/// and, when smooth, the two inner control points of each segment's Bézier form
/// (`a + h·m_a/3`, `b − h·m_b/3`). A rule that holds on a convex set (a box, a sign, an interval)
/// holds at every frame once it holds at these.
pub fn hull_points<V: Components>(track: &Track<V>) -> Vec<V> {
    let keys = &track.keys;
    let mut points: Vec<V> = keys.iter().map(|k| k.value).collect();
    if track.interpolation == Interpolation::Smooth {
        for i in 0..keys.len().saturating_sub(1) {
            let h = keys[i + 1].frame - keys[i].frame;
            let (ma, mb) = (slope(keys, i), slope(keys, i + 1));
            points.push(keys[i].value.zip_with(ma, |x, m| x + h * m / 3.0));
            points.push(keys[i + 1].value.zip_with(mb, |x, m| x - h * m / 3.0));
        }
    }
    points
}

/// The unit quaternion of `q` (which is not zero): divided by its largest component first, so
/// no tiny or huge quaternion underflows or overflows on its way to unit length.
pub fn unit(q: Quat) -> DQuat {
    let largest = q.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    let [x, y, z, w] = q.map(|c| c / largest);
    DQuat::from_xyzw(x, y, z, w).normalize()
}

/// The rotation of `track` at `frame`, a unit quaternion.
pub fn sample_rotation(track: &Track<Quat>, frame: f64) -> DQuat {
    let keys = &track.keys;
    match place(keys, frame) {
        Place::Key(k) => unit(keys[k].value),
        Place::Between { i, s } => match track.interpolation {
            Interpolation::Step => unit(keys[i].value),
            Interpolation::Linear => unit(keys[i].value).slerp(unit(keys[i + 1].value), s),
            Interpolation::Smooth => {
                let [a, ma, b, mb] = smooth_rotation_segment(keys, i);
                let h = keys[i + 1].frame - keys[i].frame;
                let q = hermite(a, ma, b, mb, h, s);
                let length = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                if length > 0.0 {
                    DQuat::from_array(q.map(|c| c / length))
                } else {
                    DQuat::from_array(a)
                }
            }
        },
    }
}

/// The smooth rotation curve from key `i` to key `i + 1` as `[a, slope at a, b, slope at b]`
/// over unit quaternions, each key from `i − 1` to `i + 2` put on the side (sign) of its
/// neighbour toward `i`, so the curve takes the shorter way (q and −q are one rotation).
pub fn smooth_rotation_segment(keys: &[Key<Quat>], i: usize) -> [Quat; 4] {
    let side = |q: DQuat, of: DQuat| if q.dot(of) < 0.0 { -q } else { q };
    let a = unit(keys[i].value);
    let b = side(unit(keys[i + 1].value), a);
    let before = (i > 0).then(|| side(unit(keys[i - 1].value), a));
    let after = keys.get(i + 2).map(|k| side(unit(k.value), b));
    let chord = |next: DQuat, previous: DQuat, span: f64| -> Quat {
        (next - previous).to_array().map(|c| c / span)
    };
    let ma = match before {
        Some(before) => chord(b, before, keys[i + 1].frame - keys[i - 1].frame),
        None => [0.0; 4],
    };
    let mb = match after {
        Some(after) => chord(after, a, keys[i + 2].frame - keys[i].frame),
        None => [0.0; 4],
    };
    [a.to_array(), ma, b.to_array(), mb]
}

/// `rotate_deg` of a unit quaternion: the angles about x, y and z (degrees) whose
/// `Rz·Ry·Rx` is its rotation (glam's intrinsic ZYX Euler angles).
pub fn rotate_deg(q: DQuat) -> Vec3 {
    let (z, y, x) = q.to_euler(EulerRot::ZYX);
    [x.to_degrees(), y.to_degrees(), z.to_degrees()]
}

#[cfg(test)]
mod tests;
