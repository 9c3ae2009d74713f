//! What shrad reads from a glTF node's or mesh's `extras`: its role (`shrad_role`) and its
//! patch size (`shrad_patch_size`), as `shrad export` writes them.

use serde_json::Value;

use crate::Role;

/// The `shrad_role` and `shrad_patch_size` of a node's or mesh's extras.
pub(super) fn extras_of(
    raw: &gltf::json::Extras,
    what: &str,
) -> Result<(Option<Role>, Option<f32>), String> {
    let Some(raw) = raw else {
        return Ok((None, None));
    };
    let Ok(v) = serde_json::from_str::<Value>(raw.get()) else {
        return Ok((None, None));
    };
    let role = match v.get("shrad_role") {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(match s.as_str() {
            "boundary" => Role::Boundary,
            "interior" => Role::Interior,
            "light" => Role::Light,
            other => {
                return Err(format!(
                    "{what}: unknown shrad_role '{other}' (expected boundary, interior or light)"
                ))
            }
        }),
        Some(other) => return Err(format!("{what}: shrad_role must be a string, not {other}")),
    };
    // As a scene file's `patch_size`: a positive length (-1 and 0 gave one patch a triangle,
    // a string was ignored, silently).
    let patch = match v.get("shrad_patch_size") {
        None | Some(Value::Null) => None,
        Some(x) => match x.as_f64().map(|x| x as f32) {
            Some(h) if h.is_finite() && h > 0.0 => Some(h),
            _ => {
                return Err(format!(
                    "{what}: shrad_patch_size must be a positive number (a length in the \
                     file's units), not {x}"
                ))
            }
        },
    };
    Ok((role, patch))
}
