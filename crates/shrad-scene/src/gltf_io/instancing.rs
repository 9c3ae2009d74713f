//! `EXT_mesh_gpu_instancing`: a node that draws its mesh once per instance, each placed by
//! a translation, rotation and scale read from accessors (a forest, a row of chairs; what
//! Blender's exporter writes with "GPU Instances", gltfpack with `-mi`, glTF-Transform's
//! `instance`). The extension's specification: an instance's world transform is the node's
//! world transform times the instance's TRS, `T * R * S` as a node's; every attribute
//! has one element per instance; TRANSLATION and SCALE are VEC3, ROTATION a VEC4 unit
//! quaternion (float, or normalized byte or short); a missing attribute is the identity.
//!
//! Each instance becomes an object of its own, as a mesh that several nodes draw: shrad
//! lights each instance's patches on their own (their light differs), so nothing is
//! shared but the mesh's data while it is read.
//!
//! The accessors are read on the raw JSON once `unpack` has decoded the buffers (meshopt
//! views, implicit zeros; sparse accessors and normalized integers are read as
//! [`Unpack::read_f32`] reads them).

use glam::{Mat4, Quat, Vec3};
use serde_json::Value;

use super::unpack::Unpack;

/// The extension's name.
pub(super) const EXTENSION: &str = "EXT_mesh_gpu_instancing";

/// Instances one file may declare in all. Each is an object with its own patches: 65,536 of
/// them is far more than a scene shrad lights interactively, and a file that declares more
/// is refused before its instances are read.
pub(super) const MAX_INSTANCES: usize = 1 << 16;

/// Per node: the transforms of its instances (None: the node is not instanced).
#[derive(Debug, Default)]
pub(super) struct FileInstances {
    per_node: Vec<Option<Vec<Mat4>>>,
}

impl FileInstances {
    /// Node `n`'s instances (their transforms relative to the node), if it is instanced.
    pub(super) fn of_node(&self, n: usize) -> Option<&[Mat4]> {
        self.per_node.get(n)?.as_deref()
    }
}

/// The attributes the extension defines, with the accessor type each must have. Others
/// (`_ID`, application-specific ones beginning with `_`) are allowed and ignored.
const ATTRIBUTES: [(&str, &str); 3] = [
    ("TRANSLATION", "VEC3"),
    ("ROTATION", "VEC4"),
    ("SCALE", "VEC3"),
];

/// Read every instanced node's instance transforms from `u`'s JSON and buffers, checking
/// what the extension says (the messages name the node and the attribute).
pub(super) fn read(u: &Unpack) -> Result<FileInstances, String> {
    let nodes = u.root.get("nodes").and_then(Value::as_array);
    let mut out = FileInstances::default();
    let mut total = 0usize;
    for (n, node) in nodes.into_iter().flatten().enumerate() {
        let Some(ext) = node.pointer(&format!("/extensions/{EXTENSION}")) else {
            out.per_node.push(None);
            continue;
        };
        let here = format!("nodes[{n}].extensions.{EXTENSION}");
        let accessors = node_accessors(u.root, ext, &here)?;
        let count = instance_count(u.root, &accessors, &here)?;
        total = total.saturating_add(count);
        if total > MAX_INSTANCES {
            return Err(format!(
                "{here}: the file declares more than {MAX_INSTANCES} instances in all (each is an object with its own patches)"
            ));
        }
        let read = |k: usize| match accessors[k] {
            Some(a) => u.read_f32(a).map(Some),
            None => Ok(None),
        };
        let (t, r, s) = (read(0)?, read(1)?, read(2)?);
        let trs = Trs {
            translation: t.as_deref(),
            rotation: r.as_deref(),
            scale: s.as_deref(),
        };
        let transforms = (0..count)
            .map(|i| instance_transform(&here, i, &trs))
            .collect::<Result<Vec<Mat4>, String>>()?;
        out.per_node.push(Some(transforms));
    }
    Ok(out)
}

