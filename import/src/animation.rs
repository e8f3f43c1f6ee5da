//! glTF node animations as spindle tracks.
//!
//! glTF animates a node's `translation`, `rotation` and `scale` by samplers: key times in
//! seconds and values, interpolated LINEAR (rotations by slerp), STEP or CUBICSPLINE (a Hermite
//! curve with the file's tangents). The importer evaluates them by glTF's rules, in f64, at every
//! whole frame from the first key to the last (frame = seconds × [`FRAME_RATE`], 24 a second,
//! Blender's default; glTF has no frame rate, and Blender's exporter writes frame `f` at `f / fps`
//! seconds), composes each animated node's world matrix through its ancestors at that frame, and
//! writes one linear key a frame — as Blender's exporter samples every frame by default. A frame
//! spindle renders is whole, so it has exactly the file's value, whatever the interpolation and
//! however animated parents and children compose.
//!
//! An animated mesh node's OBJ holds its vertices in the node's own space and its object gets
//! `translate`, `rotation` and `scale` tracks (its world matrix at each frame decomposed; a world
//! matrix that shears — a non-uniform scale under a rotated child — has no such decomposition and
//! is refused naming the node and frame). An animated camera gets `position`, `look_at` and `up`
//! tracks, a point light `position`, a sun `direction`.

use std::collections::HashMap;

