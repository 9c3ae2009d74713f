//! A `shape = "mesh"` definition with a `file`: the file's objects (filtered by `node` /
//! `mesh`), each under the definition's rest transform, material and role.

use std::path::{Path, PathBuf};

use super::object::Common;
use super::{ObjectDef, SceneBuilder};
use crate::gltf_io::PartNames;
use crate::load::{format_of, read_any, Format};
use crate::{Material, Object, Scene, SceneError};

/// Scene files including scene files stop this deep (a cycle is refused before).
const MAX_DEPTH: usize = 8;

pub(super) fn parts(
    builder: &mut SceneBuilder,
    o: &ObjectDef,
    common: &Common,
    file: &str,
) -> Result<Vec<Object>, String> {
    let file_path: PathBuf = builder.base_dir.join(file);
    let (sub, names) = match read_file(&file_path, file, o, &builder.including)? {
        Ok(read) => read,
        Err(e) => return Err(builder.nested_error(&e)),
    };
    // A warning is named by the file it is about; the OBJ reader's already are.
    let named = format!("{}: ", file_path.display());
    for w in &sub.warnings {
        let w = match w.starts_with(&named) {
            true => w.clone(),
            false => format!("{named}{w}"),
        };
        builder.scene.warnings.push(w);
    }
    let parts: Vec<Object> = sub
        .objects
        .into_iter()
        .zip(names)
        .filter(|(obj, n)| selected(o, obj, n))
        .map(|(obj, _)| obj)
        .collect();
    if parts.is_empty() {
        return Err(format!(
            "'{}' has no triangle object{}",
            file_path.display(),
            if o.node.is_some() || o.mesh.is_some() {
                " matching the node / mesh filter"
            } else {
                ""
            }
        ));
    }
    let single = parts.len() == 1;
    Ok(parts
        .into_iter()
        .map(|part| {
            let mut obj = place(o, common, part);
            if single {
                obj.name.clone_from(&common.name);
            }
            obj
        })
        .collect())
}

/// The file's scene and each object's node and mesh names, or the file's error (inside:
/// kept whole for its kind); the definition's own errors outside.
fn read_file(
    file_path: &Path,
    file: &str,
    o: &ObjectDef,
    including: &[PathBuf],
) -> Result<Result<(Scene, Vec<PartNames>), SceneError>, String> {
    // A cycle is named at its first turn (each turn's message had wrapped the next one's,
    // nine times over, before "nested too deeply").
    let canonical = std::fs::canonicalize(file_path).ok();
    if let Some(k) = including.iter().position(|p| Some(p) == canonical.as_ref()) {
        let cycle: Vec<String> = (including[k..].iter().chain([&including[k]]))
            .map(|p| p.display().to_string())
            .collect();
        return Err(format!(
            "'{file}' is a scene file being read already: an include cycle ({})",
            cycle.join(" -> ")
        ));
    }
    if including.len() >= MAX_DEPTH {
        return Err(format!(
            "'{file}': scene files nested more than {MAX_DEPTH} deep"
        ));
    }
    let format = format_of(file_path).ok();
    if o.animation.is_some() && format != Some(Format::Gltf) {
        return Err(format!(
            "'animation' selects a glTF animation, and '{file}' is not a glTF file"
        ));
    }
    if format == Some(Format::Toml) {
        let mut chain = including.to_vec();
        chain.push(canonical.unwrap_or_else(|| file_path.to_path_buf()));
        Ok(crate::scene_file::read_nested(file_path, chain).map(|sub| {
            let n = sub.objects.len();
            (sub, vec![Default::default(); n])
        }))
    } else {
        Ok(read_any(file_path, o.animation.as_deref()))
    }
}

/// Does the part pass the definition's `node` and `mesh` filters?
fn selected(o: &ObjectDef, obj: &Object, n: &PartNames) -> bool {
    let node_ok = o
        .node
        .as_ref()
        .is_none_or(|f| n.node.as_deref().unwrap_or(&obj.name) == f);
    let mesh_ok = o
        .mesh
        .as_ref()
        .is_none_or(|f| n.mesh.as_deref().unwrap_or(&obj.name) == f);
    node_ok && mesh_ok
}

/// One part of the file as an object of the definition, named `name/part`.
fn place(o: &ObjectDef, common: &Common, part: Object) -> Object {
    let m = Material {
        reflectance: common.reflectance.unwrap_or(part.material.reflectance),
        emitted_radiance: common.emission.unwrap_or(
            common
                .material
                .emitted_radiance
                .max(part.material.emitted_radiance),
        ),
        double_sided: o.double_sided.unwrap_or(part.material.double_sided),
        // A reflectance (emission) given here replaces the file's field: its texture (and
        // vertex colours) go.
        base_color_texture: part
            .material
            .base_color_texture
            .filter(|_| common.reflectance.is_none()),
        emissive_texture: part
            .material
            .emissive_texture
            .filter(|_| common.emission.is_none()),
    };
    let mut mesh = part.mesh;
    if common.reflectance.is_some() {
        mesh.colors.clear();
    }
    let mut obj = common.make(o, mesh, m);
    obj.name = format!("{}/{}", common.name, part.name);
    obj.world_from_object = common.rest * part.world_from_object;
    // The file's node animation stays, under the object's rest transform; the scene
    // file's keys go on top of both (Object::world_from_object_at).
    obj.node_animation = part.node_animation.map(|mut n| {
        n.outer = common.rest * n.outer;
        n
    });
    obj.role = o.role.or(part.role);
    obj.patch_size = o.patch_size.or(part.patch_size);
    if obj.animation.is_none() {
        obj.animation = part.animation;
    }
    obj
}
