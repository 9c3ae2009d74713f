//! The data a file's meshes read: buffers, buffer views, accessors (sparse ones too) and the
//! primitives' attributes and indices.

use serde_json::Value;

use super::{array, component, join, numbers, uint, AccessorInfo, JsonCheck};
use crate::gltf_io::builder::{ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER};

/// A buffer view: (byteOffset + byteLength within its buffer, byteLength, byteStride).
type View = (u64, u64, Option<u64>);

/// (components, bytes of an element, bytes of the last element) of an accessor of type `ty`
/// whose components have `size` bytes: matrix columns start on 4-byte boundaries, and the
/// last element needs no padding after its last column. None for a type glTF 2.0 does not
/// define.
fn layout(ty: &str, size: u64) -> Option<(u64, u64, u64)> {
    let comps: u64 = match ty {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    };
    let (elem, last) = match (ty, size) {
        ("MAT2", 1) => (8, 6),
        ("MAT3", 1) => (12, 11),
        ("MAT3", 2) => (24, 22),
        _ => (comps * size, comps * size),
    };
    Some((comps, elem, last))
}

/// The elements of an accessor, as [`Element::fits`] checks them against its buffer view.
struct Element<'a> {
    size: u64,
    cname: &'a str,
    ty: &'a str,
    /// Bytes of an element and of the last one (see [`layout`]); 0 for an unknown type.
    elem: u64,
    last: u64,
    count: u64,
}

impl Element<'_> {
    /// The accessor `at`'s elements, from byte `offset` of buffer view `v`, are aligned
    /// and lie inside it.
    fn fits(&self, at: &str, offset: u64, v: usize, view: View) -> Result<(), String> {
        let (view_offset, view_len, stride) = view;
        let Element {
            size,
            cname,
            ty,
            elem,
            last,
            count,
        } = *self;
        if offset % size != 0 || (view_offset + offset) % size != 0 {
            return Err(format!(
                "{at}.byteOffset: {offset} (plus bufferView {v}'s {view_offset}) is not a multiple of the {cname} size {size}"
            ));
        }
        let stride = match stride {
            Some(s) if s < elem => {
                return Err(format!(
                    "{at}: bufferView {v}'s byteStride {s} is smaller than the {elem}-byte {ty} {cname} element"
                ))
            }
            Some(s) => s,
            None => elem,
        };
        let need =
            u128::from(offset) + u128::from(stride) * u128::from(count - 1) + u128::from(last);
        if need > u128::from(view_len) {
            return Err(format!(
                "{at}: {count} elements of {elem} bytes (stride {stride}) from byte {offset} need {need} bytes, but bufferView {v} has {view_len}"
            ));
        }
        Ok(())
    }
}