use glam::{DMat4, DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use spindle_common::scene::{FrameRange, Key, Quat, Track, Vec3};
use spindle_common::validate::{MAX_FRAME, MAX_KEYS};

use crate::error::ImportError;
use crate::hierarchy::local_parts;
use crate::ignored::{self, Ignored};

/// Frames a second: glTF's seconds become frames at this rate, and the scene's `frame_rate`.
pub const FRAME_RATE: f64 = 24.0;

/// One sampler's keys, read and checked.
#[derive(Debug, Clone)]
struct Sampler<const N: usize> {
    times: Vec<f64>,
    /// One value a key; for CUBICSPLINE three (in-tangent, value, out-tangent).
    values: Vec<[f64; N]>,
    interpolation: Interpolation,
}

/// The channels that animate one node.
#[derive(Debug, Clone, Default)]
struct NodeChannels {
    translation: Option<Sampler<3>>,
    rotation: Option<Sampler<4>>,
    scale: Option<Sampler<3>>,
}

/// Every node animation of a file.
#[derive(Debug, Clone)]
pub struct Animations {
    by_node: HashMap<usize, NodeChannels>,
    /// Each node's parent.
    parents: HashMap<usize, usize>,
    /// The whole frames from the first key to the last.
    pub frames: FrameRange,
}

/// Reads every animation of `document` (buffers from `buffers`); `None` when the file animates
/// no node's transform. Morph-target weights are listed in `ignored`.
pub fn read(
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    ignored: &mut Ignored,
) -> Result<Option<Animations>, ImportError> {
    let mut by_node: HashMap<usize, NodeChannels> = HashMap::new();
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    for animation in document.animations() {
        for channel in animation.channels() {
            let sampler = channel.sampler();
            let element = format!(
                "animations[{}].samplers[{}]",
                animation.index(),
                sampler.index()
            );
            let target = channel.target();
            let property = target.property();
            if property == Property::MorphTargetWeights {
                ignored.add(
                    ignored::MORPH_TARGETS,
                    format!(
                        "animations[{}].channels[{}] (weights)",
                        animation.index(),
                        channel.index()
                    ),
                );
                continue;
            }
            let node = target.node();
            if matches!(node.transform(), gltf::scene::Transform::Matrix { .. }) {
                return Err(ImportError::new(
                    format!("nodes[{}]", node.index()),
                    format!(
                        "is animated by animations[{}].channels[{}] but has a `matrix`: an \
                         animated node must give translation, rotation and scale (glTF 2.0 \
                         §5.25)",
                        animation.index(),
                        channel.index()
                    ),
                ));
            }
            let reader = channel.reader(|buffer| buffers.get(buffer.index()).map(Vec::as_slice));
            let input = sampler.input();
            crate::mesh::check_accessor_as(
                &input,
                "the input",
                &element,
                input.dimensions() == Dimensions::Scalar && input.data_type() == DataType::F32,
                "SCALAR of FLOAT",
            )?;
            let times: Vec<f64> = reader
                .read_inputs()
                .ok_or_else(|| ImportError::new(&element, "its input cannot be read"))?
                .map(f64::from)
                .collect();
            check_times(&times, &element)?;
            let output = sampler.output();
            let vec3 =
                output.dimensions() == Dimensions::Vec3 && output.data_type() == DataType::F32;
            let vec4 = output.dimensions() == Dimensions::Vec4
                && matches!(
                    output.data_type(),
                    DataType::F32 | DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
                );
            let (fits, wanted) = match property {
                Property::Rotation => (vec4, "VEC4 of FLOAT or normalised integers"),
                _ => (vec3, "VEC3 of FLOAT"),
            };
            crate::mesh::check_accessor_as(&output, "the output", &element, fits, wanted)?;
            let outputs = reader
                .read_outputs()
                .ok_or_else(|| ImportError::new(&element, "its output cannot be read"))?;
            let interpolation = sampler.interpolation();
            let entry = by_node.entry(node.index()).or_default();
            use gltf::animation::util::ReadOutputs;
            match outputs {
                ReadOutputs::Translations(values) => {
                    let values = values.map(|v| v.map(f64::from)).collect();
                    entry.translation =
                        Some(sampler_of(times.clone(), values, interpolation, &element)?);
                }
                ReadOutputs::Scales(values) => {
                    let values = values.map(|v| v.map(f64::from)).collect();
                    entry.scale = Some(sampler_of(times.clone(), values, interpolation, &element)?);
                }
                ReadOutputs::Rotations(values) => {
                    let values: Vec<[f64; 4]> =
                        values.into_f32().map(|v| v.map(f64::from)).collect();
                    let sampler = sampler_of(times.clone(), values, interpolation, &element)?;
                    if let Some(k) = sampler.values.iter().position(|q| {
                        !q.iter().all(|c| c.is_finite()) || q.iter().all(|&c| c == 0.0)
                    }) {
                        return Err(ImportError::new(
                            &element,
                            format!(
                                "output[{k}] must be a finite, non-zero quaternion, got {:?}",
                                sampler.values[k]
                            ),
                        ));
                    }
                    entry.rotation = Some(sampler);
                }
                ReadOutputs::MorphTargetWeights(_) => {}
            }
            first = first.min(times[0]);
            last = last.max(times[times.len() - 1]);
        }
    }
    if by_node.is_empty() {
        return Ok(None);
    }
    let frame = |seconds: f64| {
        (seconds * FRAME_RATE)
            .round()
            .clamp(0.0, f64::from(MAX_FRAME)) as u32
    };
    let frames = FrameRange {
        start: frame(first),
        end: frame(last),
    };
    if frames.len() > MAX_KEYS as u64 {
        return Err(ImportError::new(
            "animations",
            format!(
                "last {:.3} s, {} frames at {FRAME_RATE} a second: at most {MAX_KEYS} frames are \
                 imported",
                last - first,
                frames.len()
            ),
        ));
    }
    let mut parents = HashMap::new();
    for node in document.nodes() {
        for child in node.children() {
            parents.insert(child.index(), node.index());
        }
    }
    Ok(Some(Animations {
        by_node,
        parents,
        frames,
    }))
}

/// Key times: finite, not negative, strictly increasing.
fn check_times(times: &[f64], element: &str) -> Result<(), ImportError> {
    if times.is_empty() {
        return Err(ImportError::new(element, "has no key"));
    }
    for (k, &t) in times.iter().enumerate() {
        if !(t.is_finite() && t >= 0.0) {
            return Err(ImportError::new(
                element,
                format!("input[{k}] must be a time >= 0 in seconds, got {t}"),
            ));
        }
        if k > 0 && t <= times[k - 1] {
            return Err(ImportError::new(
                element,
                format!(
                    "its key times must increase: input[{k}] = {t} s is not after input[{}] = {} s",
                    k - 1,
                    times[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

/// A sampler whose output count fits its input (three a key for CUBICSPLINE) and whose values
/// are finite.
fn sampler_of<const N: usize>(
    times: Vec<f64>,
    values: Vec<[f64; N]>,
    interpolation: Interpolation,
    element: &str,
) -> Result<Sampler<N>, ImportError> {
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if values.len() != times.len() * per_key {
        return Err(ImportError::new(
            element,
            format!(
                "has {} outputs for {} key times ({per_key} a key for {interpolation:?})",
                values.len(),
                times.len()
            ),
        ));
    }
    if let Some(k) = values.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
        return Err(ImportError::new(
            element,
            format!("output[{k}] must be finite, got {:?}", values[k]),
        ));
    }
    Ok(Sampler {
        times,
        values,
        interpolation,
    })
}

impl<const N: usize> Sampler<N> {
    /// The key value `k` (the middle of a CUBICSPLINE triplet).
    fn value(&self, k: usize) -> [f64; N] {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// glTF's value at `t` seconds; `slerp` interpolates a LINEAR pair (rotations).
    fn at(&self, t: f64, slerp: impl Fn([f64; N], [f64; N], f64) -> [f64; N]) -> [f64; N] {
        let times = &self.times;
        let last = times.len() - 1;
        if t <= times[0] {
            return self.value(0);
        }
        if t >= times[last] {
            return self.value(last);
        }
        let k = times.partition_point(|&key| key <= t) - 1;
        let span = times[k + 1] - times[k];
        let s = (t - times[k]) / span;
        let (a, b) = (self.value(k), self.value(k + 1));
        match self.interpolation {
            Interpolation::Step => a,
            Interpolation::Linear => slerp(a, b, s),
            Interpolation::CubicSpline => {
                let out_tangent = self.values[3 * k + 2];
                let in_tangent = self.values[3 * (k + 1)];
                let (s2, s3) = (s * s, s * s * s);
                std::array::from_fn(|c| {
                    (2.0 * s3 - 3.0 * s2 + 1.0) * a[c]
                        + (s3 - 2.0 * s2 + s) * span * out_tangent[c]
                        + (-2.0 * s3 + 3.0 * s2) * b[c]
                        + (s3 - s2) * span * in_tangent[c]
                })
            }
        }
    }
}

fn lerp<const N: usize>(a: [f64; N], b: [f64; N], s: f64) -> [f64; N] {
    std::array::from_fn(|c| a[c] + (b[c] - a[c]) * s)
}

fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let (a, b) = (
        DQuat::from_array(a).normalize(),
        DQuat::from_array(b).normalize(),
    );
    a.slerp(b, s).to_array()
}

impl Animations {
    /// Whether `node` or one of its ancestors is animated.
    pub fn moves(&self, node: usize) -> bool {
        let mut at = Some(node);
        while let Some(n) = at {
            if self.by_node.contains_key(&n) {
                return true;
            }
            at = self.parents.get(&n).copied();
        }
        false
    }

    /// The seconds of `frame`.
    fn seconds(frame: u32) -> f64 {
        f64::from(frame) / FRAME_RATE
    }

    /// `node`'s world matrix at `t` seconds: its ancestors' local matrices and its own, each
    /// with its animated parts at `t`.
    fn world_at(
        &self,
        document: &gltf::Document,
        node: usize,
        t: f64,
    ) -> Result<DMat4, ImportError> {
        let mut chain = vec![node];
        while let Some(&parent) = self.parents.get(chain.last().expect("not empty")) {
            chain.push(parent);
        }
        let mut world = DMat4::IDENTITY;
        for &n in chain.iter().rev() {
            let gltf_node = document
                .nodes()
                .nth(n)
                .ok_or_else(|| ImportError::new(format!("nodes[{n}]"), "does not exist"))?;
            world *= self.local_at(&gltf_node, t)?;
        }
        Ok(world)
    }

    fn local_at(&self, node: &gltf::Node, t: f64) -> Result<DMat4, ImportError> {
        let element = format!("nodes[{}]", node.index());
        let Some(channels) = self.by_node.get(&node.index()) else {
            return crate::hierarchy::local_matrix(node, &element);
        };
        let (translation, rotation, scale) = local_parts(node, &element)?;
        let translation = channels
            .translation
            .as_ref()
            .map_or(translation, |s| DVec3::from_array(s.at(t, lerp)));
        let rotation = channels
            .rotation
            .as_ref()
            .map_or(rotation, |s| DQuat::from_array(s.at(t, slerp)).normalize());
        let scale = channels
            .scale
            .as_ref()
            .map_or(scale, |s| DVec3::from_array(s.at(t, lerp)));
        Ok(DMat4::from_scale_rotation_translation(
            scale,
            rotation,
            translation,
        ))
    }

    /// `value(world matrix at the frame, frame)` at every frame, as one linear track's keys.
    fn track<V>(
        &self,
        document: &gltf::Document,
        node: usize,
        mut value: impl FnMut(DMat4, u32) -> Result<V, ImportError>,
    ) -> Result<Track<V>, ImportError> {
        let mut keys = Vec::with_capacity(self.frames.len() as usize);
        for frame in self.frames.frames() {
            let world = self.world_at(document, node, Self::seconds(frame))?;
            keys.push(Key {
                frame: f64::from(frame),
                value: value(world, frame)?,
            });
        }
        Ok(Track {
            interpolation: spindle_common::scene::Interpolation::Linear,
            keys,
        })
    }

    /// An animated mesh node's placement at every frame: `translate`, `rotation` and `scale`
    /// tracks of its world matrix (its OBJ then holds the node's own vertices).
    pub fn placement(
        &self,
        document: &gltf::Document,
        node: usize,
    ) -> Result<Placement, ImportError> {
        let track = self.track(document, node, |world, frame| {
            let (scale, rotation, translation) = world.to_scale_rotation_translation();
            let rebuilt = DMat4::from_scale_rotation_translation(scale, rotation, translation);
            let size = world
                .to_cols_array()
                .iter()
                .fold(1.0_f64, |m, x| m.max(x.abs()));
            if !rebuilt.abs_diff_eq(world, 1e-9 * size) {
                return Err(ImportError::new(
                    format!("nodes[{node}]"),
                    format!(
                        "is animated, and at frame {frame} its world matrix shears (a \
                         non-uniform scale above a rotation), which spindle's transform (scale, \
                         rotation, translation) cannot hold"
                    ),
                ));
            }
            Ok((
                translation.to_array(),
                rotation.to_array(),
                scale.to_array(),
            ))
        })?;
        Ok((
            part(&track, |p| p.0),
            part(&track, |p| p.1),
            part(&track, |p| p.2),
        ))
    }

    /// An animated camera node's `position`, `look_at` and `up` at every frame.
    pub fn camera(
        &self,
        document: &gltf::Document,
        node: usize,
    ) -> Result<[Track<Vec3>; 3], ImportError> {
        let element = format!("nodes[{node}]");
        let track = self.track(document, node, |world, _| {
            crate::camera::pose(&world, &element)
        })?;
        Ok(std::array::from_fn(|i| part(&track, |pose| pose[i])))
    }

    /// `f(world matrix)` of an animated node at every frame (a light's position or direction).
    pub fn vectors(
        &self,
        document: &gltf::Document,
        node: usize,
        f: impl Fn(DMat4) -> Vec3,
    ) -> Result<Track<Vec3>, ImportError> {
        self.track(document, node, |world, _| Ok(f(world)))
    }
}

/// An animated object's `translate`, `rotation` and `scale` tracks.
pub type Placement = (Track<Vec3>, Track<Quat>, Track<Vec3>);

/// The track of one part of each key's value.
fn part<V, W>(track: &Track<V>, f: impl Fn(&V) -> W) -> Track<W> {
    Track {
        interpolation: track.interpolation,
        keys: track
            .keys
            .iter()
            .map(|k| Key {
                frame: k.frame,
                value: f(&k.value),
            })
            .collect(),
    }
}
