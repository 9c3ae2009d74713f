//! Where a channel's keys go: what it targets (a node's transform, or through
//! `KHR_animation_pointer` a light's property, a material's emission or a camera's field of
//! view, `pointer.rs`), and the tracks it gives the node, light or material (a camera's are
//! put in `Reader::cameras` by the caller); what shrad does not play is ignored with a
//! warning.

use serde_json::Value;

use super::pointer::{self, Pointed};
use super::values::{keys_per_value, raise_collapsed_scales, rgbs, rotations, vec3s};
use super::{Current, Owner, Path, Reader, Sampler, Target};
use crate::AnimationInfo;

impl Reader<'_> {
    /// Node `node`'s `path` (translation, rotation or scale) from `sampler`'s `values`.
    pub(super) fn node_track(
        &mut self,
        node: usize,
        path: Path,
        sampler: &Sampler,
        values: &[f32],
        (anim, ci, sh): (&Current, usize, &str),
    ) -> Result<(), String> {
        let per_key = keys_per_value(sampler);
        match path {
            Path::Translation => self.nodes[node].translation = Some(sampler.track(vec3s(values))),
            Path::Scale => {
                let mut v = vec3s(values);
                if raise_collapsed_scales(&mut v, per_key) {
                    self.warnings.push(format!(
                        "{} channel {ci}: scale keys with a zero component raised to 1e-4 (a surface of no area has no patches)",
                        anim.label
                    ));
                }
                self.nodes[node].scale = Some(sampler.track(v));
            }
            Path::Rotation => {
                let v = rotations(values, per_key, sh, sampler.output)?;
                self.nodes[node].rotation = Some(sampler.track(v));
            }
            _ => unreachable!("a node's path is its transform's (`pointer::parse`, `target`)"),
        }
        Ok(())
    }

    /// Light `l`'s `path` from `sampler`'s `values`.
    pub(super) fn light_track(&mut self, l: usize, path: Path, sampler: &Sampler, values: &[f32]) {
        let light = entry_at(&mut self.lights, l);
        match path {
            Path::LightColor => light.color = Some(sampler.track(vec3s(values))),
            Path::LightIntensity => light.intensity = Some(sampler.track(values.to_vec())),
            Path::LightRange => light.range = Some(sampler.track(values.to_vec())),
            Path::SpotInner => light.inner_cone_angle = Some(sampler.track(values.to_vec())),
            Path::SpotOuter => light.outer_cone_angle = Some(sampler.track(values.to_vec())),
            _ => unreachable!("a light's path is one of its properties (`pointer::parse`)"),
        }
    }

    /// Material `m`'s emission or base colour `path` from `sampler`'s `values`.
    pub(super) fn material_track(
        &mut self,
        m: usize,
        path: Path,
        sampler: &Sampler,
        values: &[f32],
    ) {
        let material = entry_at(&mut self.materials, m);
        match path {
            Path::EmissiveFactor => material.factor = Some(sampler.track(vec3s(values))),
            Path::EmissiveStrength => material.strength = Some(sampler.track(values.to_vec())),
            Path::BaseColorFactor => material.base_color = Some(sampler.track(rgbs(values))),
            _ => unreachable!(
                "a material's path is its emission's or base colour's (`pointer::parse`)"
            ),
        }
    }

    /// What channel `ci` animates; `None` (counted as ignored, with a warning when the
    /// animation plays) for morph weights, pointers to what shrad does not play and
    /// extension channels.
    pub(super) fn target(
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
        if path == "pointer" {
            return self.pointer_target(entry, anim, ci, target, here);
        }
        let ignored = match path {
            "translation" | "rotation" | "scale" => None,
            "weights" => Some("targets morph weights".to_string()),
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
            self.ignore(entry, anim, ci, &why, path == "weights");
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
        Ok(Some(Target {
            owner: Owner::Node(node),
            path,
        }))
    }

    /// Channel `ci` ignored (counted, with a warning when its animation plays); `morph`:
    /// it animates morph weights.
    fn ignore(
        &mut self,
        entry: &mut AnimationInfo,
        anim: &Current,
        ci: usize,
        why: &str,
        morph: bool,
    ) {
        entry.ignored += 1;
        if anim.playing {
            // Morph targets are applied with the weights at rest (`mesh.rs`).
            let rest = if morph {
                " (morphed meshes keep their pose at rest: the node's weights, else the mesh's)"
            } else {
                ""
            };
            self.warnings
                .push(format!("{} channel {ci} {why}: ignored{rest}", anim.label));
        }
    }

    /// What a `KHR_animation_pointer` channel animates (`pointer.rs`); `None` (ignored, with
    /// a warning) for a pointer to something shrad does not play or without a pointer. A
    /// pointer to a node, light, material or camera the file does not have is an error.
    fn pointer_target(
        &mut self,
        entry: &mut AnimationInfo,
        anim: &Current,
        ci: usize,
        target: &Value,
        here: &str,
    ) -> Result<Option<Target>, String> {
        let Some(text) = target
            .pointer("/extensions/KHR_animation_pointer/pointer")
            .and_then(Value::as_str)
        else {
            let why = "is a pointer channel without extensions.KHR_animation_pointer.pointer";
            self.ignore(entry, anim, ci, why, false);
            return Ok(None);
        };
        let (owner, path, count, kind) = match pointer::parse(text) {
            Pointed::Node(n, path) => (Owner::Node(n), path, self.nodes.len(), "nodes"),
            Pointed::Light(l, path) => (Owner::Light(l), path, self.counts.0, "lights"),
            Pointed::Material(m, path) => (Owner::Material(m), path, self.counts.1, "materials"),
            Pointed::Camera(c, path) => (Owner::Camera(c), path, self.counts.2, "cameras"),
            Pointed::MorphWeights => {
                self.ignore(
                    entry,
                    anim,
                    ci,
                    &format!("targets morph weights ({text})"),
                    true,
                );
                return Ok(None);
            }
            Pointed::Other => {
                let why = format!("animates {text}, which changes nothing shrad lights");
                self.ignore(entry, anim, ci, &why, false);
                return Ok(None);
            }
        };
        let (Owner::Node(i) | Owner::Light(i) | Owner::Material(i) | Owner::Camera(i)) = owner;
        if i >= count {
            return Err(format!(
                "{here}.target.extensions.KHR_animation_pointer.pointer: '{text}': the file has {count} {kind}"
            ));
        }
        Ok(Some(Target { owner, path }))
    }
}

/// `v[i]`, `v` grown with defaults to hold it (the tracks are only as long as the last
/// light or material animated).
fn entry_at<T: Default>(v: &mut Vec<T>, i: usize) -> &mut T {
    if v.len() <= i {
        v.resize_with(i + 1, T::default);
    }
    &mut v[i]
}
