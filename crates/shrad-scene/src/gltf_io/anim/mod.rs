//! glTF animations: the node hierarchy and the translation / rotation / scale channels of
//! the animations that play, read into a [`NodeGraph`]. The raw JSON of `animations` was
//! checked for references by the reader (`validate::check_json`); the rest is checked here,
//! where the accessor data is at hand: sampler interpolation, accessor types, key counts,
//! key times finite and strictly increasing, values finite. Morph-target weights and
//! `KHR_animation_pointer` channels are ignored with a warning (and a skinned mesh is drawn
//! at rest, see `skin`, with a warning when its joints are animated).

use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;

mod data;

use data::{describe, output_type_fits, read_floats};

use crate::{AnimationInfo, GraphNode, Interpolation, NodeGraph, NodeRest, Track};

/// The animations read from one file.
pub(crate) struct Animations {
    /// The hierarchy with the playing channels; `None` when nothing moves.
    pub graph: Option<Arc<NodeGraph>>,
    /// Every animation of the file.
    pub info: Vec<AnimationInfo>,
}

/// What a channel animates.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum Path {
    Translation,
    Rotation,
    Scale,
}

impl Path {
    fn name(self) -> &'static str {
        match self {
            Path::Translation => "translation",
            Path::Rotation => "rotation",
            Path::Scale => "scale",
        }
    }
}

/// One sampler, read and checked once per (animation, sampler) for the path it serves.
struct Sampler {
    times: Vec<f32>,
    interpolation: Interpolation,
    input: usize,
    output: usize,
}

impl Sampler {
    /// A track of this sampler's keys with `values`.
    fn track<T>(&self, values: Vec<T>) -> Track<T> {
        Track {
            times: self.times.clone(),
            values,
            interpolation: self.interpolation,
        }
    }
}

/// Which animations play: all (`None`), or the one named or numbered `which`.
fn selected(raw: &[Value], which: Option<&str>) -> Result<Option<usize>, String> {
    let Some(which) = which else {
        return Ok(None);
    };
    let names: Vec<String> = raw.iter().enumerate().map(|(i, a)| name_of(a, i)).collect();
    if let Some(i) = raw
        .iter()
        .position(|a| a.get("name").and_then(Value::as_str) == Some(which))
    {
        return Ok(Some(i));
    }
    if let Ok(i) = which.trim().parse::<usize>() {
        if i < raw.len() {
            return Ok(Some(i));
        }
    }
    if raw.is_empty() {
        return Err(format!(
            "no animation '{which}': the file has no animations"
        ));
    }
    let list: Vec<String> = names
        .iter()
        .enumerate()
        .map(|(i, n)| format!("{i} '{n}'"))
        .collect();
    Err(format!(
        "no animation '{which}' (available: {})",
        list.join(", ")
    ))
}

fn name_of(a: &Value, i: usize) -> String {
    a.get("name")
        .and_then(Value::as_str)
        .filter(|s| !s.is_empty())
        .map_or_else(|| format!("animation{i}"), str::to_string)
}

/// Read the hierarchy and the animations `raw` (the file's `animations` array, references
/// already checked) that play: every one, or the one `which` names (name or index).
pub(crate) fn read(
    raw: &[Value],
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    which: Option<&str>,
    warnings: &mut Vec<String>,
) -> Result<Animations, String> {
    let only = selected(raw, which)?;
    let mut reader = Reader {
        doc,
        buffers,
        warnings,
        nodes: rest_nodes(doc),
        taken: Default::default(),
    };
    let mut info = Vec::with_capacity(raw.len());
    for (ai, a) in raw.iter().enumerate() {
        info.push(reader.animation(ai, a, only.is_none_or(|o| o == ai))?);
    }
    let nodes = reader.nodes;
    let graph = nodes
        .iter()
        .any(GraphNode::is_animated)
        .then(|| Arc::new(NodeGraph { nodes }));
    Ok(Animations { graph, info })
}

