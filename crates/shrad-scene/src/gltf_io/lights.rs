//! `KHR_lights_punctual`: the file's light list (`extensions.KHR_lights_punctual.lights`)
//! and the nodes that instance a light (`nodes[i].extensions.KHR_lights_punctual.light`),
//! read from the raw JSON (the gltf crate is built without the extension). Every value is
//! checked here, and a bad one is an error naming its JSON path: a negative intensity, a
//! range that is not positive, `innerConeAngle >= outerConeAngle`, an outer cone beyond
//! pi/2, a light index out of range, an unknown type.

use serde_json::Value;

use crate::{ConeFalloff, Light, LightKind};

/// The extension's name.
pub(super) const EXTENSION: &str = "KHR_lights_punctual";

/// The file's lights (at the origin, shining along -Z: the walk puts them on their nodes)
/// and, per node, the light it instances.
#[derive(Clone, Debug, Default)]
pub(super) struct FileLights {
    /// `extensions.KHR_lights_punctual.lights`, in order (`None`: an unknown type, ignored).
    pub(super) lights: Vec<Option<Light>>,
    /// `[node]`: the index into `lights` of the light the node instances.
    pub(super) node_light: Vec<Option<usize>>,
}

fn number(obj: &Value, key: &str, at: &str, default: f64) -> Result<f64, String> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(default),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{at}.{key}: {v} is not a finite number")),
    }
}

/// A spot's cones, checked (`at` the light's JSON path); equal cones are Blender's blend of
/// 0 in a file Blender wrote (`blender`), else an error.
fn spot(v: &Value, at: &str, blender: bool) -> Result<LightKind, String> {
    let spot = v.get("spot").cloned().unwrap_or(Value::Null);
    let here = format!("{at}.spot");
    let inner = number(&spot, "innerConeAngle", &here, 0.0)?;
    let outer = number(&spot, "outerConeAngle", &here, std::f64::consts::FRAC_PI_4)?;
    if outer <= 0.0 {
        return Err(format!(
            "{here}.outerConeAngle: {outer} must be > 0 (a spot of no cone lights nothing)"
        ));
    }
    if inner < 0.0 {
        return Err(format!("{here}.innerConeAngle: {inner} must be >= 0"));
    }
    if inner >= outer && !(blender && inner == outer) {
        // Blender's exporter writes inner = outer (1 - blend): equal cones for a spot of
        // blend 0, which the extension forbids (read as Blender means them in its files).
        let hint = if inner == outer {
            " (equal cones are how Blender writes a spot of blend 0, and are read so when asset.generator names Blender; this file's does not)"
        } else {
            ""
        };
        return Err(format!(
            "{here}.innerConeAngle: {inner} must be less than outerConeAngle ({outer}){hint}"
        ));
    }
    if outer > std::f64::consts::FRAC_PI_2 + 1e-9 {
        return Err(format!(
            "{here}.outerConeAngle: {outer} is beyond pi/2 (the extension's maximum)"
        ));
    }
    Ok(LightKind::Spot {
        inner_cone_angle: inner as f32,
        outer_cone_angle: (outer as f32).min(std::f32::consts::FRAC_PI_2),
    })
}

