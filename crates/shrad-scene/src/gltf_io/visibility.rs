//! `KHR_node_visibility`: a node whose `visible` is false is not drawn, nor is anything
//! below it, whatever their own `visible` (the extension's specification): its meshes and
//! punctual lights, and its descendants', are left out. Cameras are not affected. An
//! animation of `visible` (a `KHR_animation_pointer` channel, which shrad ignores with a
//! warning) does not change it: a node is as its JSON says.

use serde_json::Value;

/// The extension's name.
pub(super) const EXTENSION: &str = "KHR_node_visibility";

/// Each node's own `visible` (true where the extension is absent), checked to be a boolean.
pub(super) fn read(root: &Value) -> Result<Vec<bool>, String> {
    let nodes = root.get("nodes").and_then(Value::as_array);
    nodes
        .into_iter()
        .flatten()
        .enumerate()
        .map(
            |(n, node)| match node.pointer(&format!("/extensions/{EXTENSION}/visible")) {
                None | Some(Value::Null) => Ok(true),
                Some(Value::Bool(b)) => Ok(*b),
                Some(v) => Err(format!(
                    "nodes[{n}].extensions.{EXTENSION}.visible: {v} is not a boolean"
                )),
            },
        )
        .collect()
}