/// Every node at rest, with its parent.
fn rest_nodes(doc: &gltf::Document) -> Vec<GraphNode> {
    let mut nodes: Vec<GraphNode> = doc
        .nodes()
        .map(|n| {
            let rest = match n.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    NodeRest::Matrix(Affine3A::from_mat4(glam::Mat4::from_cols_array_2d(&matrix)))
                }
                gltf::scene::Transform::Decomposed {
                    translation,
                    rotation,
                    scale,
                } => NodeRest::Trs {
                    translation: Vec3::from(translation),
                    rotation: Quat::from_array(rotation).normalize(),
                    scale: Vec3::from(scale),
                },
            };
            let mut g = GraphNode::new(None, rest);
            g.name = n.name().map(str::to_string);
            g
        })
        .collect();
    for n in doc.nodes() {
        for c in n.children() {
            nodes[c.index()].parent = Some(n.index());
        }
    }
    nodes
}

/// The sampler `interpolation` of `s` (LINEAR when absent).
fn interpolation_of(s: &Value, here: &str) -> Result<Interpolation, String> {
    match s.get("interpolation") {
        None | Some(Value::Null) => Ok(Interpolation::Linear),
        Some(Value::String(v)) => match v.as_str() {
            "LINEAR" => Ok(Interpolation::Linear),
            "STEP" => Ok(Interpolation::Step),
            "CUBICSPLINE" => Ok(Interpolation::CubicSpline),
            other => Err(format!(
                "{here}.interpolation: '{other}' is not LINEAR, STEP or CUBICSPLINE"
            )),
        },
        Some(v) => Err(format!("{here}.interpolation: {v} is not a string")),
    }
}

/// One animation being read: how it is named in messages and whether it plays.
struct Current {
    label: String,
    at: String,
    playing: bool,
}

/// What a channel targets, once it is known to be one this reader plays.
struct Target {
    node: usize,
    path: Path,
}

/// The file's data and what the animations read so far have made of it.
struct Reader<'a> {
    doc: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    warnings: &'a mut Vec<String>,
    nodes: Vec<GraphNode>,
    /// (node, path) -> the animation that animates it first.
    taken: std::collections::HashMap<(usize, Path), String>,
}

