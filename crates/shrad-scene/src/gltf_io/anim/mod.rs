//! glTF animations: the node hierarchy and the translation / rotation / scale channels of
//! the animations that play, read into a [`NodeGraph`]. The raw JSON of `animations` was
//! checked for references by the reader (`validate::check_json`); the rest is checked here,
//! where the accessor data is at hand: sampler interpolation, accessor types, key counts,
//! key times finite and strictly increasing, values finite. `KHR_animation_pointer`
//! channels play when they point at a node's transform, a punctual light's colour,
//! intensity, range or cone, a material's emission or a camera's field of view (`pointer`),
//! into tracks the lights, objects and the scene's camera take (`LightTracks`,
//! `MaterialTracks`, `Scene::camera_yfov`). Morph-target weights and other
//! pointers are ignored with a warning (and a skinned mesh is drawn at rest, see `skin`,
//! with a warning when its joints are animated).

use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;

mod data;
mod pointer;
mod targets;
mod values;

use data::{describe, output_type_fits, read_floats};
use values::keys_per_value;

use crate::{AnimationInfo, GraphNode, Interpolation, LightTracks, NodeGraph, NodeRest, Track};

/// The animations read from one file.
pub(crate) struct Animations {
    /// The hierarchy with the playing channels; `None` when nothing moves.
    pub graph: Option<Arc<NodeGraph>>,
    /// Every animation of the file.
    pub info: Vec<AnimationInfo>,
    /// `[l]`: the animated properties of the file's light `l` (empty, or past the end:
    /// none; only as long as the last light animated).
    pub lights: Vec<LightTracks>,
    /// `[m]`: the animated emission and base colour of the file's material `m` (the same),
    /// its values at rest not filled in (`MaterialTracks::with_rest_of`).
    pub materials: Vec<crate::MaterialTracks>,
    /// Camera `c`'s keyed `yfov`, by `c`.
    pub cameras: std::collections::HashMap<usize, Track<f32>>,
}

/// The tracks of a material as the reader collects them (`factor`, `strength`,
/// `base_color`), with the material's values at rest filled in for the object that takes
/// them.
impl crate::MaterialTracks {
    /// These tracks with glTF material `m`'s emission at rest; `None` when nothing of it is
    /// animated. A material with `KHR_materials_pbrSpecularGlossiness` takes its reflectance
    /// from its `diffuseFactor` (`material::base_color`), so its `baseColorFactor`'s keys
    /// change nothing and are left out.
    pub(crate) fn with_rest_of(&self, m: &gltf::Material) -> Option<crate::MaterialTracks> {
        let base_color = match m.pbr_specular_glossiness() {
            Some(_) => None,
            None => self.base_color.clone(),
        };
        let animated = self.factor.is_some() || self.strength.is_some() || base_color.is_some();
        animated.then(|| crate::MaterialTracks {
            rest_factor: Vec3::from(m.emissive_factor()),
            rest_strength: m.emissive_strength().unwrap_or(1.0),
            base_color,
            ..self.clone()
        })
    }
}

/// What a channel animates: a node's transform (the core channels, or a pointer to one),
/// a punctual light's property or a material's emission (pointers).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum Path {
    Translation,
    Rotation,
    Scale,
    LightColor,
    LightIntensity,
    LightRange,
    SpotInner,
    SpotOuter,
    EmissiveFactor,
    EmissiveStrength,
    BaseColorFactor,
    CameraYfov,
}

