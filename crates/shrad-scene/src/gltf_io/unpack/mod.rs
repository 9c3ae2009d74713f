//! What the gltf crate cannot read, rewritten on the raw JSON into plain buffer views before
//! it sees the file: every decoded byte goes into one new buffer appended to the file's.
//!
//! In this order:
//! 1. `meshopt`: `EXT_meshopt_compression` and `KHR_meshopt_compression` buffer views
//!    decoded (meshopt-rs; the version 1 attribute codec by `attributes_v1`);
//!    then `no_data`: primitives and animation samplers whose data is not in the file
//!    marked to be skipped (nothing below reads them);
//! 2. `draco`: `KHR_draco_mesh_compression` primitives decoded (draco-oxide-decoder) into
//!    their accessors (as FLOAT attributes and UNSIGNED_INT indices);
//! 3. accessors without `bufferView` given one of zeros, as the specification says they are
//!    initialised (a sparse accessor's substitution is then applied on top by the reader);
//! 4. `KHR_mesh_quantization`: integer POSITION and TEXCOORD_n accessors dequantized to
//!    FLOAT (sparse substitution included). The node transform that undoes the scaling is an
//!    ordinary node transform, so nothing else changes.
//!
//! Why these crates: both are pure Rust (no C++ toolchain, nothing `unsafe` of shrad's), and
//! both are written for untrusted input. meshopt-rs (0.1) is a line-by-line port of
//! meshoptimizer's decoders, whose C++ is fuzzed upstream; it returns an error, not a panic,
//! on a truncated or malformed stream (its remaining asserts are on the caller's sizes, which
//! are checked here first). draco-oxide-decoder (Re:Earth, the PLATEAU 3D city models'
//! pipeline) decodes Draco 2.2 meshes (what Draco 1.3 and later write, gltf-pipeline and
//! Blender included; an older 2.0 / 2.1 stream is an error saying "unsupported bitstream
//! version"), and refuses a stream that declares more than it can allocate. It is an alpha,
//! and flipping bytes of a stream found a panic in it, so it runs behind its own guard
//! (`draco.rs`). The C++ bindings (`meshopt`, `draco-rs`)
//! would need a C++ build on every machine and CI, and `draco_decoder` calls itself work in
//! progress.
//!
//! Every length a stream declares is checked against [`MAX_DECODED_BYTES`] before anything
//! is allocated, and every decoded count against the accessor that declares it; indices are
//! bounds-checked against the vertex count where the mesh is read (`mesh.rs`).

mod attributes_v1;
mod draco;
mod meshopt;
pub(super) mod no_data;

use serde_json::{json, Value};

use super::builder::FLOAT;

/// Bytes all decoded buffer views, Draco attributes and zero-filled accessors of one file may
/// take together (1 GiB: about 90 million FLOAT VEC3 vertices, far beyond what shrad
/// lights). A file that declares more is refused before anything is allocated.
pub(super) const MAX_DECODED_BYTES: u64 = 1 << 30;

/// The file's buffers, and the JSON being rewritten.
pub(super) struct Unpack<'a> {
    pub(super) root: &'a mut Value,
    pub(super) buffers: &'a [Vec<u8>],
    /// The new buffer (index `buffers.len()`).
    out: Vec<u8>,
    /// Accessors given zeros by `fill_zeros` without sparse values on top: their values are
    /// not in the file (the validator does not look into them, nor do the value checks).
    zeros: Vec<usize>,
}

/// What [`unpack`] gives: the bytes of the one new buffer (empty when nothing was decoded),
/// and the accessors whose values are implicit zeros only.
pub(super) struct Unpacked {
    pub(super) bytes: Vec<u8>,
    pub(super) zeros: Vec<usize>,
    /// The instanced nodes' instances (`EXT_mesh_gpu_instancing`), read from the decoded
    /// data.
    pub(super) instances: super::instancing::FileInstances,
}