impl Reader<'_> {
    /// Animation `ai`: its samplers and channels checked, its tracks (when it plays) put
    /// on the nodes.
    fn animation(&mut self, ai: usize, a: &Value, playing: bool) -> Result<AnimationInfo, String> {
        let name = name_of(a, ai);
        let anim = Current {
            label: format!("animation '{name}'"),
            at: format!("animations[{ai}]"),
            playing,
        };
        let mut entry = AnimationInfo {
            index: ai,
            name,
            channels: 0,
            ignored: 0,
            start: f32::INFINITY,
            end: f32::NEG_INFINITY,
            playing,
        };
        let samplers_raw = a.get("samplers").and_then(Value::as_array);
        let samplers_raw: &[Value] = samplers_raw.map_or(&[], Vec::as_slice);
        let mut samplers = Vec::with_capacity(samplers_raw.len());
        for (k, s) in samplers_raw.iter().enumerate() {
            let here = format!("{}.samplers[{k}]", anim.at);
            let sampler = match super::unpack::no_data::skipped(s) {
                Some(why) => Err(format!("{here}.{why}")),
                None => self.sampler(s, &here)?,
            };
            // A sampler that cannot play is skipped, not the file (a viewer plays the rest).
            match sampler {
                Ok(sampler) => samplers.push(Some(sampler)),
                Err(why) => {
                    self.warnings.push(format!(
                        "{}: {why}: the sampler is skipped, and its channels do not play",
                        anim.label
                    ));
                    samplers.push(None);
                }
            }
        }
        let channels = a.get("channels").and_then(Value::as_array);
        let channels: &[Value] = channels.map_or(&[], Vec::as_slice);
        if channels.is_empty() {
            self.warnings
                .push(format!("{} has no channels: nothing moves", anim.label));
        }
        for (ci, c) in channels.iter().enumerate() {
            self.channel(&mut entry, &anim, ci, c, &samplers)?;
        }
        self.close_range(&mut entry, &anim, &samplers);
        Ok(entry)
    }

    /// One sampler's key times, checked (SCALAR FLOAT, finite, strictly increasing). The
    /// inner error is a sampler to skip (with a warning): key times not strictly
    /// increasing, as an accessor without data (all zeros) has them. glTF 2.0 requires them
    /// increasing, but the glTF-Validator does not look into data that is not there, and
    /// viewers play the other channels; the outer error refuses the file.
    fn sampler(&self, s: &Value, here: &str) -> Result<Result<Sampler, String>, String> {
        let interpolation = interpolation_of(s, here)?;
        let input = s["input"].as_u64().unwrap_or(0) as usize;
        let output = s["output"].as_u64().unwrap_or(0) as usize;
        let acc = self
            .doc
            .accessors()
            .nth(input)
            .ok_or_else(|| format!("{here}.input: accessor {input} does not exist"))?;
        if acc.dimensions() != Dimensions::Scalar
            || acc.data_type() != DataType::F32
            || acc.normalized()
        {
            return Err(format!(
                "{here}.input: accessor {input} is {}, key times must be SCALAR FLOAT",
                describe(&acc)
            ));
        }
        let (times, _) = read_floats(self.doc, self.buffers, input, &format!("{here}.input"))?;
        if let Some(e) = times.iter().position(|t| !t.is_finite()) {
            return Err(format!(
                "{here}.input: key time {e} of accessor {input} is not finite ({})",
                times[e]
            ));
        }
        if let Some(e) = (1..times.len()).find(|&e| times[e] <= times[e - 1]) {
            return Ok(Err(format!(
                "{here}.input: key times of accessor {input} must be strictly increasing (key {e}: {} after {})",
                times[e],
                times[e - 1]
            )));
        }
        if interpolation == Interpolation::CubicSpline && times.len() < 2 {
            return Err(format!(
                "{here}: a CUBICSPLINE sampler needs at least 2 keys, accessor {input} has {}",
                times.len()
            ));
        }
        Ok(Ok(Sampler {
            times,
            interpolation,
            input,
            output,
        }))
    }

    /// Channel `ci`: checked always, its track put on its node when the animation plays
    /// and no earlier animation took that node's path.
    fn channel(
        &mut self,
        entry: &mut AnimationInfo,
        anim: &Current,
        ci: usize,
        c: &Value,
        samplers: &[Option<Sampler>],
    ) -> Result<(), String> {
        let here = format!("{}.channels[{ci}]", anim.at);
        let Some(Target { node, path }) = self.target(entry, anim, ci, c, &here)? else {
            return Ok(());
        };
        let si = c["sampler"].as_u64().unwrap_or(u64::MAX) as usize;
        let Some(sampler) = samplers.get(si) else {
            return Err(format!(
                "{here}.sampler: sampler {si} does not exist (the animation has {})",
                samplers.len()
            ));
        };
        let Some(sampler) = sampler else {
            // Skipped, with a warning naming the sampler.
            entry.ignored += 1;
            return Ok(());
        };
        let sh = format!("{}.samplers[{si}].output", anim.at);
        let values = self.output_values(sampler, path, &sh, &here)?;
        if !anim.playing {
            entry.channels += 1;
            return Ok(());
        }
        if let Some(first) = self.taken.get(&(node, path)) {
            entry.ignored += 1;
            self.warnings.push(format!(
                "{} channel {ci}: node {node} {} is already animated by {first}: ignored",
                anim.label,
                path.name()
            ));
            return Ok(());
        }
        self.taken.insert((node, path), anim.label.clone());
        let per_key = keys_per_value(sampler);
        match path {
            Path::Translation => self.nodes[node].translation = Some(sampler.track(vec3s(&values))),
            Path::Scale => {
                let mut v = vec3s(&values);
                if raise_collapsed_scales(&mut v, per_key) {
                    self.warnings.push(format!(
                        "{} channel {ci}: scale keys with a zero component raised to 1e-4 (a surface of no area has no patches)",
                        anim.label
                    ));
                }
                self.nodes[node].scale = Some(sampler.track(v));
            }
            Path::Rotation => {
                let v = rotations(&values, per_key, &sh, sampler.output)?;
                self.nodes[node].rotation = Some(sampler.track(v));
            }
        }
        entry.channels += 1;
        entry.start = entry.start.min(sampler.times[0]);
        entry.end = entry.end.max(sampler.times[sampler.times.len() - 1]);
        Ok(())
    }

    /// The node and path channel `ci` animates; `None` (counted as ignored, with a warning
    /// when the animation plays) for morph weights, pointers and extension channels.
    fn target(
        &mut self,
        entry: &mut AnimationInfo,
        anim: &Current,
        ci: usize,
        c: &Value,
        here: &str,
    ) -> Result<Option<Target>, String> {
        let target = &c["target"];
        let path = match target.get("path") {
            Some(Value::String(p)) => p.as_str(),
            None | Some(Value::Null) => {
                return Err(format!("{here}.target.path: missing (required)"))
            }
            Some(v) => return Err(format!("{here}.target.path: {v} is not a string")),
        };
        let ignored = match path {
            "translation" | "rotation" | "scale" => None,
            "weights" => Some("targets morph weights".to_string()),
            "pointer" => Some("is a KHR_animation_pointer channel".to_string()),
            other => Some(format!("has the unknown target path '{other}'")),
        };
        let node = target
            .get("node")
            .and_then(Value::as_u64)
            .map(|n| n as usize);
        let ignored = ignored.or_else(|| {
            node.is_none()
                .then(|| "has no target node (an extension's channel)".to_string())
        });
        if let Some(why) = ignored {
            entry.ignored += 1;
            if anim.playing {
                // Morph targets are applied with the weights at rest (`mesh.rs`).
                let rest = if path == "weights" {
                    " (morphed meshes keep their pose at rest: the node's weights, else the mesh's)"
                } else {
                    ""
                };
                self.warnings
                    .push(format!("{} channel {ci} {why}: ignored{rest}", anim.label));
            }
            return Ok(None);
        }
        let node = node.unwrap_or_default();
        if node >= self.nodes.len() {
            return Err(format!(
                "{here}.target.node: node {node} does not exist (the file has {})",
                self.nodes.len()
            ));
        }
        let path = match path {
            "translation" => Path::Translation,
            "rotation" => Path::Rotation,
            _ => Path::Scale,
        };
        Ok(Some(Target { node, path }))
    }

    /// The sampler's output for a `path` channel: type and count checked, values finite.
    fn output_values(
        &self,
        sampler: &Sampler,
        path: Path,
        sh: &str,
        here: &str,
    ) -> Result<Vec<f32>, String> {
        let out = self
            .doc
            .accessors()
            .nth(sampler.output)
            .ok_or_else(|| format!("{sh}: accessor {} does not exist", sampler.output))?;
        if !output_type_fits(&out, path) {
            let want = match path {
                Path::Rotation => "VEC4 FLOAT (or normalized BYTE / SHORT)",
                _ => "VEC3 FLOAT",
            };
            return Err(format!(
                "{sh}: accessor {} is {}, a {} channel ({here}) needs {want}",
                sampler.output,
                describe(&out),
                path.name()
            ));
        }
        let per_key = keys_per_value(sampler);
        let keys = sampler.times.len();
        if out.count() != keys * per_key {
            return Err(format!(
                "{sh}: accessor {} has {} values, but {} keys ({}.input accessor {}) need {}{}",
                sampler.output,
                out.count(),
                keys,
                sh.trim_end_matches(".output"),
                sampler.input,
                keys * per_key,
                if per_key == 3 {
                    " (in-tangent, value, out-tangent per key for CUBICSPLINE)"
                } else {
                    ""
                }
            ));
        }
        let (values, dims) = read_floats(self.doc, self.buffers, sampler.output, sh)?;
        if let Some(e) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "{sh}: value {} of accessor {} is not finite",
                e / dims,
                sampler.output
            ));
        }
        Ok(values)
    }

    /// The animation's time range: its played channels', or (when it does not play, its
    /// channels checked all the same) its samplers'; 0..0 when it has neither.
    fn close_range(
        &mut self,
        entry: &mut AnimationInfo,
        anim: &Current,
        samplers: &[Option<Sampler>],
    ) {
        if !entry.start.is_finite() {
            entry.start = 0.0;
            entry.end = 0.0;
            if anim.playing && entry.ignored > 0 {
                self.warnings.push(format!(
                    "{} has no playable channel (only morph weights, pointers, extension channels or skipped samplers): nothing moves",
                    anim.label
                ));
            }
        }
        if !anim.playing {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for s in samplers.iter().flatten() {
                lo = lo.min(s.times[0]);
                hi = hi.max(s.times[s.times.len() - 1]);
            }
            if lo.is_finite() {
                entry.start = lo;
                entry.end = hi;
            }
        }
    }
}

