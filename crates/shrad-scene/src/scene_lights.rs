//! The scene file's `[[lights]]` (docs/scene-format.md): point, spot and directional lights
//! with a position or a direction, a colour, and a strength given as power in watts (point
//! and spot: Blender's convention, radiant intensity `P / (4 pi)` W/sr), as irradiance in
//! W/m^2 (directional), or as the glTF extension's photometric `intensity` (candela, lux).

use glam::{Affine3A, Quat, Vec3};
use serde::Deserialize;

use crate::{ConeFalloff, Light, LightKind, LUMENS_PER_WATT};

/// `[[lights]]`: what a light's table may hold (docs/scene-format.md, "Lights").
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct LightDef {
    name: Option<String>,
    kind: Kind,
    position: Option<[f32; 3]>,
    /// The way the light shines (spot, directional).
    direction: Option<[f32; 3]>,
    color: Option<[f32; 3]>,
    /// Watts (point, spot).
    power: Option<f32>,
    /// W/m^2 (directional).
    irradiance: Option<f32>,
    /// Candela (point, spot) or lux (directional).
    intensity: Option<f32>,
    range: Option<f32>,
    inner_cone_deg: Option<f32>,
    outer_cone_deg: Option<f32>,
    /// Blender's spot blend, in place of `inner_cone_deg`: the falloff is Blender's.
    blend: Option<f32>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum Kind {
    Point,
    Spot,
    Directional,
}

fn vec3(v: [f32; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from(v);
    v.is_finite()
        .then_some(v)
        .ok_or_else(|| format!("{what} must be finite"))
}

/// The kind of light `d` is, with a spot's cones and falloff: the extension's between
/// `inner_cone_deg` and `outer_cone_deg`, or Blender's for a `blend` (the inner angle the
/// outer times 1 - blend, as Blender's exporter writes it).
fn spot_cone(d: &LightDef) -> Result<(LightKind, ConeFalloff), String> {
    let cones = d.inner_cone_deg.is_some() || d.outer_cone_deg.is_some() || d.blend.is_some();
    if d.kind != Kind::Spot {
        if cones {
            return Err("only a spot light has cone angles or a blend".into());
        }
        let kind = match d.kind {
            Kind::Point => LightKind::Point,
            _ => LightKind::Directional,
        };
        return Ok((kind, ConeFalloff::Gltf));
    }
    let outer = d.outer_cone_deg.unwrap_or(45.0).to_radians();
    let (inner, falloff) = match (d.inner_cone_deg, d.blend) {
        (Some(_), Some(_)) => {
            return Err("give inner_cone_deg or blend (Blender's), not both".into())
        }
        (_, Some(b)) if !(0.0..=1.0).contains(&b) => {
            return Err(format!("blend {b} must be within [0, 1]"))
        }
        (_, Some(b)) => (outer * (1.0 - b), ConeFalloff::Blender),
        (inner, None) => (inner.unwrap_or(0.0).to_radians(), ConeFalloff::Gltf),
    };
    let kind = LightKind::Spot {
        inner_cone_angle: inner,
        outer_cone_angle: outer,
    };
    Ok((kind, falloff))
}

/// The light `d` describes (its values checked by [`Light::problem`] afterwards).
pub(crate) fn light(d: &LightDef, i: usize) -> Result<Light, String> {
    let (kind, cone_falloff) = spot_cone(d)?;
    // The strength as written, before it becomes an intensity the user never wrote.
    for (key, v) in [
        ("power", d.power),
        ("irradiance", d.irradiance),
        ("intensity", d.intensity),
    ] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(format!("{key} {v} must be finite and >= 0"));
        }
    }
    let intensity = match (d.kind, d.power, d.irradiance, d.intensity) {
        (Kind::Directional, None, Some(e), None) => e * LUMENS_PER_WATT,
        (Kind::Point | Kind::Spot, Some(p), None, None) => {
            p * LUMENS_PER_WATT / (4.0 * std::f32::consts::PI)
        }
        (_, None, None, Some(i)) => i,
        (Kind::Directional, ..) => {
            return Err(
                "give a directional light one of irradiance (W/m^2) or intensity (lux)".into(),
            )
        }
        _ => return Err("give one of power (W) or intensity (candela)".into()),
    };
    // Named as written: a power of 1e38 W was refused as "intensity inf".
    let most = crate::MAX_RADIANCE * LUMENS_PER_WATT;
    if intensity.is_nan() || intensity > most {
        let (key, v) = [("power", d.power), ("irradiance", d.irradiance)]
            .into_iter()
            .find_map(|(k, v)| v.map(|v| (k, v)))
            .unwrap_or(("intensity", intensity));
        return Err(format!(
            "{key} {v:e} is beyond what a solve can hold (an intensity of at most {most:.1e} cd or lux)"
        ));
    }
    let position = match (d.kind, d.position) {
        (Kind::Directional, Some(_)) => {
            return Err("a directional light has a direction, not a position".into())
        }
        (_, Some(p)) => vec3(p, "position")?,
        (Kind::Directional, None) => Vec3::ZERO,
        (_, None) => return Err("position missing".into()),
    };
    let rotation = match (d.kind, d.direction) {
        (Kind::Point, Some(_)) => return Err("a point light has no direction".into()),
        (Kind::Point, None) => Quat::IDENTITY,
        (_, None) => return Err("direction missing (the way the light shines)".into()),
        (_, Some(v)) => {
            let v = vec3(v, "direction")?;
            if v.length() <= 1e-12 {
                return Err("direction must not be zero".into());
            }
            Quat::from_rotation_arc(-Vec3::Z, v.normalize())
        }
    };
    if d.range.is_some() && d.kind == Kind::Directional {
        return Err("a directional light has no range".into());
    }
    Ok(Light {
        color: vec3(d.color.unwrap_or([1.0; 3]), "color")?,
        range: d.range,
        world_from_light: Affine3A::from_rotation_translation(rotation, position),
        cone_falloff,
        ..Light::new(
            d.name.clone().unwrap_or_else(|| format!("light{i}")),
            kind,
            intensity,
        )
    })
}
