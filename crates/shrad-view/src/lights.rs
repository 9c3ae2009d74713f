//! The lights without a surface as the page sees them: the punctual lights (in the `scene`
//! message as loaded, in every `frame` as they are now) and the sky (its radiance in the
//! `scene` message, its map once as a binary message). Surfaces that emit are objects.

use glam::{Affine3A, Vec3};
use serde_json::{json, Value};
use shrad::engine::Engine;
use shrad::scene::{Environment, Light, LightKind};

use crate::protocol;

/// The sky map the page gets is at most this many texels across (a background needs no
/// more; a 16k map would be 300 MB of halves).
pub const SKY_MAX_WIDTH: usize = 1024;

/// Light `l` under `world_from_light`, with its colour and intensity: what changes.
fn state(light: &Light, world_from_light: Affine3A) -> Value {
    json!({
        "world_from_light": protocol::columns(world_from_light),
        "position": Light::position(&world_from_light).to_array(),
        "direction": Light::direction(&world_from_light).unwrap_or(-Vec3::Z).to_array(),
        "color": light.color.to_array(),
        "intensity": light.intensity,
        "radiometric": light.radiometric().to_array(),
    })
}

/// Every punctual light, by index: `describe` of the light and its [`state`] now.
fn each_light(engine: &Engine, describe: impl Fn(&Light, Value) -> Value) -> Value {
    let lights = &engine.world().scene.lights;
    Value::Array(
        lights
            .iter()
            .enumerate()
            .map(|(l, light)| {
                let m = engine.light_transform(l).unwrap_or(light.world_from_light);
                // Its colour, intensity and cone now (animated ones: at the engine's time).
                let now = light.at(engine.time());
                describe(&now, state(&now, m))
            })
            .collect(),
    )
}

/// Every punctual light now, by index (the `frame` message's `lights`).
pub fn states_json(engine: &Engine) -> Value {
    each_light(engine, |_, state| state)
}

/// Every punctual light with what does not change (name, kind, units, cone, range) and its
/// state at load (the `scene` message's `lights`).
pub fn lights_json(engine: &Engine) -> Value {
    each_light(engine, |light, mut v| {
        let directional = light.kind == LightKind::Directional;
        let cone = match light.kind {
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => json!({
                "inner": inner_cone_angle,
                "outer": outer_cone_angle,
                "falloff": match light.cone_falloff {
                    shrad::scene::ConeFalloff::Gltf => "gltf",
                    shrad::scene::ConeFalloff::Blender => "blender",
                },
            }),
            _ => Value::Null,
        };
        v["name"] = json!(light.name);
        v["kind"] = json!(light.kind.name());
        v["unit"] = json!(if directional { "lx" } else { "cd" });
        v["radiometric_unit"] = json!(if directional { "W/m^2" } else { "W/sr" });
        v["cone"] = cone;
        v["range"] = json!(light.range);
        v["animated"] = json!(light.is_animated());
        v
    })
}

/// The sky for the `scene` message: `null`, a uniform radiance, or a map's description (the
/// map itself comes as a binary message, [`sky_map`]).
pub fn sky_json(environment: Option<&Environment>) -> Value {
    let Some(env) = environment else {
        return Value::Null;
    };
    match &env.map {
        None => json!({ "kind": "uniform", "radiance": (env.radiance * env.scale).to_array() }),
        Some(map) => {
            let (w, h, _) = downsampled(map);
            json!({
                "kind": "map",
                "file": map.path.display().to_string(),
                "width": w,
                "height": h,
                "source_width": map.width,
                "source_height": map.height,
                "rotate_deg": env.rotate_deg,
                "scale": env.scale,
            })
        }
    }
}

/// `map`'s texels averaged over square blocks so that it is at most [`SKY_MAX_WIDTH`]
/// across and half that down: width, height, texels (rows from the top).
fn downsampled(map: &shrad::scene::EnvMap) -> (usize, usize, Vec<Vec3>) {
    let (w, h) = (map.width as usize, map.height as usize);
    let k = w
        .div_ceil(SKY_MAX_WIDTH)
        .max(h.div_ceil(SKY_MAX_WIDTH / 2))
        .max(1);
    let (dw, dh) = (w.div_ceil(k), h.div_ceil(k));
    let mut out = Vec::with_capacity(dw * dh);
    for y in 0..dh {
        for x in 0..dw {
            let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
            for sy in y * k..((y + 1) * k).min(h) {
                for sx in x * k..((x + 1) * k).min(w) {
                    sum += map.texels[sy * w + sx];
                    n += 1.0;
                }
            }
            out.push(sum / n);
        }
    }
    (dw, dh, out)
}

/// The binary sky message of a map sky (`None` for a uniform one): the header (kind
/// [`protocol::KIND_SKY`], extra: the width), then `f32` scale, `u32` width `W`, `u32`
/// height `H`, `f32` rotation about +Y in degrees, then `W x H` RGB halves, rows from the
/// top (+Y), whose value times the scale is the radiance (the environment's `scale` in).
pub fn sky_map(environment: &Environment) -> Option<Vec<u8>> {
    let map = environment.map.as_ref()?;
    let (w, h, texels) = downsampled(map);
    let texels: Vec<Vec3> = texels.iter().map(|t| *t * environment.scale).collect();
    let scale = protocol::half_scale(&texels);
    let mut out = Vec::with_capacity(32 + 6 * texels.len());
    protocol::header(&mut out, protocol::KIND_SKY, 0, 0, w as u32);
    out.extend_from_slice(&scale.to_le_bytes());
    out.extend_from_slice(&(w as u32).to_le_bytes());
    out.extend_from_slice(&(h as u32).to_le_bytes());
    out.extend_from_slice(&environment.rotate_deg.to_le_bytes());
    protocol::push_halves(&mut out, &texels, scale);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shrad::scene::EnvMap;

    #[test]
    fn a_large_map_is_sent_averaged_and_scaled() {
        // 2050 x 1025: blocks of 3, the last row and column partial.
        let (w, h) = (2050usize, 1025usize);
        let texels = (0..w * h)
            .map(|i| Vec3::splat(((i % w) / 3) as f32))
            .collect();
        let map = EnvMap::new("t.exr".into(), w as u32, h as u32, texels).unwrap();
        let mut env = Environment::from_map(map);
        env.scale = 2.0;
        let bytes = sky_map(&env).unwrap();
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let (dw, dh) = (word(20) as usize, word(24) as usize);
        assert_eq!((dw, dh), (w.div_ceil(3), h.div_ceil(3)));
        assert_eq!(bytes.len(), 32 + 6 * dw * dh);
        let scale = f32::from_le_bytes(bytes[16..20].try_into().unwrap());
        let texel = |x: usize, y: usize| {
            let at = 32 + 6 * (y * dw + x);
            half::f16::from_le_bytes(bytes[at..at + 2].try_into().unwrap()).to_f32() * scale
        };
        // Block x averages columns 3x..3x+2, each of value x; times the scale 2.
        assert_eq!(texel(5, 7), 10.0);
        assert_eq!(texel(dw - 1, dh - 1), 2.0 * (dw - 1) as f32);
        assert!(sky_map(&Environment::uniform(Vec3::ONE)).is_none());
        let j = sky_json(Some(&env));
        assert_eq!(
            (j["width"].as_u64(), j["kind"].as_str()),
            (Some(dw as u64), Some("map"))
        );
    }
}