/// Light `i` of the list, checked; `None` for a type the extension does not define (the
/// glTF validator accepts it, so it is warned about and ignored). In a file Blender wrote
/// (`blender`) a spot falls off as Blender's blend does ([`ConeFalloff::Blender`]), and its
/// blend of 0, written as equal cones, is a hard edge.
fn light(
    v: &Value,
    i: usize,
    blender: bool,
    warnings: &mut Vec<String>,
) -> Result<Option<Light>, String> {
    let at = format!("extensions.{EXTENSION}.lights[{i}]");
    if !v.is_object() {
        return Err(format!("{at}: must be an object, not {v}"));
    }
    let ty = v.get("type").and_then(Value::as_str).ok_or_else(|| {
        format!("{at}.type: missing (required: \"point\", \"spot\" or \"directional\")")
    })?;
    let kind = match ty {
        "point" => LightKind::Point,
        "directional" => LightKind::Directional,
        "spot" => spot(v, &at, blender)?,
        other => {
            warnings.push(format!(
                "{at}.type: '{other}' is not a punctual light type (\"point\", \"spot\" or \"directional\"): the light is ignored"
            ));
            return Ok(None);
        }
    };
    let intensity = number(v, "intensity", &at, 1.0)?;
    if intensity < 0.0 {
        return Err(format!("{at}.intensity: {intensity} must be >= 0"));
    }
    let color = match v.get("color") {
        None | Some(Value::Null) => glam::Vec3::ONE,
        Some(Value::Array(c)) if c.len() == 3 => {
            let mut out = [0f32; 3];
            for (k, x) in c.iter().enumerate() {
                match x.as_f64() {
                    Some(x) if x.is_finite() && x >= 0.0 => out[k] = x as f32,
                    _ => return Err(format!("{at}.color[{k}]: {x} must be a number >= 0")),
                }
            }
            glam::Vec3::from(out)
        }
        Some(c) => {
            return Err(format!(
                "{at}.color: must be an array of 3 numbers, not {c}"
            ))
        }
    };
    let range = match v.get("range") {
        None | Some(Value::Null) => None,
        Some(_) if kind == LightKind::Directional => None,
        Some(_) => {
            let r = number(v, "range", &at, 0.0)?;
            if r <= 0.0 {
                return Err(format!("{at}.range: {r} must be > 0"));
            }
            Some(r as f32)
        }
    };
    let name = v
        .get("name")
        .and_then(Value::as_str)
        .map_or_else(|| format!("light{i}"), str::to_string);
    let cone_falloff = match kind {
        LightKind::Spot { .. } if blender => ConeFalloff::Blender,
        _ => ConeFalloff::Gltf,
    };
    Ok(Some(Light {
        color,
        range,
        cone_falloff,
        ..Light::new(name, kind, intensity as f32)
    }))
}

