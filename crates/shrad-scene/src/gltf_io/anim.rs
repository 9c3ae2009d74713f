//! glTF animations: the node hierarchy and the translation / rotation / scale channels of
//! the animations that play, read into a [`NodeGraph`]. The raw JSON of `animations` was
//! checked for references by the reader (`validate::check_json`); the rest is checked here,
//! where the accessor data is at hand: sampler interpolation, accessor types, key counts,
//! key times finite and strictly increasing, values finite. Morph-target weights, skins and
//! `KHR_animation_pointer` channels are ignored with a warning.

use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;

use crate::{AnimationInfo, GraphNode, Interpolation, NodeGraph, NodeRest, Track};

/// The animations read from one file.
pub(crate) struct Animations {
    /// The hierarchy with the playing channels; `None` when nothing moves.
    pub graph: Option<Arc<NodeGraph>>,
    /// Every animation of the file.
    pub info: Vec<AnimationInfo>,
}

/// The float components of accessor `index` (`dims` per element), normalised integers
/// converted as the specification says; all zeros for an accessor without data.
fn read_floats(
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    index: usize,
    at: &str,
) -> Result<(Vec<f32>, usize), String> {
    let acc = doc
        .accessors()
        .nth(index)
        .ok_or_else(|| format!("{at}: accessor {index} does not exist"))?;
    let dims = acc.dimensions().multiplicity();
    let count = acc.count();
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
    let unreadable = || format!("{at}: accessor {index} cannot be read");
    macro_rules! read {
        ($t:ty, $conv:expr) => {{
            match gltf::accessor::Iter::<$t>::new(acc.clone(), get) {
                Some(it) => {
                    let v: Vec<f32> = it.flat_map($conv).collect();
                    if v.len() != count * dims {
                        return Err(unreadable());
                    }
                    v
                }
                None if acc.view().is_none() && acc.sparse().is_none() => vec![0.0; count * dims],
                None => return Err(unreadable()),
            }
        }};
    }
    let norm = acc.normalized();
    let data = match (acc.dimensions(), acc.data_type(), norm) {
        (Dimensions::Scalar, DataType::F32, _) => read!(f32, |x: f32| [x]),
        (Dimensions::Vec3, DataType::F32, _) => read!([f32; 3], |x: [f32; 3]| x),
        (Dimensions::Vec4, DataType::F32, _) => read!([f32; 4], |x: [f32; 4]| x),
        (Dimensions::Vec4, DataType::I8, true) => read!([i8; 4], |x: [i8; 4]| x
            .map(|c| (f32::from(c) / 127.0).max(-1.0))),
        (Dimensions::Vec4, DataType::U8, true) => {
            read!([u8; 4], |x: [u8; 4]| x.map(|c| f32::from(c) / 255.0))
        }
        (Dimensions::Vec4, DataType::I16, true) => read!([i16; 4], |x: [i16; 4]| x
            .map(|c| (f32::from(c) / 32767.0).max(-1.0))),
        (Dimensions::Vec4, DataType::U16, true) => {
            read!([u16; 4], |x: [u16; 4]| x.map(|c| f32::from(c) / 65535.0))
        }
        _ => return Err(format!("{at}: accessor {index} has an unsupported type")),
    };
    Ok((data, dims))
}

