//! The JSON pointers of `KHR_animation_pointer` channels that shrad plays: a node's
//! translation, rotation and scale (as the core channels), a punctual light's colour,
//! intensity, range and cone angles, a material's emission factor and strength and its base
//! colour factor (the reflectance), and a perspective camera's field of view. Any other
//! property (a texture transform, a metallic factor, a camera's clipping planes) changes
//! nothing shrad computes or shows, and its channel is ignored with a warning.

use super::Path;

/// What a pointer names: which kind of thing, its index in the file, and the property.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pointed {
    /// `/nodes/{n}/translation`, `rotation` or `scale`.
    Node(usize, Path),
    /// `/extensions/KHR_lights_punctual/lights/{l}/...`.
    Light(usize, Path),
    /// `/materials/{m}/emissiveFactor`, its `KHR_materials_emissive_strength`, or
    /// `/materials/{m}/pbrMetallicRoughness/baseColorFactor`.
    Material(usize, Path),
    /// `/cameras/{c}/perspective/yfov`.
    Camera(usize, Path),
    /// `/nodes/{n}/weights`: morph weights, which shrad does not play (as the core channel).
    MorphWeights,
    /// Anything else.
    Other,
}

/// The light property after `/extensions/KHR_lights_punctual/lights/{l}/`. The extension
/// spells a cone angle `spot/innerConeAngle`; Blender's exporter (5.0) writes
/// `spot.innerConeAngle`, which is read the same.
fn light_property(rest: &str) -> Option<Path> {
    Some(match rest {
        "color" => Path::LightColor,
        "intensity" => Path::LightIntensity,
        "range" => Path::LightRange,
        "spot/innerConeAngle" | "spot.innerConeAngle" => Path::SpotInner,
        "spot/outerConeAngle" | "spot.outerConeAngle" => Path::SpotOuter,
        _ => return None,
    })
}

/// The index at the head of `rest` (a JSON pointer segment of decimal digits, no leading
/// zero but `0` itself, as RFC 6901 writes array indices) and what follows its `/`.
fn index_then(rest: &str) -> Option<(usize, &str)> {
    let (head, tail) = rest.split_once('/')?;
    let canonical = head == "0" || (!head.starts_with('0') && !head.is_empty());
    if !canonical || !head.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((head.parse().ok()?, tail))
}

/// What `pointer` names (see [`Pointed`]).
pub(super) fn parse(pointer: &str) -> Pointed {
    let named = || -> Option<Pointed> {
        if let Some(rest) = pointer.strip_prefix("/nodes/") {
            let (n, property) = index_then(rest)?;
            return Some(match property {
                "translation" => Pointed::Node(n, Path::Translation),
                "rotation" => Pointed::Node(n, Path::Rotation),
                "scale" => Pointed::Node(n, Path::Scale),
                "weights" => Pointed::MorphWeights,
                _ => return None,
            });
        }
        if let Some(rest) = pointer.strip_prefix("/extensions/KHR_lights_punctual/lights/") {
            let (l, property) = index_then(rest)?;
            return Some(Pointed::Light(l, light_property(property)?));
        }
        if let Some(rest) = pointer.strip_prefix("/cameras/") {
            let (c, property) = index_then(rest)?;
            return (property == "perspective/yfov")
                .then_some(Pointed::Camera(c, Path::CameraYfov));
        }
        let rest = pointer.strip_prefix("/materials/")?;
        let (m, property) = index_then(rest)?;
        Some(match property {
            "emissiveFactor" => Pointed::Material(m, Path::EmissiveFactor),
            "pbrMetallicRoughness/baseColorFactor" => Pointed::Material(m, Path::BaseColorFactor),
            "extensions/KHR_materials_emissive_strength/emissiveStrength" => {
                Pointed::Material(m, Path::EmissiveStrength)
            }
            _ => return None,
        })
    };
    named().unwrap_or(Pointed::Other)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pointers_shrad_plays_are_named_and_the_rest_are_other() {
        assert_eq!(parse("/nodes/3/rotation"), Pointed::Node(3, Path::Rotation));
        assert_eq!(parse("/nodes/0/weights"), Pointed::MorphWeights);
        assert_eq!(
            parse("/extensions/KHR_lights_punctual/lights/12/intensity"),
            Pointed::Light(12, Path::LightIntensity)
        );
        for spot in ["spot/outerConeAngle", "spot.outerConeAngle"] {
            assert_eq!(
                parse(&format!("/extensions/KHR_lights_punctual/lights/0/{spot}")),
                Pointed::Light(0, Path::SpotOuter)
            );
        }
        assert_eq!(
            parse("/cameras/1/perspective/yfov"),
            Pointed::Camera(1, Path::CameraYfov)
        );
        assert_eq!(
            parse("/materials/2/extensions/KHR_materials_emissive_strength/emissiveStrength"),
            Pointed::Material(2, Path::EmissiveStrength)
        );
        assert_eq!(
            parse("/materials/0/pbrMetallicRoughness/baseColorFactor"),
            Pointed::Material(0, Path::BaseColorFactor)
        );
        for other in [
            "/materials/0/pbrMetallicRoughness/metallicFactor",
            "/nodes/01/translation",
            "/nodes/-1/translation",
            "/nodes/x/scale",
            "/nodes/99999999999999999999999/scale",
            "/cameras/0/perspective/znear",
            "/nodes/0",
            "",
            "nodes/0/translation",
        ] {
            assert_eq!(parse(other), Pointed::Other, "{other}");
        }
    }
}