/// Read and check the file's lights and the nodes' references to them.
pub(super) fn read(root: &Value, warnings: &mut Vec<String>) -> Result<FileLights, String> {
    let mut out = FileLights::default();
    let generator = root.pointer("/asset/generator").and_then(Value::as_str);
    let blender = generator.is_some_and(|g| g.contains("Blender"));
    if let Some(ext) = root.pointer(&format!("/extensions/{EXTENSION}")) {
        let list = match ext.get("lights") {
            None | Some(Value::Null) => &[][..],
            Some(Value::Array(a)) => a.as_slice(),
            Some(v) => {
                return Err(format!(
                    "extensions.{EXTENSION}.lights: must be an array, not {v}"
                ))
            }
        };
        out.lights = list
            .iter()
            .enumerate()
            .map(|(i, v)| light(v, i, blender, warnings))
            .collect::<Result<_, _>>()?;
    }
    let nodes = root.get("nodes").and_then(Value::as_array);
    for (n, node) in nodes.into_iter().flatten().enumerate() {
        let mut which = None;
        if let Some(x) = node
            .get("extensions")
            .and_then(|e| e.get(EXTENSION))
            .filter(|x| !x.is_null())
        {
            let here = format!("nodes[{n}].extensions.{EXTENSION}.light");
            let l = x
                .get("light")
                .and_then(Value::as_u64)
                .ok_or_else(|| format!("{here}: missing or not a non-negative integer"))?;
            match usize::try_from(l) {
                Ok(l) if l < out.lights.len() => which = Some(l),
                _ => {
                    return Err(format!(
                        "{here}: light {l} does not exist (the file has {})",
                        out.lights.len()
                    ))
                }
            }
        }
        out.node_light.push(which);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn with(light: Value) -> Value {
        json!({
            "extensions": { "KHR_lights_punctual": { "lights": [light] } },
            "nodes": [ { "extensions": { "KHR_lights_punctual": { "light": 0 } } } ]
        })
    }

    #[test]
    fn lights_are_read_with_defaults() {
        let f = read(
            &with(json!({ "type": "spot", "intensity": 683.0 })),
            &mut vec![],
        )
        .unwrap();
        assert_eq!(f.node_light, vec![Some(0)]);
        let l = f.lights[0].as_ref().unwrap();
        assert_eq!(l.intensity, 683.0);
        assert_eq!(l.color, glam::Vec3::ONE);
        match l.kind {
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                assert_eq!(inner_cone_angle, 0.0);
                assert!((outer_cone_angle - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
            }
            k => panic!("{k:?}"),
        }
    }

    #[test]
    fn bad_values_name_their_json_path() {
        let cases = [
            (
                json!({ "type": "point", "intensity": -1.0 }),
                "lights[0].intensity",
            ),
            (
                json!({ "type": "spot", "spot": { "innerConeAngle": 0.8, "outerConeAngle": 0.8 } }),
                "lights[0].spot.innerConeAngle",
            ),
            (
                json!({ "type": "spot", "spot": { "outerConeAngle": 2.0 } }),
                "lights[0].spot.outerConeAngle",
            ),
            (json!({ "type": "point", "range": 0.0 }), "lights[0].range"),
        ];
        for (light, path) in cases {
            let e = read(&with(light.clone()), &mut vec![]).unwrap_err();
            assert!(e.contains(path), "{light}: {e}");
        }
        let mut bad_index = with(json!({ "type": "point" }));
        bad_index["nodes"][0]["extensions"]["KHR_lights_punctual"]["light"] = json!(3);
        let e = read(&bad_index, &mut vec![]).unwrap_err();
        assert!(
            e.contains("nodes[0].extensions.KHR_lights_punctual.light") && e.contains("has 1"),
            "{e}"
        );
        // An unknown type: warned about and ignored (the glTF validator accepts it).
        let mut warnings = vec![];
        let f = read(&with(json!({ "type": "area" })), &mut warnings).unwrap();
        assert!(f.lights[0].is_none() && warnings[0].contains("lights[0].type"));
    }

    /// In a file Blender wrote a spot falls off as Blender's, and its blend of 0 (equal
    /// cones) is a hard edge; from another writer equal cones stay an error, and a point
    /// light keeps the extension's (it has no cone).
    #[test]
    fn a_spot_blender_wrote_falls_off_as_blenders() {
        let spot =
            json!({ "type": "spot", "spot": { "innerConeAngle": 0.8, "outerConeAngle": 0.8 } });
        let mut file = with(spot.clone());
        file["asset"] =
            json!({ "version": "2.0", "generator": "Khronos glTF Blender I/O v5.0.21" });
        let l = read(&file, &mut vec![]).unwrap().lights[0].clone().unwrap();
        assert_eq!(l.cone_falloff, ConeFalloff::Blender);
        assert_eq!(l.problem(), None);
        file["asset"]["generator"] = json!("three.js GLTFExporter");
        assert!(read(&file, &mut vec![]).is_err());
        let mut point = with(json!({ "type": "point" }));
        point["asset"] = json!({ "version": "2.0", "generator": "Khronos glTF Blender I/O" });
        let l = read(&point, &mut vec![]).unwrap().lights[0]
            .clone()
            .unwrap();
        assert_eq!(l.cone_falloff, ConeFalloff::Gltf);
        // Equal cones of nothing are no spot, Blender's or not.
        file["asset"]["generator"] = json!("Khronos glTF Blender I/O");
        file["extensions"]["KHR_lights_punctual"]["lights"][0]["spot"] =
            json!({ "innerConeAngle": 0.0, "outerConeAngle": 0.0 });
        let e = read(&file, &mut vec![]).unwrap_err();
        assert!(e.contains("spot.outerConeAngle: 0 must be > 0"), "{e}");
    }
}
