//! The TOML scene file (docs/scene-format.md): camera, settings and a list of objects
//! built from primitives (quad, box, sphere) or taken from glTF / OBJ files, each with a
//! material, an optional role, a rest transform and optional keyframed animation.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Quat, Vec3};
use serde::Deserialize;

use crate::builtin::{box_mesh, quad, sphere_mesh};
use crate::{
    Animation, Camera, EmissionKey, Keyframe, Material, Object, Role, Scene, SceneError,
    SceneSettings,
};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDef {
    camera: Option<CameraDef>,
    settings: Option<SettingsDef>,
    #[serde(default)]
    object: Vec<toml::Spanned<ObjectDef>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    eye: [f32; 3],
    target: [f32; 3],
    yfov_deg: Option<f32>,
    aspect_ratio: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsDef {
    patch_size: Option<f32>,
    patches: Option<usize>,
    #[serde(default)]
    solver: BTreeMap<String, toml::Value>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
enum Shape {
    Quad,
    Box,
    Sphere,
    Mesh,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum Interpolation {
    Linear,
    Step,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(untagged)]
enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    name: Option<String>,
    role: Option<Role>,
    shape: Shape,
    // quad
    corners: Option<Vec<[f32; 3]>>,
    // box
    size: Option<[f32; 3]>,
    inward: Option<bool>,
    // sphere
    radius: Option<f32>,
    segments: Option<u32>,
    // mesh
    file: Option<String>,
    node: Option<String>,
    mesh: Option<String>,
    animation: Option<String>,
    // material
    reflectance: Option<[f32; 3]>,
    emission: Option<[f32; 3]>,
    double_sided: Option<bool>,
    // rest transform
    position: Option<[f32; 3]>,
    rotation_deg: Option<[f32; 3]>,
    rotation_quat: Option<[f32; 4]>,
    scale: Option<Scale>,
    patch_size: Option<f32>,
    // animation
    interpolation: Option<Interpolation>,
    #[serde(default)]
    key: Vec<KeyDef>,
    #[serde(default)]
    emission_key: Vec<EmissionKeyDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyDef {
    time: f32,
    translation: Option<[f32; 3]>,
    rotation_deg: Option<[f32; 3]>,
    rotation_quat: Option<[f32; 4]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EmissionKeyDef {
    time: f32,
    emission: [f32; 3],
}

/// Rotation from `rotation_deg` (about X, then Y, then Z, world axes: R = Rz Ry Rx) or
/// `rotation_quat` (`[x, y, z, w]`, normalised).
fn rotation(deg: Option<[f32; 3]>, quat: Option<[f32; 4]>) -> Result<Quat, String> {
    match (deg, quat) {
        (Some(_), Some(_)) => Err("give rotation_deg or rotation_quat, not both".into()),
        (Some([x, y, z]), None) => {
            if ![x, y, z].iter().all(|v| v.is_finite()) {
                return Err("rotation_deg must be finite".into());
            }
            Ok(Quat::from_rotation_z(z.to_radians())
                * Quat::from_rotation_y(y.to_radians())
                * Quat::from_rotation_x(x.to_radians()))
        }
        (None, Some(q)) => {
            let q = Quat::from_array(q);
            let len = q.length();
            if !(len.is_finite() && len > 1e-6) {
                return Err(
                    "rotation_quat must be a finite non-zero quaternion [x, y, z, w]".into(),
                );
            }
            Ok(q / len)
        }
        (None, None) => Ok(Quat::IDENTITY),
    }
}

fn finite3(v: [f32; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from(v);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{what} must be finite"))
    }
}

/// 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()[..pos.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Read a scene file (no role inference or validation; that is [`crate::load()`]'s job).
pub(crate) fn read(path: &Path) -> Result<Scene, SceneError> {
    read_nested(path, 0)
}

fn read_nested(path: &Path, depth: usize) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let def: FileDef = toml::from_str(&text)
        .map_err(|e| SceneError::invalid(path, e.to_string().trim_end().to_string()))?;
    let mut scene = Scene {
        source: path.display().to_string(),
        ..Default::default()
    };
    if let Some(c) = def.camera {
        let bad = |m: &str| SceneError::invalid(path, format!("[camera]: {m}"));
        let eye = finite3(c.eye, "eye").map_err(|m| bad(&m))?;
        let target = finite3(c.target, "target").map_err(|m| bad(&m))?;
        if (target - eye).length() <= 0.0 {
            return Err(bad("eye and target must differ"));
        }
        let yfov = c.yfov_deg.unwrap_or(40.0);
        if !(yfov > 0.0 && yfov < 180.0) {
            return Err(bad("yfov_deg must be in (0, 180)"));
        }
        if c.aspect_ratio.is_some_and(|a| !(a > 0.0 && a.is_finite())) {
            return Err(bad("aspect_ratio must be positive"));
        }
        let mut cam = Camera::look_at(eye, target, yfov.to_radians());
        cam.aspect_ratio = c.aspect_ratio;
        scene.camera = Some(cam);
    }
    if let Some(s) = def.settings {
        scene.settings = settings(path, s)?;
    }
    if def.object.is_empty() {
        return Err(SceneError::invalid(path, "no [[object]] in the scene file"));
    }
    let mut shape_triangles = 0usize;
    for (i, spanned) in def.object.into_iter().enumerate() {
        let line = line_of(&text, spanned.span().start);
        let o = spanned.into_inner();
        let label = match &o.name {
            Some(n) => format!("object {i} '{n}' (line {line})"),
            None => format!("object {i} (line {line})"),
        };
        let objects = object(path, &o, i, depth, &mut scene.warnings)
            .map_err(|m| SceneError::invalid(path, format!("{label}: {m}")))?;
        if !matches!(o.shape, Shape::Mesh) {
            shape_triangles += objects
                .iter()
                .map(|o| o.mesh.triangles.len())
                .sum::<usize>();
            if shape_triangles > MAX_SHAPE_TRIANGLES {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{label}: the file's quads, boxes and spheres make {shape_triangles} triangles by here, more than the {MAX_SHAPE_TRIANGLES} a scene file may build (use fewer segments)"
                    ),
                ));
            }
        }
        scene.objects.extend(objects);
    }
    Ok(scene)
}