impl Path {
    fn name(self) -> &'static str {
        match self {
            Path::Translation => "translation",
            Path::Rotation => "rotation",
            Path::Scale => "scale",
            Path::LightColor => "color",
            Path::LightIntensity => "intensity",
            Path::LightRange => "range",
            Path::SpotInner => "spot innerConeAngle",
            Path::SpotOuter => "spot outerConeAngle",
            Path::EmissiveFactor => "emissiveFactor",
            Path::EmissiveStrength => "emissiveStrength",
            Path::BaseColorFactor => "baseColorFactor",
            Path::CameraYfov => "yfov",
        }
    }

    /// The element type its sampler's output must have, for messages.
    fn wants(self) -> &'static str {
        match self {
            Path::Rotation => "VEC4 FLOAT (or normalized BYTE / SHORT)",
            Path::BaseColorFactor => "VEC4 FLOAT",
            Path::Translation | Path::Scale | Path::LightColor | Path::EmissiveFactor => {
                "VEC3 FLOAT"
            }
            _ => "SCALAR FLOAT",
        }
    }
}

/// What a channel's path belongs to, with its index in the file.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
enum Owner {
    Node(usize),
    Light(usize),
    Material(usize),
    Camera(usize),
}

impl Owner {
    fn label(self) -> String {
        match self {
            Owner::Node(n) => format!("node {n}"),
            Owner::Light(l) => format!("light {l}"),
            Owner::Material(m) => format!("material {m}"),
            Owner::Camera(c) => format!("camera {c}"),
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
/// `lights`: how many punctual lights the file defines.
pub(crate) fn read(
    raw: &[Value],
    (doc, lights): (&gltf::Document, usize),
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
        counts: (lights, doc.materials().count(), doc.cameras().count()),
        lights: Vec::new(),
        materials: Vec::new(),
        cameras: Default::default(),
        taken: Default::default(),
    };
    let mut info = Vec::with_capacity(raw.len());
    for (ai, a) in raw.iter().enumerate() {
        info.push(reader.animation(ai, a, only.is_none_or(|o| o == ai))?);
    }
    let (nodes, lights, materials, cameras) = (
        reader.nodes,
        reader.lights,
        reader.materials,
        reader.cameras,
    );
    let graph = nodes
        .iter()
        .any(GraphNode::is_animated)
        .then(|| Arc::new(NodeGraph { nodes }));
    Ok(Animations {
        graph,
        info,
        lights,
        materials,
        cameras,
    })
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
    owner: Owner,
    path: Path,
}

/// The file's data and what the animations read so far have made of it.
struct Reader<'a> {
    doc: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    warnings: &'a mut Vec<String>,
    nodes: Vec<GraphNode>,
    /// How many lights, materials and cameras the file has (what a pointer may name).
    counts: (usize, usize, usize),
    /// `[l]`: light `l`'s tracks so far.
    lights: Vec<LightTracks>,
    /// `[m]`: material `m`'s emission tracks so far.
    materials: Vec<crate::MaterialTracks>,
    /// Camera `c`'s `yfov` track.
    cameras: std::collections::HashMap<usize, Track<f32>>,
    /// (owner, path) -> the animation that animates it first.
    taken: std::collections::HashMap<(Owner, Path), String>,
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
        let Some(Target { owner, path }) = self.target(entry, anim, ci, c, &here)? else {
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
        if let Some(first) = self.taken.get(&(owner, path)) {
            entry.ignored += 1;
            self.warnings.push(format!(
                "{} channel {ci}: {} {} is already animated by {first}: ignored",
                anim.label,
                owner.label(),
                path.name()
            ));
            return Ok(());
        }
        self.taken.insert((owner, path), anim.label.clone());
        match owner {
            Owner::Node(node) => self.node_track(node, path, sampler, &values, (anim, ci, &sh))?,
            Owner::Light(l) => self.light_track(l, path, sampler, &values),
            Owner::Material(m) => self.material_track(m, path, sampler, &values),
            Owner::Camera(c) => {
                self.cameras.insert(c, sampler.track(values));
            }
        }
        entry.channels += 1;
        entry.start = entry.start.min(sampler.times[0]);
        entry.end = entry.end.max(sampler.times[sampler.times.len() - 1]);
        Ok(())
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
            return Err(format!(
                "{sh}: accessor {} is {}, a {} channel ({here}) needs {}",
                sampler.output,
                describe(&out),
                path.name(),
                path.wants()
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
