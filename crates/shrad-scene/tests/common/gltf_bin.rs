//! Accessors over one embedded buffer, built up as a glTF test needs them: the shared part
//! (views, the plain accessors, the file's buffer). Test files add the accessors only they
//! need in `impl Bin` blocks of their own.

use serde_json::{json, Value};

/// Accessors over one embedded buffer.
#[derive(Default)]
pub struct Bin {
    pub bytes: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

impl Bin {
    /// A view of `bytes` (padded to 4 bytes), with `extra` JSON merged in; returns its index.
    pub fn view(&mut self, bytes: &[u8], extra: Value) -> usize {
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(bytes);
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        merge(&mut v, &extra);
        self.views.push(v);
        self.views.len() - 1
    }

    /// Accessor `a` added; returns its index.
    pub fn push(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// An accessor of `bytes` in a view of their own (`count` elements of `ty`, component
    /// type `ct`), with `extra` JSON merged in.
    pub fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        ty: &str,
        ct: u32,
        extra: Value,
    ) -> usize {
        let v = self.view(bytes, json!({}));
        let mut a = json!({"bufferView": v, "componentType": ct, "count": count, "type": ty});
        merge(&mut a, &extra);
        self.push(a)
    }

    /// A VEC3 FLOAT accessor of `data`, with min and max.
    pub fn vec3(&mut self, data: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let (lo, hi) = bounds(data);
        self.accessor(
            &bytes,
            data.len(),
            "VEC3",
            5126,
            json!({"min": lo, "max": hi}),
        )
    }

    /// A FLOAT accessor of `ty` ("SCALAR", "VEC2", "VEC3", "VEC4") over `data`; a SCALAR one
    /// (key times) with min and max when its values are finite, as glTF requires of an
    /// animation's input.
    pub fn floats_of(&mut self, ty: &str, data: &[f32]) -> usize {
        let dims = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut extra = json!({});
        if dims == 1 && data.iter().all(|x| x.is_finite()) {
            let lo = data.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = data.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            extra = json!({"min": [lo], "max": [hi]});
        }
        self.accessor(&bytes, data.len() / dims, ty, 5126, extra)
    }

    /// A SCALAR UNSIGNED_SHORT accessor of triangle indices.
    pub fn indices(&mut self, data: &[u16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let v = self.view(&bytes, json!({"target": 34963}));
        self.push(
            json!({"bufferView": v, "componentType": 5123, "count": data.len(),
                         "type": "SCALAR"}),
        )
    }

    /// The unit square (0, 0, 0) .. (1, 1, 0) facing +z as two triangles: its POSITION and
    /// index accessors.
    pub fn unit_square(&mut self) -> (usize, usize) {
        let pos = self.vec3(&[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        (pos, self.indices(&[0, 1, 2, 0, 2, 3]))
    }

    /// `root` with this buffer's accessors, views and (embedded) buffer.
    pub fn finish(self, mut root: Value) -> Value {
        root["asset"] = json!({"version": "2.0"});
        root["accessors"] = json!(self.accessors);
        root["bufferViews"] = json!(self.views);
        root["buffers"] = json!([{
            "byteLength": self.bytes.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64::encode(&self.bytes))
        }]);
        root
    }
}

/// The least and greatest of each coordinate of `data`.
pub fn bounds(data: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for e in data {
        for k in 0..3 {
            lo[k] = lo[k].min(e[k]);
            hi[k] = hi[k].max(e[k]);
        }
    }
    (lo, hi)
}

/// `extra`'s keys set on `v` (both JSON objects).
fn merge(v: &mut Value, extra: &Value) {
    if let (Some(v), Some(extra)) = (v.as_object_mut(), extra.as_object()) {
        v.extend(extra.clone());
    }
}