/// Most triangles the primitive shapes (quads, boxes, spheres) of one scene file may make
/// together: sixteen 512-segment spheres. Each sphere is bounded by its `segments` limit; this
/// bounds a small file repeating them (a 64 KB file holds a thousand such spheres).
const MAX_SHAPE_TRIANGLES: usize = 16 * 261_120;

fn settings(path: &Path, s: SettingsDef) -> Result<SceneSettings, SceneError> {
    let bad = |m: &str| SceneError::invalid(path, format!("[settings]: {m}"));
    if s.patch_size.is_some() && s.patches.is_some() {
        return Err(bad("give patch_size or patches, not both"));
    }
    if s.patch_size.is_some_and(|h| !(h > 0.0 && h.is_finite())) {
        return Err(bad("patch_size must be positive"));
    }
    if s.patches == Some(0) {
        return Err(bad("patches must be positive"));
    }
    // Values as the command line would spell them (the CLI applies them as its options).
    let mut solver = BTreeMap::new();
    for (k, v) in s.solver {
        let v = match v {
            toml::Value::String(s) => s,
            toml::Value::Array(_) | toml::Value::Table(_) => {
                return Err(SceneError::invalid(
                    path,
                    format!("[settings.solver] {k}: must be a string, number or boolean"),
                ))
            }
            other => other.to_string(),
        };
        solver.insert(k, v);
    }
    Ok(SceneSettings {
        patch_size: s.patch_size,
        patches: s.patches,
        solver,
    })
}

