//! Rules of glTF 2.0 about what shrad reads past or ignores (morph targets, skins, joints
//! and weights, tangents, the layout of vertex data): broken, they change nothing shrad
//! draws, so they are warnings, never refusals. Each names the JSON path and what is wrong,
//! in the terms of the specification section it cites, so that a file that loads with
//! nothing to light still says what the Khronos glTF-Validator would say of it.
//!
//! Runs after the checks that refuse, so every index it follows exists; it looks things up
//! with `Value` indexing (Null when absent), which cannot panic.

use serde_json::{Map, Value};

use super::{AccessorInfo, JsonCheck};

/// The attributes of a primitive or a morph target: (name, accessor).
fn attributes(obj: &Value) -> Vec<(&str, usize)> {
    obj.as_object()
        .into_iter()
        .flatten()
        .filter_map(|(k, v)| Some((k.as_str(), v.as_u64()? as usize)))
        .collect()
}

fn targets(prim: &Value) -> &[Value] {
    prim["targets"].as_array().map_or(&[], Vec::as_slice)
}

pub(super) fn primitives(mesh: &Value) -> &[Value] {
    mesh["primitives"].as_array().map_or(&[], Vec::as_slice)
}

/// How many `prefix`N attribute sets `attrs` has.
fn sets(attrs: &Map<String, Value>, prefix: &str) -> usize {
    attrs.keys().filter(|k| k.starts_with(prefix)).count()
}

