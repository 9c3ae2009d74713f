//! The one glTF writer's binary half, shared by [`crate::write_gltf`] (scenes) and
//! `shrad::bake` (lit meshes): vertex data and indices as buffer views and accessors, with
//! the GL enums named; the one buffer; and the GLB container ([`join_glb`]).
//!
//! Each writer builds the rest of its JSON (nodes, meshes, materials, extras) as
//! `serde_json` values: their objects are sorted maps, so the bytes written do not depend on
//! the order in which fields are set. Not `gltf-json`'s typed values: the writers' extras
//! and extension objects are free-form JSON anyway, and `serde_json` keeps both outputs
//! byte for byte what they were before the two writers became one.

use glam::Vec3;
use serde_json::{json, Value};

use crate::Aabb;

pub use super::container::join_glb;

/// `bufferView.target` of vertex attributes.
pub const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` of indices.
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// `accessor.componentType` of a 32-bit float.
pub const FLOAT: u32 = 5126;
/// `accessor.componentType` of a 32-bit unsigned integer.
pub const UNSIGNED_INT: u32 = 5125;
/// `primitive.mode` of a triangle list.
pub const TRIANGLES: u32 = 4;

/// Where a glTF's one buffer is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferAt<'a> {
    /// In the GLB's BIN chunk (no `uri`).
    Glb,
    /// In the JSON, as a base64 `data:` URI.
    Embedded,
    /// In a file of this name beside the `.gltf`.
    File(&'a str),
}

/// A glTF's binary buffer being filled: every accessor with a buffer view of its own.
#[derive(Debug, Default)]
pub struct GltfBuffer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

/// The JSON arrays of a filled [`GltfBuffer`], to go in the root object under their names,
/// and the buffer's bytes.
#[derive(Debug)]
pub struct FinishedBuffer {
    /// `accessors`.
    pub accessors: Value,
    /// `bufferViews`.
    pub buffer_views: Value,
    /// `buffers` (one).
    pub buffers: Value,
    /// The buffer, a multiple of 4 bytes long.
    pub bin: Vec<u8>,
}

/// The smallest and largest coordinates of `points` (both zero when there are none), for
/// `POSITION`'s `min` and `max`.
pub fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    Aabb::from_points(points.iter().copied()).map_or((Vec3::ZERO, Vec3::ZERO), |b| (b.min, b.max))
}

impl GltfBuffer {
    /// An empty buffer.
    pub fn new() -> GltfBuffer {
        GltfBuffer::default()
    }

    /// A float `VEC3` vertex attribute (`POSITION`, `NORMAL`, `COLOR_0`, ...); `min_max`:
    /// its `min` and `max` (required on `POSITION`), spelt as the writer wants its numbers.
    /// Returns the accessor's index.
    pub fn vec3s(&mut self, values: &[Vec3], min_max: Option<(Value, Value)>) -> usize {
        let bytes = values
            .iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_le_bytes);
        let accessor = self.push(bytes, ARRAY_BUFFER, values.len(), "VEC3", FLOAT);
        if let (Some((min, max)), Some(a)) = (min_max, self.accessors[accessor].as_object_mut()) {
            a.insert("min".into(), min);
            a.insert("max".into(), max);
        }
        accessor
    }

    /// A float `VEC2` vertex attribute (`TEXCOORD_n`). Returns the accessor's index.
    pub fn vec2s(&mut self, values: &[glam::Vec2]) -> usize {
        let bytes = values
            .iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_le_bytes);
        self.push(bytes, ARRAY_BUFFER, values.len(), "VEC2", FLOAT)
    }

    /// A buffer view of `bytes` (an image's file, say), with no target and no accessor,
    /// padded to 4 bytes. Returns the buffer view's index.
    pub fn blob(&mut self, bytes: &[u8]) -> usize {
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}));
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.views.len() - 1
    }

    /// A triangle list's indices, an unsigned-int `SCALAR` accessor. Returns its index.
    pub fn triangles(&mut self, triangles: &[[u32; 3]]) -> usize {
        let bytes = triangles.iter().flatten().map(|i| i.to_le_bytes());
        let count = 3 * triangles.len();
        self.push(bytes, ELEMENT_ARRAY_BUFFER, count, "SCALAR", UNSIGNED_INT)
    }

    /// A buffer view of 4-byte elements and the accessor over all of it; its index.
    fn push(
        &mut self,
        elements: impl Iterator<Item = [u8; 4]>,
        target: u32,
        count: usize,
        kind: &str,
        component: u32,
    ) -> usize {
        let offset = self.bin.len();
        self.bin.extend(elements.flatten());
        let length = self.bin.len() - offset;
        self.views.push(json!({
            "buffer": 0, "byteOffset": offset, "byteLength": length, "target": target,
        }));
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1, "componentType": component, "count": count,
            "type": kind,
        }));
        self.accessors.len() - 1
    }

    /// The accessors, views and buffer (`at` says where its bytes are) as JSON, and the
    /// bytes.
    pub fn finish(mut self, at: BufferAt<'_>) -> FinishedBuffer {
        // Every element is 4 bytes, so this pads nothing today; a 2-byte one would need it.
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let mut buffer = json!({"byteLength": self.bin.len()});
        match at {
            BufferAt::Glb => {}
            BufferAt::Embedded => {
                buffer["uri"] = json!(format!(
                    "data:application/octet-stream;base64,{}",
                    base64::encode(&self.bin)
                ));
            }
            BufferAt::File(name) => buffer["uri"] = json!(file_uri(name)),
        }
        FinishedBuffer {
            accessors: Value::Array(self.accessors),
            buffer_views: Value::Array(self.views),
            buffers: json!([buffer]),
            bin: self.bin,
        }
    }
}

/// A file name as a relative URI (RFC 3986): every byte but the unreserved ones
/// percent-encoded, so that `50%.bin`, `a#1.bin` or `my file.bin` name themselves (written
/// raw, shrad's own reader, the validator and three.js read `50%.bin` as a broken escape
/// and `a#1.bin` as `a` with a fragment).
pub(crate) fn file_uri(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn file_names_are_percent_encoded_as_uris() {
        assert_eq!(file_uri("x.bin"), "x.bin");
        assert_eq!(file_uri("50%.bin"), "50%25.bin");
        assert_eq!(file_uri("a#1 b.bin"), "a%231%20b.bin");
        assert_eq!(file_uri("é.bin"), "%C3%A9.bin");
    }

    use super::*;

    #[test]
    fn accessors_views_and_buffer() {
        let mut b = GltfBuffer::new();
        let p = [Vec3::new(1.0, -2.0, 3.0), Vec3::new(-1.0, 4.0, 0.5)];
        let (lo, hi) = bounds(&p);
        assert_eq!(
            (lo, hi),
            (Vec3::new(-1.0, -2.0, 0.5), Vec3::new(1.0, 4.0, 3.0))
        );
        assert_eq!(bounds(&[]), (Vec3::ZERO, Vec3::ZERO));
        let pos = b.vec3s(&p, Some((json!(lo.to_array()), json!(hi.to_array()))));
        let idx = b.triangles(&[[0, 1, 1]]);
        assert_eq!((pos, idx), (0, 1));
        let f = b.finish(BufferAt::File("x.bin"));
        assert_eq!(f.bin.len(), 24 + 12);
        assert_eq!(f.bin[24..28], 0u32.to_le_bytes());
        assert_eq!(
            f.accessors,
            json!([
                {"bufferView": 0, "componentType": FLOAT, "count": 2, "type": "VEC3",
                 "min": [-1.0, -2.0, 0.5], "max": [1.0, 4.0, 3.0]},
                {"bufferView": 1, "componentType": UNSIGNED_INT, "count": 3, "type": "SCALAR"},
            ])
        );
        assert_eq!(
            f.buffer_views,
            json!([
                {"buffer": 0, "byteOffset": 0, "byteLength": 24, "target": ARRAY_BUFFER},
                {"buffer": 0, "byteOffset": 24, "byteLength": 12, "target": ELEMENT_ARRAY_BUFFER},
            ])
        );
        assert_eq!(f.buffers, json!([{"byteLength": 36, "uri": "x.bin"}]));
        let glb = GltfBuffer::new().finish(BufferAt::Glb);
        assert_eq!(glb.buffers, json!([{"byteLength": 0}]));
        let embedded = GltfBuffer::new().finish(BufferAt::Embedded);
        assert_eq!(
            embedded.buffers[0]["uri"],
            json!("data:application/octet-stream;base64,")
        );
    }
}