impl JsonCheck<'_> {
    /// Declared byte lengths of the buffers.
    pub(super) fn buffers(&mut self, glb_bin: Option<usize>) -> Result<Vec<u64>, String> {
        let mut out = Vec::new();
        for (i, b) in array(self.root, "buffers", "")?.iter().enumerate() {
            let at = format!("buffers[{i}]");
            let len = uint(b, "byteLength", &at)?
                .ok_or_else(|| format!("{at}.byteLength: missing (required)"))?;
            if len == 0 {
                return Err(format!("{at}.byteLength: must be at least 1"));
            }
            match b.get("uri") {
                // Buffer 0 of a GLB is its BIN chunk; any other buffer without uri is a
                // placeholder without data (EXT_meshopt_compression's fallback buffers are):
                // a buffer view that is read from one is refused when it is read.
                None | Some(Value::Null) => match glb_bin {
                    Some(n) if i == 0 && (n as u64) < len => {
                        return Err(format!(
                            "{at}: declares byteLength {len} but the GLB BIN chunk has {n} bytes (truncated file?)"
                        ))
                    }
                    _ => {}
                },
                Some(Value::String(_)) => {}
                Some(v) => return Err(format!("{at}.uri: {v} is not a string")),
            }
            out.push(len);
        }
        Ok(out)
    }

    /// (byteOffset + byteLength within its buffer, byteLength, byteStride) of each view.
    pub(super) fn buffer_views(&mut self, buffers: &[u64]) -> Result<Vec<View>, String> {
        let mut out = Vec::new();
        for (i, v) in array(self.root, "bufferViews", "")?.iter().enumerate() {
            let at = format!("bufferViews[{i}]");
            let b = self.required(v, "buffer", &at, "buffers")?;
            let offset = uint(v, "byteOffset", &at)?.unwrap_or(0);
            let len = uint(v, "byteLength", &at)?
                .ok_or_else(|| format!("{at}.byteLength: missing (required)"))?;
            if len == 0 {
                return Err(format!("{at}.byteLength: must be at least 1"));
            }
            let end = offset.saturating_add(len);
            if end > buffers[b] {
                return Err(format!(
                    "{at}: bytes {offset}..{end} lie outside buffer {b} ({} bytes)",
                    buffers[b]
                ));
            }
            let stride = uint(v, "byteStride", &at)?;
            if let Some(s) = stride {
                if !(4..=252).contains(&s) || s % 4 != 0 {
                    return Err(format!(
                        "{at}.byteStride: {s} must be a multiple of 4 in [4, 252]"
                    ));
                }
            }
            if let Some(t) = uint(v, "target", &at)? {
                if t != u64::from(ARRAY_BUFFER) && t != u64::from(ELEMENT_ARRAY_BUFFER) {
                    return Err(format!(
                        "{at}.target: {t} is neither ARRAY_BUFFER (34962) nor ELEMENT_ARRAY_BUFFER (34963)"
                    ));
                }
            }
            out.push((offset, len, stride));
        }
        Ok(out)
    }

    pub(super) fn accessors(&mut self, views: &[View]) -> Result<Vec<AccessorInfo>, String> {
        let mut out = Vec::new();
        for (i, a) in array(self.root, "accessors", "")?.iter().enumerate() {
            out.push(self.accessor(i, a, views)?);
        }
        Ok(out)
    }

    /// Accessor `i`, `a`: its component type, type, count and normalization, where its
    /// elements lie in its buffer view, its min / max and sparse parts.
    fn accessor(&mut self, i: usize, a: &Value, views: &[View]) -> Result<AccessorInfo, String> {
        let at = format!("accessors[{i}]");
        let ct = uint(a, "componentType", &at)?
            .ok_or_else(|| format!("{at}.componentType: missing (required)"))?;
        let (size, cname) = component(ct)
            .ok_or_else(|| format!("{at}.componentType: {ct} is not a glTF component type"))?;
        let ty = a
            .get("type")
            .and_then(Value::as_str)
            .ok_or_else(|| format!("{at}.type: missing or not a string (required)"))?;
        let count =
            uint(a, "count", &at)?.ok_or_else(|| format!("{at}.count: missing (required)"))?;
        if count == 0 {
            return Err(format!("{at}.count: must be at least 1"));
        }
        let normalized = match a.get("normalized") {
            None | Some(Value::Null) => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => return Err(format!("{at}.normalized: {v} is not a boolean")),
        };
        if normalized && (ct == 5126 || ct == 5125) {
            return Err(format!("{at}.normalized: must not be true for {cname}"));
        }
        let layout = layout(ty, size);
        if layout.is_none() {
            // The schema's accessor.type is any string (the listed values, "or any other
            // string", for types a later glTF may add), and the validator only warns about
            // an unknown one (VALUE_NOT_IN_LIST). shrad cannot size its elements, so such an
            // accessor is fine as long as nothing shrad reads refers to it (`reference`).
            self.warnings.push(format!(
                "{at}.type: '{ty}' is not a glTF 2.0 accessor type: the accessor is not read"
            ));
            self.unknown_accessors.push((i, ty.to_string()));
        }
        let (comps, elem, last) = layout.unwrap_or((0, 0, 0));
        let offset = uint(a, "byteOffset", &at)?;
        match self.reference(a, "bufferView", &at, "bufferViews")? {
            None if offset.is_some_and(|o| o != 0) => {
                // The specification forbids it; harmless, and some exporters write it.
                self.warnings.push(format!(
                    "{at}.byteOffset: ignored (the accessor has no bufferView)"
                ));
            }
            None => {}
            Some(v) => {
                let element = Element {
                    size,
                    cname,
                    ty,
                    elem,
                    last,
                    count,
                };
                element.fits(&at, offset.unwrap_or(0), v, views[v])?;
            }
        }
        if layout.is_some() {
            for key in ["min", "max"] {
                if a.get(key).is_some_and(|v| !v.is_null()) {
                    numbers(a, key, &at, comps as usize)?;
                }
            }
        }
        if let Some(sp) = a.get("sparse").filter(|v| !v.is_null()) {
            if layout.is_none() {
                return Err(format!(
                    "{at}.sparse: the values of an accessor of type '{ty}' cannot be sized"
                ));
            }
            self.sparse(sp, &format!("{at}.sparse"), count, elem, views)?;
        }
        Ok(AccessorInfo {
            ty: ty.to_string(),
            component_type: ct,
            normalized,
            count,
        })
    }

    fn sparse(
        &mut self,
        sp: &Value,
        at: &str,
        count: u64,
        elem: u64,
        views: &[View],
    ) -> Result<(), String> {
        let n = uint(sp, "count", at)?.ok_or_else(|| format!("{at}.count: missing (required)"))?;
        if n == 0 || n > count {
            return Err(format!(
                "{at}.count: {n} must be in [1, {count}] (the accessor's count)"
            ));
        }
        for (key, default_size) in [("indices", 0u64), ("values", elem)] {
            let here = join(at, key);
            let part = sp
                .get(key)
                .filter(|v| v.is_object())
                .ok_or_else(|| format!("{here}: missing (required)"))?;
            let v = self.required(part, "bufferView", &here, "bufferViews")?;
            let offset = uint(part, "byteOffset", &here)?.unwrap_or(0);
            let size = if key == "indices" {
                let ct = uint(part, "componentType", &here)?
                    .ok_or_else(|| format!("{here}.componentType: missing (required)"))?;
                match ct {
                    5121 => 1,
                    5123 => 2,
                    5125 => 4,
                    _ => {
                        return Err(format!(
                            "{here}.componentType: {ct} is not UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"
                        ))
                    }
                }
            } else {
                default_size
            };
            let (_, view_len, stride) = views[v];
            if stride.is_some() {
                return Err(format!(
                    "{here}: bufferView {v} of sparse {key} must not have a byteStride"
                ));
            }
            let need = u128::from(offset) + u128::from(size) * u128::from(n);
            if need > u128::from(view_len) {
                return Err(format!(
                    "{here}: {n} elements of {size} bytes from byte {offset} need {need} bytes, but bufferView {v} has {view_len}"
                ));
            }
        }
        Ok(())
    }

    pub(super) fn meshes(&mut self, accessors: &[AccessorInfo]) -> Result<(), String> {
        // POSITION accessors already warned about for having no min / max.
        let mut unbounded = Vec::new();
        for (m, mesh) in array(self.root, "meshes", "")?.iter().enumerate() {
            let at = format!("meshes[{m}]");
            let prims = array(mesh, "primitives", &at)?;
            if prims.is_empty() {
                return Err(format!("{at}.primitives: missing or empty (required)"));
            }
            for (p, prim) in prims.iter().enumerate() {
                let at = format!("{at}.primitives[{p}]");
                if !prim.is_object() {
                    return Err(format!("{at}: must be an object"));
                }
                let counts = self.attribute_accessors(prim, &at, accessors)?;
                let position = counts.iter().find(|c| c.0 == "POSITION");
                if let Some(&(_, pos, _)) = position {
                    self.position(pos, &at, accessors, &mut unbounded)?;
                } else {
                    // glTF 2.0, "Meshes": without positions a client SHOULD skip the primitive.
                    self.warnings.push(format!(
                        "{at}: primitive without POSITION skipped (nothing to draw)"
                    ));
                }
                attribute_types(&counts, &at, accessors, self.quantized)?;
                if let Some(&(_, _, n)) = position {
                    if let Some((name, a, c)) = counts.iter().find(|c| c.2 != n) {
                        return Err(format!(
                            "{at}.attributes.{name}: accessor {a} has {c} elements but POSITION has {n} (all attributes of a primitive have the same count)"
                        ));
                    }
                }
                self.indices_mode_targets(prim, &at, accessors)?;
            }
        }
        Ok(())
    }

    /// (name, accessor, count) of each attribute of primitive `at`, every name one glTF
    /// defines or application-specific (`_NAME`).
    fn attribute_accessors(
        &self,
        prim: &Value,
        at: &str,
        accessors: &[AccessorInfo],
    ) -> Result<Vec<(String, usize, u64)>, String> {
        let attrs = prim
            .get("attributes")
            .and_then(Value::as_object)
            .ok_or_else(|| format!("{at}.attributes: missing (required)"))?;
        let attrs_at = format!("{at}.attributes");
        let mut counts = Vec::new();
        for name in attrs.keys() {
            let known = ["POSITION", "NORMAL", "TANGENT"].contains(&name.as_str())
                || ["TEXCOORD_", "COLOR_", "JOINTS_", "WEIGHTS_"]
                    .iter()
                    .any(|s| {
                        name.strip_prefix(s)
                            .is_some_and(|n| !n.is_empty() && n.parse::<u32>().is_ok())
                    })
                || name.starts_with('_');
            if !known {
                return Err(format!(
                    "{attrs_at}.{name}: not a glTF attribute name (application-specific ones start with '_')"
                ));
            }
            let a = self.required(&prim["attributes"], name, &attrs_at, "accessors")?;
            counts.push((name.clone(), a, accessors[a].count));
        }
        Ok(counts)
    }

    /// The POSITION accessor `pos` of primitive `at` is VEC3 FLOAT (or integers, with
    /// KHR_mesh_quantization); one without min / max is a warning, once per accessor.
    fn position(
        &mut self,
        pos: usize,
        at: &str,
        accessors: &[AccessorInfo],
        unbounded: &mut Vec<usize>,
    ) -> Result<(), String> {
        let info = &accessors[pos];
        let quantized = self.quantized;
        let pos_ok = info.ty == "VEC3"
            && ((info.component_type == 5126 && !info.normalized)
                || (quantized && matches!(info.component_type, 5120..=5123)));
        if !pos_ok {
            return Err(format!(
                "{at}.attributes.POSITION: accessor {pos} is {}, but positions must be VEC3 FLOAT{}",
                info.describe(),
                if quantized {
                    ", or (KHR_mesh_quantization) BYTE, UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT"
                } else {
                    " (integer positions need KHR_mesh_quantization in extensionsUsed)"
                }
            ));
        }
        let pos_json = &self.root["accessors"][pos];
        // The specification requires min and max on POSITION, but some exporters leave them
        // out and three.js and Blender load such files: shrad does not use them (it bounds
        // the vertices it reads, and refuses non-finite ones), so a missing pair is a
        // warning, once per accessor.
        if (pos_json.get("min").is_none_or(Value::is_null)
            || pos_json.get("max").is_none_or(Value::is_null))
            && !unbounded.contains(&pos)
        {
            unbounded.push(pos);
            self.warnings.push(format!(
                "{at}.attributes.POSITION: accessor {pos} has no min and max (the specification requires them); bounds computed from the vertices"
            ));
        }
        Ok(())
    }

    /// Primitive `at`'s indices (an unsigned integer SCALAR), mode (0 to 6), material and
    /// morph targets refer to what exists.
    fn indices_mode_targets(
        &self,
        prim: &Value,
        at: &str,
        accessors: &[AccessorInfo],
    ) -> Result<(), String> {
        if let Some(i) = self.reference(prim, "indices", at, "accessors")? {
            let info = &accessors[i];
            if info.ty != "SCALAR"
                || !matches!(info.component_type, 5121 | 5123 | 5125)
                || info.normalized
            {
                return Err(format!(
                    "{at}.indices: accessor {i} is {}, but indices must be SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                    info.describe()
                ));
            }
        }
        self.reference(prim, "material", at, "materials")?;
        if let Some(mode) = uint(prim, "mode", at)? {
            if mode > 6 {
                return Err(format!(
                    "{at}.mode: {mode} is not a glTF primitive mode (0 to 6)"
                ));
            }
        }
        for (t, target) in array(prim, "targets", at)?.iter().enumerate() {
            let here = format!("{at}.targets[{t}]");
            let Some(obj) = target.as_object() else {
                return Err(format!("{here}: must be an object"));
            };
            for name in obj.keys() {
                self.required(target, name, &here, "accessors")?;
            }
        }
        Ok(())
    }
}