/// The accessor of each of [`ATTRIBUTES`] (None where it is absent), checked to exist and to
/// be of the attribute's type.
fn node_accessors(root: &Value, ext: &Value, here: &str) -> Result<[Option<usize>; 3], String> {
    let attrs = ext
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| format!("{here}.attributes: missing or not an object"))?;
    let accessors = root.get("accessors").and_then(Value::as_array);
    let n_accessors = accessors.map_or(0, Vec::len);
    let mut out = [None; 3];
    for (k, (name, ty)) in ATTRIBUTES.iter().enumerate() {
        let Some(v) = attrs.get(*name) else {
            continue;
        };
        let at = format!("{here}.attributes.{name}");
        let a = v
            .as_u64()
            .and_then(|a| usize::try_from(a).ok())
            .filter(|&a| a < n_accessors)
            .ok_or_else(|| {
                format!("{at}: {v} is not an accessor of the file (it has {n_accessors})")
            })?;
        let acc = &root["accessors"][a];
        let is = acc["type"].as_str().unwrap_or("?");
        if is != *ty {
            return Err(format!("{at}: accessor {a} is {is}, but {name} is {ty}"));
        }
        let ct = acc["componentType"].as_u64().unwrap_or(0);
        // FLOAT, or the 8- and 16-bit integers (ROTATION's normalized ones, and those
        // KHR_mesh_quantization allows TRANSLATION and SCALE).
        if ![5126, 5120, 5121, 5122, 5123].contains(&ct) {
            return Err(format!(
                "{at}: accessor {a} has componentType {ct}, which {EXTENSION} does not allow"
            ));
        }
        out[k] = Some(a);
    }
    if out.iter().all(Option::is_none) {
        return Err(format!(
            "{here}.attributes: none of TRANSLATION, ROTATION, SCALE (the extension needs at least one)"
        ));
    }
    Ok(out)
}

/// The number of instances: every attribute's accessor count, which must agree.
fn instance_count(
    root: &Value,
    accessors: &[Option<usize>; 3],
    here: &str,
) -> Result<usize, String> {
    let mut count: Option<(usize, &str)> = None;
    for (a, (name, _)) in accessors.iter().zip(ATTRIBUTES) {
        let Some(a) = *a else {
            continue;
        };
        let c = root["accessors"][a]["count"].as_u64().unwrap_or(0) as usize;
        match count {
            Some((first, first_name)) if first != c => {
                return Err(format!(
                    "{here}.attributes: {first_name} has {first} instances but {name} has {c} (every attribute has one element per instance)"
                ))
            }
            _ => count = Some((c, name)),
        }
    }
    Ok(count.map_or(0, |(c, _)| c))
}

/// The components of an instanced node's attributes (None: absent).
struct Trs<'a> {
    translation: Option<&'a [f32]>,
    rotation: Option<&'a [f32]>,
    scale: Option<&'a [f32]>,
}

/// Instance `i`'s transform `T * R * S` from the attributes' components (absent: identity).
/// A rotation is normalised (normalized integers are only close to unit length); one of
/// length zero, or any value not finite, is an error naming the instance.
fn instance_transform(here: &str, i: usize, trs: &Trs) -> Result<Mat4, String> {
    let v3 = |x: Option<&[f32]>, default: Vec3| {
        x.map_or(default, |x| Vec3::from_slice(&x[3 * i..3 * i + 3]))
    };
    let translation = v3(trs.translation, Vec3::ZERO);
    let scale = v3(trs.scale, Vec3::ONE);
    let rotation = trs
        .rotation
        .map_or(Quat::IDENTITY, |r| Quat::from_slice(&r[4 * i..4 * i + 4]));
    let finite = translation.is_finite() && scale.is_finite() && rotation.is_finite();
    if !finite {
        return Err(format!(
            "{here}: instance {i}'s translation, rotation or scale is not finite"
        ));
    }
    if rotation.length_squared() < 1e-12 {
        return Err(format!(
            "{here}: instance {i}'s rotation is a zero quaternion (not a rotation)"
        ));
    }
    Ok(Mat4::from_scale_rotation_translation(
        scale,
        rotation.normalize(),
        translation,
    ))
}