/// The objects one `[[object]]` stands for (several for a multi-part mesh file).
fn object(
    path: &Path,
    o: &ObjectDef,
    index: usize,
    depth: usize,
    warnings: &mut Vec<String>,
) -> Result<Vec<Object>, String> {
    // Keys that belong to another shape are mistakes, not silently ignored.
    let given: [(&str, bool, &[Shape]); 9] = [
        ("corners", o.corners.is_some(), &[Shape::Quad]),
        ("size", o.size.is_some(), &[Shape::Box]),
        ("inward", o.inward.is_some(), &[Shape::Box]),
        ("radius", o.radius.is_some(), &[Shape::Sphere]),
        ("segments", o.segments.is_some(), &[Shape::Sphere]),
        ("file", o.file.is_some(), &[Shape::Mesh]),
        ("node", o.node.is_some(), &[Shape::Mesh]),
        ("mesh", o.mesh.is_some(), &[Shape::Mesh]),
        ("animation", o.animation.is_some(), &[Shape::Mesh]),
    ];
    for (key, present, shapes) in given {
        if present && !shapes.contains(&o.shape) {
            return Err(format!(
                "'{key}' does not apply to shape '{}'",
                format!("{:?}", o.shape).to_lowercase()
            ));
        }
    }
    let name = o.name.clone().unwrap_or_else(|| format!("object{index}"));
    let position = finite3(o.position.unwrap_or([0.0; 3]), "position")?;
    let rot = rotation(o.rotation_deg, o.rotation_quat)?;
    let scale = match o.scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::Axes(s)) => Vec3::from(s),
    };
    if !(scale.is_finite() && scale.min_element() > 0.0) {
        return Err(format!("scale {scale} must be positive"));
    }
    if o.patch_size.is_some_and(|h| !(h > 0.0 && h.is_finite())) {
        return Err("patch_size must be positive".into());
    }
    let rest = Affine3A::from_scale_rotation_translation(scale, rot, position);
    let reflectance = o
        .reflectance
        .map(|r| finite3(r, "reflectance"))
        .transpose()?;
    if reflectance.is_some_and(|r| r.min_element() < 0.0) {
        return Err("reflectance must be >= 0".into());
    }
    let emission = o.emission.map(|e| finite3(e, "emission")).transpose()?;
    if emission.is_some_and(|e| e.min_element() < 0.0) {
        return Err("emission must be >= 0".into());
    }
    let animation = animation(o)?;
    let mut material = Material {
        reflectance: reflectance.unwrap_or(Material::default().reflectance),
        emitted_radiance: emission.unwrap_or(Vec3::ZERO),
        double_sided: o.double_sided.unwrap_or(false),
        base_color_texture: None,
        emissive_texture: None,
    };
    if emission.is_none() {
        if let Some(e) = animation
            .as_ref()
            .and_then(|a| a.emission_at(f32::NEG_INFINITY))
        {
            material.emitted_radiance = e;
        }
    }
    let make = |mesh, material| {
        let mut obj = Object::new(name.clone(), mesh, material);
        obj.role = o.role;
        obj.world_from_object = rest;
        obj.animation = animation.clone();
        obj.patch_size = o.patch_size;
        obj
    };
    match o.shape {
        Shape::Quad => {
            let c = o
                .corners
                .as_ref()
                .ok_or("shape 'quad' needs 'corners' (4 points)")?;
            let c: [[f32; 3]; 4] = c
                .as_slice()
                .try_into()
                .map_err(|_| format!("'corners' must have 4 points, not {}", c.len()))?;
            let c = c.map(Vec3::from);
            Ok(vec![make(quad(c), material)])
        }
        Shape::Box => {
            let size = finite3(
                o.size.ok_or("shape 'box' needs 'size' = [w, h, d]")?,
                "size",
            )?;
            if size.min_element() <= 0.0 {
                return Err(format!("size {size} must be positive"));
            }
            Ok(vec![make(
                box_mesh(0.5 * size, o.inward.unwrap_or(false)),
                material,
            )])
        }
        Shape::Sphere => {
            let r = o.radius.ok_or("shape 'sphere' needs 'radius'")?;
            if !(r > 0.0 && r.is_finite()) {
                return Err(format!("radius {r} must be positive"));
            }
            let segments = o.segments.unwrap_or(32);
            if !(3..=512).contains(&segments) {
                return Err(format!("segments {segments} must be in 3..=512 (512 segments make 261,120 triangles; patches subdivide further)"));
            }
            Ok(vec![make(sphere_mesh(r, segments), material)])
        }
        Shape::Mesh => {
            let file = o.file.as_ref().ok_or("shape 'mesh' needs 'file'")?;
            let file_path: PathBuf = path.parent().unwrap_or(Path::new(".")).join(file);
            if depth >= 8 {
                return Err(format!(
                    "'{file}': scene files nested too deeply (include cycle?)"
                ));
            }
            let format = crate::load::format_of(&file_path).ok();
            if o.animation.is_some() && format != Some(crate::load::Format::Gltf) {
                return Err(format!(
                    "'animation' selects a glTF animation, and '{file}' is not a glTF file"
                ));
            }
            let (sub, names) = if format == Some(crate::load::Format::Toml) {
                let sub = read_nested(&file_path, depth + 1).map_err(|e| e.to_string())?;
                let n = sub.objects.len();
                (sub, vec![Default::default(); n])
            } else {
                crate::load::read_any(&file_path, o.animation.as_deref())
                    .map_err(|e| e.to_string())?
            };
            for w in &sub.warnings {
                warnings.push(format!("{}: {w}", file_path.display()));
            }
            let parts: Vec<Object> = sub
                .objects
                .into_iter()
                .zip(names)
                .filter(|(obj, n)| {
                    let node_ok = o
                        .node
                        .as_ref()
                        .is_none_or(|f| n.node.as_deref().unwrap_or(&obj.name) == f);
                    let mesh_ok = o
                        .mesh
                        .as_ref()
                        .is_none_or(|f| n.mesh.as_deref().unwrap_or(&obj.name) == f);
                    node_ok && mesh_ok
                })
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
                    let m = Material {
                        reflectance: reflectance.unwrap_or(part.material.reflectance),
                        emitted_radiance: emission.unwrap_or(
                            material
                                .emitted_radiance
                                .max(part.material.emitted_radiance),
                        ),
                        double_sided: o.double_sided.unwrap_or(part.material.double_sided),
                        // A reflectance (emission) given here replaces the file's field:
                        // its texture (and vertex colours) go.
                        base_color_texture: part
                            .material
                            .base_color_texture
                            .filter(|_| reflectance.is_none()),
                        emissive_texture: part
                            .material
                            .emissive_texture
                            .filter(|_| emission.is_none()),
                    };
                    let mut mesh = part.mesh;
                    if reflectance.is_some() {
                        mesh.colors.clear();
                    }
                    let mut obj = make(mesh, m);
                    if !single {
                        obj.name = format!("{name}/{}", part.name);
                    }
                    obj.world_from_object = rest * part.world_from_object;
                    // The file's node animation stays, under the object's rest transform;
                    // the scene file's keys go on top of both (Object::world_from_object_at).
                    obj.node_animation = part.node_animation.map(|mut n| {
                        n.outer = rest * n.outer;
                        n
                    });
                    obj.role = o.role.or(part.role);
                    obj.patch_size = o.patch_size.or(part.patch_size);
                    if obj.animation.is_none() {
                        obj.animation = part.animation;
                    }
                    obj
                })
                .collect())
        }
    }
}