impl JsonCheck<'_> {
    /// Push `at: what (glTF 2.0, section)`.
    pub(super) fn lint(&mut self, at: &str, what: &str, section: &str) {
        self.warnings
            .push(format!("{at}: {what} (glTF 2.0, {section})"));
    }

    /// Every warning-only rule (see the module's doc); `accessors` as [`JsonCheck::accessors`]
    /// gave them.
    pub(super) fn lints(&mut self, accessors: &[AccessorInfo]) {
        let root = self.root;
        for (m, mesh) in root["meshes"].as_array().into_iter().flatten().enumerate() {
            self.lint_morph_counts(m, mesh);
            for (p, prim) in primitives(mesh).iter().enumerate() {
                let at = format!("meshes[{m}].primitives[{p}]");
                self.lint_attribute_types(prim, &at, accessors);
                self.lint_targets(prim, &at, accessors);
                self.lint_material_needs(prim, &at);
            }
        }
        self.lint_vertex_layout(accessors);
        self.lint_nodes();
        self.lint_skins(accessors);
        self.lint_extensions();
    }

    /// Every primitive of mesh `m` has as many morph targets, and the mesh's `weights` one
    /// for each (glTF 2.0, "Morph Targets").
    fn lint_morph_counts(&mut self, m: usize, mesh: &Value) {
        let prims = primitives(mesh);
        let n = prims.first().map_or(0, |p| targets(p).len());
        for (p, prim) in prims.iter().enumerate().skip(1) {
            let k = targets(prim).len();
            if k != n {
                self.lint(
                    &format!("meshes[{m}].primitives[{p}].targets"),
                    &format!("{k} morph target(s), but primitives[0] has {n} (all primitives of a mesh must have the same number)"),
                    "Morph Targets",
                );
            }
        }
        if let Some(w) = mesh["weights"].as_array().filter(|w| w.len() != n) {
            self.lint(
                &format!("meshes[{m}].weights"),
                &format!(
                    "{} weight(s), but the primitives have {n} morph target(s) (one weight each)",
                    w.len()
                ),
                "Morph Targets",
            );
        }
    }

    /// The component types glTF 2.0 ("Meshes", its table of attribute semantics) allows for
    /// the attributes shrad does not check elsewhere, and JOINTS_n paired with WEIGHTS_n. (A
    /// TANGENT without NORMAL is allowed: "Meshes" says the tangents are then ignored.)
    fn lint_attribute_types(&mut self, prim: &Value, at: &str, accessors: &[AccessorInfo]) {
        let q = self.quantized;
        for (name, a) in attributes(&prim["attributes"]) {
            let info = &accessors[a];
            let (ty, c, norm) = (info.ty.as_str(), info.component_type, info.normalized);
            let q_norm = q && norm && matches!(c, 5120 | 5122);
            let want = match name {
                "NORMAL" if !(ty == "VEC3" && (c == 5126 || q_norm)) => "VEC3 FLOAT",
                "TANGENT" if !(ty == "VEC4" && (c == 5126 || q_norm)) => "VEC4 FLOAT",
                n if n.starts_with("JOINTS_")
                    && !(ty == "VEC4" && !norm && matches!(c, 5121 | 5123)) =>
                {
                    "VEC4 UNSIGNED_BYTE or UNSIGNED_SHORT"
                }
                n if n.starts_with("WEIGHTS_")
                    && !(ty == "VEC4" && (c == 5126 || (norm && matches!(c, 5121 | 5123)))) =>
                {
                    "VEC4 FLOAT, or normalized UNSIGNED_BYTE or UNSIGNED_SHORT"
                }
                n if n.starts_with('_') && c == 5125 => "of any component type but UNSIGNED_INT",
                _ => continue,
            };
            self.lint(
                &format!("{at}.attributes.{name}"),
                &format!("accessor {a} is {}, but must be {want}", info.describe()),
                "Meshes",
            );
        }
        let Some(attrs) = prim["attributes"].as_object() else {
            return;
        };
        let (joints, weights) = (sets(attrs, "JOINTS_"), sets(attrs, "WEIGHTS_"));
        if joints != weights {
            self.lint(
                &format!("{at}.attributes"),
                &format!("{joints} JOINTS_n set(s) but {weights} WEIGHTS_n (each JOINTS_n has its WEIGHTS_n)"),
                "Skins",
            );
        }
    }

    /// Each morph target's attribute is one the primitive has, with as many elements as
    /// its POSITION; a target POSITION has min and max, as a base one does (glTF 2.0,
    /// "Morph Targets").
    fn lint_targets(&mut self, prim: &Value, at: &str, accessors: &[AccessorInfo]) {
        let base = &prim["attributes"];
        let vertices = base["POSITION"]
            .as_u64()
            .map(|a| accessors[a as usize].count);
        for (t, target) in targets(prim).iter().enumerate() {
            for (name, a) in attributes(target) {
                let here = format!("{at}.targets[{t}].{name}");
                let count = accessors[a].count;
                if base.get(name).is_none() {
                    let what = format!(
                        "the primitive has no {name} attribute for this target to displace"
                    );
                    self.lint(&here, &what, "Morph Targets");
                } else if let Some(n) = vertices.filter(|&n| n != count) {
                    let what = format!("accessor {a} count {count} differs from the primitive's POSITION count {n}");
                    self.lint(&here, &what, "Morph Targets");
                }
                let acc = &self.root["accessors"][a];
                if name == "POSITION" && (acc["min"].is_null() || acc["max"].is_null()) {
                    let what = format!("accessor {a} has no min and max (required on POSITION)");
                    self.lint(&here, &what, "Morph Targets");
                }
            }
        }
    }

    /// `weights` of a node has one weight for each morph target of its mesh; a node with a
    /// `skin` has a mesh whose every primitive has JOINTS_0 and WEIGHTS_0 (glTF 2.0, "Skins":
    /// "Skinned Mesh Attributes"), and is drawn in a scene that holds its skin's joints.
    fn lint_nodes(&mut self) {
        let root = self.root;
        for (i, n) in root["nodes"].as_array().into_iter().flatten().enumerate() {
            let at = format!("nodes[{i}]");
            let mesh = n["mesh"].as_u64().map(|m| &root["meshes"][m as usize]);
            let targets = mesh
                .and_then(|m| primitives(m).first())
                .map(|p| targets(p).len());
            if let (Some(w), Some(t)) = (n["weights"].as_array(), targets) {
                if w.len() != t {
                    let what = format!(
                        "{} weight(s), but its mesh has {t} morph target(s) (one weight each)",
                        w.len()
                    );
                    self.lint(&format!("{at}.weights"), &what, "Morph Targets");
                }
            }
            if n["skin"].is_null() {
                continue;
            }
            let Some(mesh) = mesh else {
                self.lint(
                    &format!("{at}.skin"),
                    "a node with a skin must have a mesh",
                    "Skins",
                );
                continue;
            };
            let skinned = |p: &Value| {
                ["JOINTS_0", "WEIGHTS_0"]
                    .iter()
                    .all(|k| p["attributes"].get(k).is_some())
            };
            if !primitives(mesh).iter().all(skinned) {
                let what = "has a skin, but its mesh's primitives have no JOINTS_0 and WEIGHTS_0 to skin with";
                self.lint(&at, what, "Skins");
            }
        }
        self.lint_skinned_scenes();
    }

    /// Every skinned node a scene draws has its skin's joints in that scene too (glTF 2.0,
    /// "Skins": the joints' world transforms place the skinned mesh).
    fn lint_skinned_scenes(&mut self) {
        let root = self.root;
        for (s, scene) in root["scenes"].as_array().into_iter().flatten().enumerate() {
            let mut inside = vec![false; self.parents.len()];
            let mut stack: Vec<usize> = index_list(&scene["nodes"]);
            while let Some(n) = stack.pop() {
                if !std::mem::replace(&mut inside[n], true) {
                    stack.extend(index_list(&root["nodes"][n]["children"]));
                }
            }
            for n in (0..inside.len()).filter(|&n| inside[n]) {
                let Some(skin) = root["nodes"][n]["skin"].as_u64() else {
                    continue;
                };
                let joints = index_list(&root["skins"][skin as usize]["joints"]);
                let missing: Vec<usize> = joints.into_iter().filter(|&j| !inside[j]).collect();
                if !missing.is_empty() {
                    let what = format!("skinned with skins[{skin}], but scenes[{s}] does not hold its joint node(s) {missing:?}");
                    self.lint(&format!("nodes[{n}]"), &what, "Skins");
                }
            }
        }
    }

    /// A skin's joints are distinct, and its inverse bind matrices MAT4 FLOAT, one for each
    /// joint at least (glTF 2.0, "Skins").
    fn lint_skins(&mut self, accessors: &[AccessorInfo]) {
        let root = self.root;
        for (i, s) in root["skins"].as_array().into_iter().flatten().enumerate() {
            let at = format!("skins[{i}]");
            let joints = index_list(&s["joints"]);
            for (k, j) in joints.iter().enumerate() {
                if joints[..k].contains(j) {
                    let what = format!("node {j} is a joint more than once");
                    self.lint(&format!("{at}.joints[{k}]"), &what, "Skins");
                }
            }
            let Some(a) = s["inverseBindMatrices"].as_u64().map(|a| a as usize) else {
                continue;
            };
            let info = &accessors[a];
            if info.ty != "MAT4" || info.component_type != 5126 || info.normalized {
                let what = format!(
                    "accessor {a} is {}, but must be MAT4 FLOAT",
                    info.describe()
                );
                self.lint(&format!("{at}.inverseBindMatrices"), &what, "Skins");
            } else if info.count < joints.len() as u64 {
                let what = format!(
                    "accessor {a} has {} matrices for {} joints",
                    info.count,
                    joints.len()
                );
                self.lint(&format!("{at}.inverseBindMatrices"), &what, "Skins");
            }
        }
    }
}

/// The indices of a JSON array of them (others left out: the refusing checks saw to them).
fn index_list(v: &Value) -> Vec<usize> {
    v.as_array()
        .into_iter()
        .flatten()
        .filter_map(|x| Some(x.as_u64()? as usize))
        .collect()
}