/// Output elements per key: 3 for CUBICSPLINE (in-tangent, value, out-tangent), else 1.
fn keys_per_value(sampler: &Sampler) -> usize {
    if sampler.interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    }
}

fn vec3s(values: &[f32]) -> Vec<Vec3> {
    values.chunks_exact(3).map(Vec3::from_slice).collect()
}

/// Scale values with a component under 1e-4 raised to it (keeping the sign); whether any
/// was. Tangents may be zero; only values must not collapse a surface.
fn raise_collapsed_scales(v: &mut [Vec3], per_key: usize) -> bool {
    let mut raised = false;
    for (e, s) in v.iter_mut().enumerate() {
        let is_value = per_key == 1 || e % 3 == 1;
        if is_value && s.abs().min_element() < 1e-4 {
            raised = true;
            *s = Vec3::select(
                s.abs().cmplt(Vec3::splat(1e-4)),
                Vec3::splat(1e-4).copysign(*s),
                *s,
            );
        }
    }
    raised
}

/// Rotation keys as quaternions: values normalised (a zero one is an error naming the key
/// of accessor `output`), cubic-spline keys made sign-continuous.
fn rotations(values: &[f32], per_key: usize, sh: &str, output: usize) -> Result<Vec<Quat>, String> {
    let mut v = Vec::with_capacity(values.len() / 4);
    for (e, q) in values.chunks_exact(4).enumerate() {
        let q = Quat::from_slice(q);
        let is_value = per_key == 1 || e % 3 == 1;
        if !is_value {
            v.push(q);
        } else if q.length() < 1e-6 {
            return Err(format!(
                "{sh}: rotation key {} of accessor {output} is a zero quaternion",
                e / per_key
            ));
        } else {
            v.push(q.normalize());
        }
    }
    if per_key == 3 {
        hemisphere_continuous(&mut v);
    }
    Ok(v)
}

/// Cubic-spline rotation keys (in-tangent, value, out-tangent per key) made sign-continuous:
/// a key whose value lies in the other hemisphere from the one before (q and -q are the
/// same rotation) is negated with its tangents. Blender's exporter writes such keys with
/// tangents that point to the continuous sign (a box turning 90 -> 200 deg about Z keyed at
/// (0, .71, 0, .71) then (.03, -.97, .17, .17), out-tangent towards the negated one); taken
/// literally the spline cuts through the origin of quaternion space, a half-turn off
/// Blender's pose between the keys. A file already continuous is unchanged; LINEAR keys
/// need nothing (slerp takes the short way, as the specification says).
fn hemisphere_continuous(keys: &mut [Quat]) {
    for k in 1..keys.len() / 3 {
        if keys[3 * k + 1].dot(keys[3 * k - 2]) < 0.0 {
            for q in &mut keys[3 * k..3 * k + 3] {
                *q = -*q;
            }
        }
    }
}