fn animation(o: &ObjectDef) -> Result<Option<Animation>, String> {
    if o.key.is_empty() && o.emission_key.is_empty() {
        if o.interpolation.is_some() {
            return Err(
                "'interpolation' given without any [[object.key]] or [[object.emission_key]]"
                    .into(),
            );
        }
        return Ok(None);
    }
    let mut keys = Vec::with_capacity(o.key.len());
    for (k, key) in o.key.iter().enumerate() {
        if !key.time.is_finite() {
            return Err(format!("key {k}: time must be finite"));
        }
        keys.push(Keyframe {
            time: key.time,
            translation: finite3(key.translation.unwrap_or([0.0; 3]), "translation")
                .map_err(|m| format!("key {k}: {m}"))?,
            rotation: rotation(key.rotation_deg, key.rotation_quat)
                .map_err(|m| format!("key {k}: {m}"))?,
        });
    }
    let mut emission = Vec::with_capacity(o.emission_key.len());
    for (k, key) in o.emission_key.iter().enumerate() {
        let e = finite3(key.emission, "emission").map_err(|m| format!("emission_key {k}: {m}"))?;
        if !key.time.is_finite() || e.min_element() < 0.0 {
            return Err(format!(
                "emission_key {k}: time must be finite and emission >= 0"
            ));
        }
        emission.push(EmissionKey {
            time: key.time,
            emitted_radiance: e,
        });
    }
    keys.sort_by(|a, b| a.time.total_cmp(&b.time));
    emission.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(Some(Animation {
        keys,
        emission,
        step: o.interpolation == Some(Interpolation::Step),
    }))
}