/// What a channel animates.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
enum Path {
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

/// Describe an accessor's element type for messages ("VEC3 FLOAT").
fn describe(acc: &gltf::Accessor) -> String {
    format!(
        "{:?}{} {:?}",
        acc.dimensions(),
        if acc.normalized() { " normalized" } else { "" },
        acc.data_type()
    )
    .to_uppercase()
}

/// One sampler, read and checked once per (animation, sampler) for the path it serves.
struct Sampler {
    times: Vec<f32>,
    interpolation: Interpolation,
    input: usize,
    output: usize,
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
    let mut info = Vec::with_capacity(raw.len());
    // (node, path) -> the animation that animates it first.
    let mut taken: std::collections::HashMap<(usize, Path), String> = Default::default();
    for (ai, a) in raw.iter().enumerate() {
        let name = name_of(a, ai);
        let label = format!("animation '{name}'");
        let at = format!("animations[{ai}]");
        let playing = only.is_none_or(|o| o == ai);
        let mut entry = AnimationInfo {
            index: ai,
            name: name.clone(),
            channels: 0,
            ignored: 0,
            start: f32::INFINITY,
            end: f32::NEG_INFINITY,
            playing,
        };
        let samplers_raw = a.get("samplers").and_then(Value::as_array);
        let samplers_raw: &[Value] = samplers_raw.map_or(&[], Vec::as_slice);
        let mut samplers: Vec<Option<Sampler>> = Vec::new();
        for (k, s) in samplers_raw.iter().enumerate() {
            let here = format!("{at}.samplers[{k}]");
            let interpolation = match s.get("interpolation") {
                None | Some(Value::Null) => Interpolation::Linear,
                Some(Value::String(v)) => match v.as_str() {
                    "LINEAR" => Interpolation::Linear,
                    "STEP" => Interpolation::Step,
                    "CUBICSPLINE" => Interpolation::CubicSpline,
                    other => {
                        return Err(format!(
                            "{here}.interpolation: '{other}' is not LINEAR, STEP or CUBICSPLINE"
                        ))
                    }
                },
                Some(v) => return Err(format!("{here}.interpolation: {v} is not a string")),
            };
            let input = s["input"].as_u64().unwrap_or(0) as usize;
            let output = s["output"].as_u64().unwrap_or(0) as usize;
            let acc = doc
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
            let (times, _) = read_floats(doc, buffers, input, &format!("{here}.input"))?;
            if let Some(e) = times.iter().position(|t| !t.is_finite()) {
                return Err(format!(
                    "{here}.input: key time {e} of accessor {input} is not finite ({})",
                    times[e]
                ));
            }
            if let Some(e) = (1..times.len()).find(|&e| times[e] <= times[e - 1]) {
                return Err(format!(
                    "{here}.input: key times of accessor {input} must be strictly increasing (key {e}: {} after {})",
                    times[e],
                    times[e - 1]
                ));
            }
            if interpolation == Interpolation::CubicSpline && times.len() < 2 {
                return Err(format!(
                    "{here}: a CUBICSPLINE sampler needs at least 2 keys, accessor {input} has {}",
                    times.len()
                ));
            }
            samplers.push(Some(Sampler {
                times,
                interpolation,
                input,
                output,
            }));
        }
        let channels = a.get("channels").and_then(Value::as_array);
        let channels: &[Value] = channels.map_or(&[], Vec::as_slice);
        if channels.is_empty() {
            warnings.push(format!("{label} has no channels: nothing moves"));
        }
        for (ci, c) in channels.iter().enumerate() {
            let here = format!("{at}.channels[{ci}]");
            let target = &c["target"];
            let path = match target.get("path") {
                Some(Value::String(p)) => p.as_str(),
                None | Some(Value::Null) => {
                    return Err(format!("{here}.target.path: missing (required)"))
                }
                Some(v) => return Err(format!("{here}.target.path: {v} is not a string")),
            };
            let path = match path {
                "translation" => Path::Translation,
                "rotation" => Path::Rotation,
                "scale" => Path::Scale,
                "weights" => {
                    entry.ignored += 1;
                    if playing {
                        warnings.push(format!(
                            "{label} channel {ci} targets morph weights: ignored"
                        ));
                    }
                    continue;
                }
                "pointer" => {
                    entry.ignored += 1;
                    if playing {
                        warnings.push(format!(
                            "{label} channel {ci} is a KHR_animation_pointer channel: ignored"
                        ));
                    }
                    continue;
                }
                other => {
                    entry.ignored += 1;
                    if playing {
                        warnings.push(format!(
                            "{label} channel {ci} has the unknown target path '{other}': ignored"
                        ));
                    }
                    continue;
                }
            };
            let Some(node) = target
                .get("node")
                .and_then(Value::as_u64)
                .map(|n| n as usize)
            else {
                entry.ignored += 1;
                if playing {
                    warnings.push(format!(
                        "{label} channel {ci} has no target node (an extension's channel): ignored"
                    ));
                }
                continue;
            };
            if node >= nodes.len() {
                return Err(format!(
                    "{here}.target.node: node {node} does not exist (the file has {})",
                    nodes.len()
                ));
            }
            let si = c["sampler"].as_u64().unwrap_or(u64::MAX) as usize;
            let Some(Some(sampler)) = samplers.get(si) else {
                return Err(format!(
                    "{here}.sampler: sampler {si} does not exist (the animation has {})",
                    samplers.len()
                ));
            };
            let sh = format!("{at}.samplers[{si}].output");
            let out = doc
                .accessors()
                .nth(sampler.output)
                .ok_or_else(|| format!("{sh}: accessor {} does not exist", sampler.output))?;
            let type_ok = match path {
                Path::Translation | Path::Scale => {
                    out.dimensions() == Dimensions::Vec3 && out.data_type() == DataType::F32
                }
                Path::Rotation => {
                    out.dimensions() == Dimensions::Vec4
                        && (out.data_type() == DataType::F32
                            || (out.normalized()
                                && matches!(
                                    out.data_type(),
                                    DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
                                )))
                }
            };
            if !type_ok {
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
            let per_key = if sampler.interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            let keys = sampler.times.len();
            if out.count() != keys * per_key {
                return Err(format!(
                    "{sh}: accessor {} has {} values, but {} keys ({}.input accessor {}) need {}{}",
                    sampler.output,
                    out.count(),
                    keys,
                    format_args!("{at}.samplers[{si}]"),
                    sampler.input,
                    keys * per_key,
                    if per_key == 3 {
                        " (in-tangent, value, out-tangent per key for CUBICSPLINE)"
                    } else {
                        ""
                    }
                ));
            }
            let (values, dims) = read_floats(doc, buffers, sampler.output, &sh)?;
            if let Some(e) = values.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "{sh}: value {} of accessor {} is not finite",
                    e / dims,
                    sampler.output
                ));
            }
            if !playing {
                entry.channels += 1;
                continue;
            }
            if let Some(first) = taken.get(&(node, path)) {
                entry.ignored += 1;
                warnings.push(format!(
                    "{label} channel {ci}: node {node} {} is already animated by {first}: ignored",
                    path.name()
                ));
                continue;
            }
            taken.insert((node, path), label.clone());
            let times = sampler.times.clone();
            let interpolation = sampler.interpolation;
            let g = &mut nodes[node];
            match path {
                Path::Translation | Path::Scale => {
                    let mut v: Vec<Vec3> = values.chunks_exact(3).map(Vec3::from_slice).collect();
                    if path == Path::Scale {
                        let mut clamped = false;
                        // Tangents may be zero; only values must not collapse a surface.
                        for (e, s) in v.iter_mut().enumerate() {
                            let is_value = per_key == 1 || e % 3 == 1;
                            if is_value && s.abs().min_element() < 1e-4 {
                                clamped = true;
                                *s = Vec3::select(
                                    s.abs().cmplt(Vec3::splat(1e-4)),
                                    Vec3::splat(1e-4).copysign(*s),
                                    *s,
                                );
                            }
                        }
                        if clamped {
                            warnings.push(format!(
                                "{label} channel {ci}: scale keys with a zero component raised to 1e-4 (a surface of no area has no patches)"
                            ));
                        }
                    }
                    let track = Track {
                        times,
                        values: v,
                        interpolation,
                    };
                    if path == Path::Scale {
                        g.scale = Some(track);
                    } else {
                        g.translation = Some(track);
                    }
                }
                Path::Rotation => {
                    let mut v = Vec::with_capacity(values.len() / 4);
                    for (e, q) in values.chunks_exact(4).enumerate() {
                        let q = Quat::from_slice(q);
                        let is_value = per_key == 1 || e % 3 == 1;
                        if is_value {
                            if q.length() < 1e-6 {
                                return Err(format!(
                                    "{sh}: rotation key {} of accessor {} is a zero quaternion",
                                    e / per_key,
                                    sampler.output
                                ));
                            }
                            v.push(q.normalize());
                        } else {
                            v.push(q);
                        }
                    }
                    if per_key == 3 {
                        hemisphere_continuous(&mut v);
                    }
                    g.rotation = Some(Track {
                        times,
                        values: v,
                        interpolation,
                    });
                }
            }
            entry.channels += 1;
            entry.start = entry.start.min(sampler.times[0]);
            entry.end = entry.end.max(sampler.times[keys - 1]);
        }
        if !entry.start.is_finite() {
            entry.start = 0.0;
            entry.end = 0.0;
            if playing && entry.ignored > 0 {
                warnings.push(format!(
                    "{label} has no playable channel (only morph weights, pointers or extension channels): nothing moves"
                ));
            }
        }
        // Channels of an animation that does not play were checked; record their range.
        if !playing {
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
        info.push(entry);
    }
    let graph = nodes
        .iter()
        .any(GraphNode::is_animated)
        .then(|| Arc::new(NodeGraph { nodes }));
    Ok(Animations { graph, info })
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