/// Rewrite `root` so that every compressed, quantized or implicit (zero) piece of data the
/// reader needs lies in a plain buffer view; returns the bytes of the one new buffer (empty
/// when nothing was decoded), whose `buffers` entry has been appended to `root`, and the
/// accessors given zeros only, with the instanced nodes' instances.
pub(super) fn unpack(root: &mut Value, buffers: &[Vec<u8>]) -> Result<Unpacked, String> {
    let mut u = Unpack {
        root,
        buffers,
        out: Vec::new(),
        zeros: Vec::new(),
    };
    meshopt::decode_views(&mut u)?;
    u.mark_without_data();
    draco::decode_primitives(&mut u)?;
    u.fill_zeros()?;
    let instances = super::instancing::read(&u)?;
    u.dequantize()?;
    let out = std::mem::take(&mut u.out);
    if !out.is_empty() {
        let buffers = u
            .root
            .as_object_mut()
            .ok_or("the JSON is not an object")?
            .entry("buffers")
            .or_insert_with(|| json!([]));
        if let Value::Array(b) = buffers {
            b.push(json!({ "byteLength": out.len(), "name": "decoded by shrad" }));
        }
    }
    Ok(Unpacked {
        bytes: out,
        zeros: u.zeros,
        instances,
    })
}

/// Size in bytes of a component type (checked by `validate`).
fn component_size(ct: u64) -> u64 {
    match ct {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    }
}

/// Components of an accessor type (checked by `validate`).
fn components(ty: &str) -> u64 {
    match ty {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        _ => 16,
    }
}

/// Bytes of one tightly packed element (matrix columns start on 4-byte boundaries).
fn element_size(ty: &str, ct: u64) -> u64 {
    match (ty, component_size(ct)) {
        ("MAT2", 1) => 8,
        ("MAT3", 1) => 12,
        ("MAT3", 2) => 24,
        (t, s) => components(t) * s,
    }
}

/// One component of type `ct` at the start of `b` as a float: normalized integers mapped to
/// [0, 1] or [-1, 1] as glTF 2.0 ("Animation", "Meshes") says, others converted as they are.
fn component_f32(b: &[u8], ct: u64, normalized: bool) -> f32 {
    let (v, max) = match ct {
        5120 => (f32::from(b[0] as i8), 127.0),
        5121 => (f32::from(b[0]), 255.0),
        5122 => (f32::from(i16::from_le_bytes([b[0], b[1]])), 32767.0),
        5123 => (f32::from(u16::from_le_bytes([b[0], b[1]])), 65535.0),
        5125 => (u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32, 1.0),
        _ => return f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    };
    if normalized {
        (v / max).max(-1.0)
    } else {
        v
    }
}