/// The texture coordinates and colours of primitive `at` have types shrad reads:
/// `TEXCOORD_n` VEC2 FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT (any integers with
/// KHR_mesh_quantization), `COLOR_n` VEC3 / VEC4 FLOAT or normalized UNSIGNED_BYTE /
/// UNSIGNED_SHORT.
fn attribute_types(
    counts: &[(String, usize, u64)],
    at: &str,
    accessors: &[AccessorInfo],
    quantized: bool,
) -> Result<(), String> {
    for (name, a, _) in counts {
        let info = &accessors[*a];
        let (ty, c, norm) = (info.ty.as_str(), info.component_type, info.normalized);
        let ok = if name.starts_with("TEXCOORD_") {
            ty == "VEC2"
                && (c == 5126
                    || (norm && matches!(c, 5121 | 5123))
                    || (quantized && matches!(c, 5120..=5123)))
        } else if name.starts_with("COLOR_") {
            matches!(ty, "VEC3" | "VEC4") && (c == 5126 || (norm && matches!(c, 5121 | 5123)))
        } else {
            true
        };
        if !ok {
            let colour = name.starts_with("COLOR_");
            return Err(format!(
                "{at}.attributes.{name}: accessor {a} is {}, but {} must be {} FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT",
                info.describe(),
                if colour { "colours" } else { "texture coordinates" },
                if colour { "VEC3 / VEC4" } else { "VEC2" },
            ));
        }
    }
    Ok(())
}
