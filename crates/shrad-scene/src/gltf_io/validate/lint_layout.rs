//! Warning-only rules (see `lint`) on how vertex and index data lie in buffer views. They
//! matter to GPU uploads, not to shrad, which reads each element wherever it lies; and a
//! file whose data is not in it is skipped before its layout is read at all.

use serde_json::Value;

use super::lint::primitives;
use super::{AccessorInfo, JsonCheck};

const ARRAY_BUFFER: u64 = 34962;
const ELEMENT_ARRAY_BUFFER: u64 = 34963;

/// One use of an accessor by a primitive: the JSON path, the accessor, what for.
struct Use {
    at: String,
    accessor: usize,
    kind: Kind,
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Attribute,
    Target,
    Indices,
}

/// Every accessor a primitive reads, in document order.
fn uses(root: &Value) -> Vec<Use> {
    let mut out = Vec::new();
    let mut push = |at: String, a: &Value, kind| {
        if let Some(a) = a.as_u64() {
            out.push(Use {
                at,
                accessor: a as usize,
                kind,
            });
        }
    };
    for (m, mesh) in root["meshes"].as_array().into_iter().flatten().enumerate() {
        for (p, prim) in primitives(mesh).iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            for (name, a) in prim["attributes"].as_object().into_iter().flatten() {
                push(format!("{at}.attributes.{name}"), a, Kind::Attribute);
            }
            let targets = prim["targets"].as_array().into_iter().flatten();
            for (t, target) in targets.enumerate() {
                for (name, a) in target.as_object().into_iter().flatten() {
                    push(format!("{at}.targets[{t}].{name}"), a, Kind::Target);
                }
            }
            push(format!("{at}.indices"), &prim["indices"], Kind::Indices);
        }
    }
    out
}

impl JsonCheck<'_> {
    /// Vertex attribute data 4-byte aligned, index data in a buffer view without
    /// `byteStride`, a `byteStride` on a view that two attribute accessors share, and each
    /// view holding one kind of data (glTF 2.0, "Buffers and Buffer Views", "Data
    /// Alignment").
    pub(super) fn lint_vertex_layout(&mut self, accessors: &[AccessorInfo]) {
        let root = self.root;
        let uses = uses(root);
        let view_of = |u: &Use| root["accessors"][u.accessor]["bufferView"].as_u64();
        let mut aligned_checked = vec![false; accessors.len()];
        for u in &uses {
            let Some(v) = view_of(u) else { continue };
            let view = &root["bufferViews"][v as usize];
            if u.kind == Kind::Indices {
                if let Some(s) = view["byteStride"].as_u64() {
                    let what = format!("bufferView {v} has byteStride {s}, which a buffer view of indices must not have");
                    self.lint(&u.at, &what, "Buffers and Buffer Views");
                }
            } else if !std::mem::replace(&mut aligned_checked[u.accessor], true) {
                self.lint_aligned(u, v, view);
            }
        }
        for v in 0..root["bufferViews"].as_array().map_or(0, Vec::len) {
            let here: Vec<&Use> = uses
                .iter()
                .filter(|u| view_of(u) == Some(v as u64))
                .collect();
            self.lint_view_uses(v, &here);
        }
    }

    /// The attribute accessor of `u` starts 4-byte aligned in buffer view `v` and in its
    /// buffer.
    fn lint_aligned(&mut self, u: &Use, v: u64, view: &Value) {
        let a = u.accessor;
        let offset = self.root["accessors"][a]["byteOffset"]
            .as_u64()
            .unwrap_or(0);
        let in_buffer = offset + view["byteOffset"].as_u64().unwrap_or(0);
        if offset % 4 != 0 || in_buffer % 4 != 0 {
            let what = format!("accessor {a} starts at byte {offset} of bufferView {v} (byte {in_buffer} of its buffer): vertex attribute data must be aligned to 4-byte boundaries");
            self.lint(&u.at, &what, "Data Alignment");
        }
    }

    /// Buffer view `v`, read by the uses `here`: vertex data or index data, not both and
    /// not against its `target`; shared by two attribute accessors only with a
    /// `byteStride`.
    fn lint_view_uses(&mut self, v: usize, here: &[&Use]) {
        let view = &self.root["bufferViews"][v];
        let target = view["target"].as_u64();
        let first_vertex = here.iter().find(|u| u.kind != Kind::Indices);
        let first_index = here.iter().find(|u| u.kind == Kind::Indices);
        let clash = match (first_vertex, first_index) {
            (Some(a), Some(b)) => Some((b, "index data", format!("vertex data at {}", a.at))),
            (Some(a), None) if target == Some(ELEMENT_ARRAY_BUFFER) => Some((
                a,
                "vertex data",
                "ELEMENT_ARRAY_BUFFER as its target".into(),
            )),
            (None, Some(b)) if target == Some(ARRAY_BUFFER) => {
                Some((b, "index data", "ARRAY_BUFFER as its target".into()))
            }
            _ => None,
        };
        if let Some((u, kind, other)) = clash {
            let what = format!("bufferView {v} is read as {kind} but has {other} (a buffer view holds vertex data or index data, not both)");
            self.lint(&u.at, &what, "Buffers and Buffer Views");
        }
        let mut attrs: Vec<&&Use> = here.iter().filter(|u| u.kind == Kind::Attribute).collect();
        attrs.dedup_by_key(|u| u.accessor);
        let shared = attrs.iter().find(|u| u.accessor != attrs[0].accessor);
        if let (Some(u), None) = (shared, view["byteStride"].as_u64()) {
            let what = format!("accessors {} and {} both read bufferView {v}, which has no byteStride (it must be defined when two or more vertex attribute accessors use one buffer view)", attrs[0].accessor, u.accessor);
            self.lint(&u.at, &what, "Buffers and Buffer Views");
        }
    }
}