impl Unpack<'_> {
    /// Refuse `n` more decoded bytes past [`MAX_DECODED_BYTES`], before they are allocated.
    pub(super) fn budget(&self, n: u64, what: &str) -> Result<(), String> {
        let total = (self.out.len() as u64).saturating_add(n);
        if total > MAX_DECODED_BYTES {
            return Err(format!(
                "{what}: would decode to {n} bytes, past the {MAX_DECODED_BYTES} bytes shrad decodes from one file"
            ));
        }
        Ok(())
    }

    /// Append `bytes` (4-byte aligned) to the new buffer; returns its byte offset.
    pub(super) fn append(&mut self, bytes: &[u8]) -> usize {
        self.out.resize(self.out.len().next_multiple_of(4), 0);
        let at = self.out.len();
        self.out.extend_from_slice(bytes);
        at
    }

    /// Index of the new buffer.
    pub(super) fn out_buffer(&self) -> usize {
        self.buffers.len()
    }

    /// Append `bytes` as a new buffer view of the new buffer; returns its index.
    pub(super) fn push_view(&mut self, bytes: &[u8]) -> Result<usize, String> {
        let at = self.append(bytes);
        let view =
            json!({ "buffer": self.out_buffer(), "byteOffset": at, "byteLength": bytes.len() });
        let root = self
            .root
            .as_object_mut()
            .ok_or("the JSON is not an object")?;
        let views = root.entry("bufferViews").or_insert_with(|| json!([]));
        let Value::Array(views) = views else {
            return Err("bufferViews: must be an array".into());
        };
        views.push(view);
        Ok(views.len() - 1)
    }

    /// The bytes of buffer view `v` (a plain one: its buffer's data, bounds checked).
    pub(super) fn view_bytes(&self, v: usize, at: &str) -> Result<&[u8], String> {
        let view = &self.root["bufferViews"][v];
        let b = view["buffer"].as_u64().unwrap_or(0) as usize;
        let off = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = view["byteLength"].as_u64().unwrap_or(0) as usize;
        let data: &[u8] = if b == self.out_buffer() {
            &self.out
        } else {
            self.buffers.get(b).map_or(&[][..], Vec::as_slice)
        };
        data.get(off..off.saturating_add(len)).ok_or_else(|| {
            format!("{at}: bufferView {v} lies outside the data of buffer {b} ({} bytes; a buffer without uri has none)", data.len())
        })
    }

    /// Give every accessor without a bufferView one of zeros (glTF 2.0, "Accessors": "When
    /// accessor.bufferView is undefined, the sparse accessor is initialized as an array of
    /// zeros").
    fn fill_zeros(&mut self) -> Result<(), String> {
        let n = self.root["accessors"].as_array().map_or(0, Vec::len);
        for i in 0..n {
            let a = &self.root["accessors"][i];
            if a.get("bufferView").is_some_and(|v| !v.is_null()) {
                continue;
            }
            let ty = a["type"].as_str().unwrap_or("SCALAR");
            let ct = a["componentType"].as_u64().unwrap_or(FLOAT.into());
            let count = a["count"].as_u64().unwrap_or(0);
            let at = format!("accessors[{i}]");
            let bytes = element_size(ty, ct).saturating_mul(count);
            self.budget(bytes, &at)?;
            let v = self.push_view(&vec![0; bytes as usize])?;
            let a = &mut self.root["accessors"][i];
            if a.get("sparse").is_none_or(Value::is_null) {
                self.zeros.push(i);
            }
            a["bufferView"] = json!(v);
            if let Some(o) = a.as_object_mut() {
                o.remove("byteOffset");
            }
        }
        Ok(())
    }

    /// Every component of accessor `i` as floats (sparse substitution applied); the accessor
    /// has a bufferView and was bounds-checked by `validate`, and is checked again here.
    pub(super) fn read_f32(&self, i: usize) -> Result<Vec<f32>, String> {
        let at = format!("accessors[{i}]");
        let a = &self.root["accessors"][i];
        let ty = a["type"].as_str().unwrap_or("SCALAR");
        let ct = a["componentType"].as_u64().unwrap_or(FLOAT.into());
        let norm = a["normalized"].as_bool().unwrap_or(false);
        let count = a["count"].as_u64().unwrap_or(0) as usize;
        let (nc, cs) = (components(ty) as usize, component_size(ct) as usize);
        let v = a["bufferView"].as_u64().unwrap_or(0) as usize;
        let stride = self.root["bufferViews"][v]["byteStride"]
            .as_u64()
            .map_or(nc * cs, |s| s as usize);
        let offset = a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let data = self.view_bytes(v, &at)?;
        let short = || format!("{at}: {count} elements do not fit in bufferView {v}");
        let mut out = Vec::with_capacity(count * nc);
        for k in 0..count {
            let e = offset + k * stride;
            let elem = data.get(e..e + nc * cs).ok_or_else(short)?;
            out.extend(elem.chunks_exact(cs).map(|c| component_f32(c, ct, norm)));
        }
        if let Some(sp) = a.get("sparse").filter(|s| s.is_object()) {
            let n = sp["count"].as_u64().unwrap_or(0) as usize;
            let ind = &sp["indices"];
            let ict = ind["componentType"].as_u64().unwrap_or(5125);
            let ics = component_size(ict) as usize;
            let iv = ind["bufferView"].as_u64().unwrap_or(0) as usize;
            let io = ind["byteOffset"].as_u64().unwrap_or(0) as usize;
            let idx = self.view_bytes(iv, &format!("{at}.sparse.indices"))?;
            let vals = &sp["values"];
            let vv = vals["bufferView"].as_u64().unwrap_or(0) as usize;
            let vo = vals["byteOffset"].as_u64().unwrap_or(0) as usize;
            let val = self.view_bytes(vv, &format!("{at}.sparse.values"))?;
            for s in 0..n {
                let ib = idx
                    .get(io + s * ics..io + (s + 1) * ics)
                    .ok_or_else(|| format!("{at}.sparse.indices: outside bufferView {iv}"))?;
                let k = ib
                    .iter()
                    .rev()
                    .fold(0usize, |acc, &b| acc << 8 | b as usize);
                let vb = val
                    .get(vo + s * nc * cs..vo + (s + 1) * nc * cs)
                    .ok_or_else(|| format!("{at}.sparse.values: outside bufferView {vv}"))?;
                let dst = out.get_mut(k * nc..(k + 1) * nc).ok_or_else(|| {
                    format!("{at}.sparse.indices: index {k} is not below the count {count}")
                })?;
                for (d, c) in dst.iter_mut().zip(vb.chunks_exact(cs)) {
                    *d = component_f32(c, ct, norm);
                }
            }
        }
        Ok(out)
    }

    /// Replace accessor `i`'s data by `values` (FLOAT, tightly packed, no sparse part).
    pub(super) fn set_f32(&mut self, i: usize, values: &[f32]) -> Result<(), String> {
        let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.push_view(&bytes)?;
        let a = &mut self.root["accessors"][i];
        a["bufferView"] = json!(v);
        a["componentType"] = json!(FLOAT);
        if let Some(o) = a.as_object_mut() {
            for key in ["byteOffset", "normalized", "sparse"] {
                o.remove(key);
            }
        }
        Ok(())
    }

    /// `KHR_mesh_quantization`: integer POSITION and TEXCOORD_n accessors of every primitive
    /// (morph targets are not read) dequantized to FLOAT.
    fn dequantize(&mut self) -> Result<(), String> {
        let mut todo: Vec<usize> = Vec::new();
        for mesh in self.root["meshes"].as_array().into_iter().flatten() {
            for prim in mesh["primitives"].as_array().into_iter().flatten() {
                if no_data::skipped(prim).is_some() {
                    continue;
                }
                let Some(attrs) = prim["attributes"].as_object() else {
                    continue;
                };
                for (name, a) in attrs {
                    if name == "POSITION" || name.starts_with("TEXCOORD_") {
                        todo.extend(a.as_u64().map(|a| a as usize));
                    }
                }
            }
        }
        todo.sort_unstable();
        todo.dedup();
        for i in todo {
            let a = &self.root["accessors"][i];
            if a["componentType"].as_u64() == Some(FLOAT.into()) {
                continue;
            }
            let count = a["count"].as_u64().unwrap_or(0);
            let nc = components(a["type"].as_str().unwrap_or("SCALAR"));
            self.budget(count * nc * 4, &format!("accessors[{i}]"))?;
            let values = self.read_f32(i)?;
            self.set_f32(i, &values)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalized_integers_follow_the_specification() {
        assert_eq!(component_f32(&[0x81], 5120, true), -1.0);
        assert_eq!(component_f32(&[0x80], 5120, true), -1.0);
        assert_eq!(component_f32(&[127], 5120, true), 1.0);
        assert_eq!(component_f32(&[255], 5121, true), 1.0);
        assert_eq!(component_f32(&[0xff, 0xff], 5123, true), 1.0);
        assert_eq!(component_f32(&[0x00, 0x80], 5122, false), -32768.0);
        assert_eq!(component_f32(&[7, 0], 5123, false), 7.0);
    }

    #[test]
    fn zeros_then_sparse_then_dequantized() {
        // A quantized (SHORT) POSITION accessor without bufferView, two vertices replaced by
        // a sparse part: vertex 1 = (1, 2, 3).
        let mut buf = vec![1u8, 0]; // sparse index 1 (UNSIGNED_SHORT)
        buf.extend([0, 0]); // padding
        for v in [1i16, 2, 3] {
            buf.extend(v.to_le_bytes());
        }
        let mut root = json!({
            "buffers": [{"byteLength": buf.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 2},
                {"buffer": 0, "byteOffset": 4, "byteLength": 6}
            ],
            "accessors": [{
                "componentType": 5122, "type": "VEC3", "count": 3,
                "sparse": {"count": 1,
                    "indices": {"bufferView": 0, "componentType": 5123},
                    "values": {"bufferView": 1}}
            }],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}]
        });
        let out = unpack(&mut root, &[buf.clone()]).unwrap().bytes;
        let a = &root["accessors"][0];
        assert_eq!(a["componentType"], 5126);
        assert!(a.get("sparse").is_none());
        let v = &root["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        assert_eq!(v["buffer"], 1);
        let off = v["byteOffset"].as_u64().unwrap() as usize;
        let floats: Vec<f32> = out[off..off + 36]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(floats, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
        assert_eq!(root["buffers"][1]["byteLength"], out.len());
    }

    #[test]
    fn hostile_counts_are_refused_before_allocating() {
        let mut root = json!({
            "accessors": [{"componentType": 5126, "type": "MAT4", "count": 1u64 << 40}]
        });
        let e = unpack(&mut root, &[]).err().unwrap();
        assert!(e.starts_with("accessors[0]: would decode to"), "{e}");
    }
}
