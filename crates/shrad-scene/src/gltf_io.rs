//! glTF 2.0 import (`.gltf` with embedded or external buffers, `.glb`) and export.
//!
//! Import: every triangle primitive of every node of the default scene becomes one
//! [`Object`] whose mesh is in the node's frame and whose `world_from_object` is the node's
//! accumulated transform. Export: each object one node (matrix), one mesh, one material.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Vec3};
use gltf::mesh::Mode;
use serde_json::{json, Value};

use crate::{base64, Camera, Material, Mesh, Object, Role, Scene, SceneError};

/// The names an imported object came from, for the scene file's `node` / `mesh` filters.
#[derive(Clone, Debug, Default)]
pub(crate) struct PartNames {
    /// Name of the node that instanced it.
    pub node: Option<String>,
    /// Name of the mesh.
    pub mesh: Option<String>,
}

/// Deepest node hierarchy accepted (guards against cyclic node graphs).
const MAX_DEPTH: usize = 512;

/// Read a glTF or GLB file into a scene (no role inference, no validation).
pub(crate) fn read(path: &Path) -> Result<(Scene, Vec<PartNames>), SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // The gltf crate reports bad input as errors, but a belt-and-braces guard keeps a
    // malformed file from ever taking the program down.
    match std::panic::catch_unwind(|| read_bytes(path, &bytes)) {
        Ok(r) => r,
        Err(_) => Err(SceneError::invalid(
            path,
            "malformed glTF (the reader gave up on it)",
        )),
    }
}

fn read_bytes(path: &Path, bytes: &[u8]) -> Result<(Scene, Vec<PartNames>), SceneError> {
    let bad = |m: String| SceneError::invalid(path, m);
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, base, &gltf.document, gltf.blob.clone())?;
    let doc = &gltf.document;
    let mut cx = Walk {
        path,
        base,
        doc,
        buffers: &buffers,
        scene: Scene {
            source: path.display().to_string(),
            ..Default::default()
        },
        names: Vec::new(),
        textures: std::collections::HashMap::new(),
    };
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            cx.scene
                .warnings
                .push("glTF has no scene: taking every root node".into());
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    for node in roots {
        cx.node(node, Mat4::IDENTITY, 0)?;
    }
    if doc.meshes().len() > 0 && cx.scene.objects.is_empty() {
        cx.scene
            .warnings
            .push("no node of the scene instances a triangle mesh".into());
    }
    Ok((cx.scene, cx.names))
}

fn load_buffers(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                SceneError::invalid(path, format!("buffer {i}: the GLB has no BIN chunk"))
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(base, uri)
                .map_err(|m| SceneError::invalid(path, format!("buffer {i}: {m}")))?,
        };
        if data.len() < b.length() {
            return Err(SceneError::invalid(
                path,
                format!(
                    "buffer {i}: has {} bytes but declares {} (truncated file?)",
                    data.len(),
                    b.length()
                ),
            ));
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// The bytes behind a glTF URI: a base64 data URI or a file relative to `base`.
fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, data)) = rest.split_once(";base64,") else {
            return Err("data URI is not base64".into());
        };
        return base64::decode(data);
    }
    if uri.contains("://") && !uri.starts_with("file://") {
        return Err(format!("unsupported URI scheme in '{uri}'"));
    }
    let rel = percent_decode(uri.strip_prefix("file://").unwrap_or(uri));
    let file: PathBuf = base.join(&rel);
    std::fs::read(&file).map_err(|e| format!("cannot read '{}': {e}", file.display()))
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

struct Walk<'a> {
    path: &'a Path,
    base: &'a Path,
    doc: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    scene: Scene,
    names: Vec<PartNames>,
    /// Average linear colour of each image (None: could not be loaded).
    textures: std::collections::HashMap<usize, Option<Vec3>>,
}

/// The `shrad_role` and `shrad_patch_size` of a node's or mesh's extras.
fn extras_of(raw: &gltf::json::Extras, what: &str) -> Result<(Option<Role>, Option<f32>), String> {
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
    let patch = v
        .get("shrad_patch_size")
        .and_then(Value::as_f64)
        .map(|x| x as f32);
    Ok((role, patch))
}

impl Walk<'_> {
    fn node(&mut self, node: gltf::Node, parent: Mat4, depth: usize) -> Result<(), SceneError> {
        if depth > MAX_DEPTH {
            return Err(SceneError::invalid(
                self.path,
                format!(
                    "node {}: hierarchy deeper than {MAX_DEPTH} (cyclic node graph?)",
                    node.index()
                ),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_label = match node.name() {
            Some(n) => format!("node {} '{n}'", node.index()),
            None => format!("node {}", node.index()),
        };
        if !world.is_finite() {
            return Err(SceneError::invalid(
                self.path,
                format!("{node_label}: transform is not finite"),
            ));
        }
        if let Some(cam) = node.camera() {
            if self.scene.camera.is_none() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => {
                        let (_, r, t) = world.to_scale_rotation_translation();
                        self.scene.camera = Some(Camera {
                            world_from_camera: Affine3A::from_rotation_translation(
                                r.normalize(),
                                t,
                            ),
                            yfov: p.yfov(),
                            aspect_ratio: p.aspect_ratio(),
                        });
                    }
                    gltf::camera::Projection::Orthographic(_) => self
                        .scene
                        .warnings
                        .push(format!("{node_label}: orthographic camera ignored")),
                }
            }
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(&node, &mesh, world, &node_label)?;
        }
        for child in node.children() {
            self.node(child, world, depth + 1)?;
        }
        Ok(())
    }

    fn mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: Mat4,
        node_label: &str,
    ) -> Result<(), SceneError> {
        let (path, buffers) = (self.path, self.buffers);
        let bad = |m: String| SceneError::invalid(path, m);
        let (node_role, node_patch) = extras_of(node.extras(), node_label).map_err(bad)?;
        let (mesh_role, mesh_patch) =
            extras_of(mesh.extras(), &format!("mesh {}", mesh.index())).map_err(bad)?;
        let base_name = node
            .name()
            .or(mesh.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("node{}", node.index()));
        let world_from_object = Affine3A::from_mat4(world);
        let flip = world_from_object.matrix3.determinant() < 0.0;
        let n_prims = mesh.primitives().len();
        for prim in mesh.primitives() {
            let name = if n_prims > 1 {
                format!("{base_name}.{}", prim.index())
            } else {
                base_name.clone()
            };
            let who = format!(
                "{node_label}, mesh {} primitive {}",
                mesh.index(),
                prim.index()
            );
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.scene.warnings.push(format!(
                    "{who}: {mode:?} primitive skipped (only triangles are used)"
                ));
                continue;
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                return Err(bad(format!("{who}: primitive has no POSITION attribute")));
            };
            if pos_acc.count() == 0 || prim.indices().is_some_and(|a| a.count() == 0) {
                self.scene
                    .warnings
                    .push(format!("{who}: empty primitive skipped"));
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| {
                    bad(format!(
                        "{who}: POSITION accessor cannot be read (outside its buffer?)"
                    ))
                })?
                .map(Vec3::from)
                .collect();
            if positions.len() != pos_acc.count() {
                return Err(bad(format!(
                    "{who}: POSITION accessor has {} of {} elements (outside its buffer?)",
                    positions.len(),
                    pos_acc.count()
                )));
            }
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => {
                    let v: Vec<u32> = reader
                        .read_indices()
                        .ok_or_else(|| {
                            bad(format!(
                                "{who}: index accessor cannot be read (outside its buffer?)"
                            ))
                        })?
                        .into_u32()
                        .collect();
                    if v.len() != acc.count() {
                        return Err(bad(format!("{who}: index accessor is outside its buffer")));
                    }
                    v
                }
                None => (0..positions.len() as u32).collect(),
            };
            let mut triangles = to_triangles(mode, &indices);
            if mode == Mode::Triangles && indices.len() % 3 != 0 {
                self.scene.warnings.push(format!(
                    "{who}: {} index(es) beyond the last whole triangle ignored",
                    indices.len() % 3
                ));
            }
            if flip {
                for t in &mut triangles {
                    t.swap(1, 2);
                }
            }
            let material = self.material(&prim.material(), &who);
            let mut object = Object::new(
                name,
                Mesh {
                    positions,
                    triangles,
                },
                material,
            );
            object.world_from_object = world_from_object;
            object.role = node_role.or(mesh_role);
            object.patch_size = node_patch.or(mesh_patch);
            self.scene.objects.push(object);
            self.names.push(PartNames {
                node: node.name().map(str::to_string),
                mesh: mesh.name().map(str::to_string),
            });
        }
        Ok(())
    }

    fn material(&mut self, m: &gltf::Material, who: &str) -> Material {
        let pbr = m.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let mut reflectance = Vec3::new(f[0], f[1], f[2]);
        if let Some(info) = pbr.base_color_texture() {
            let image = info.texture().source().index();
            let avg = match self.textures.get(&image) {
                Some(a) => *a,
                None => {
                    let a = match self.texture_average(image) {
                        Ok(a) => Some(a),
                        Err(e) => {
                            self.scene.warnings.push(format!(
                                "{who}: base colour image {image} cannot be loaded ({e}); using the factor alone"
                            ));
                            None
                        }
                    };
                    self.textures.insert(image, a);
                    a
                }
            };
            if let Some(avg) = avg {
                reflectance *= avg;
                self.scene
                    .warnings
                    .push(format!("{who}: base colour texture averaged to one colour"));
            }
        }
        let e = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        Material {
            reflectance,
            emitted_radiance: Vec3::from(e) * strength,
            double_sided: m.double_sided(),
        }
    }

    /// Mean linear RGB of image `index` (sRGB-decoded).
    fn texture_average(&self, index: usize) -> Result<Vec3, String> {
        let json = self
            .doc
            .as_json()
            .images
            .get(index)
            .ok_or_else(|| format!("no image {index}"))?;
        let bytes: Vec<u8> = if let Some(view) = &json.buffer_view {
            let view = self
                .doc
                .views()
                .nth(view.value())
                .ok_or("image buffer view out of range")?;
            let data = self
                .buffers
                .get(view.buffer().index())
                .ok_or("buffer out of range")?;
            data.0
                .get(view.offset()..view.offset() + view.length())
                .ok_or("image buffer view outside its buffer")?
                .to_vec()
        } else if let Some(uri) = &json.uri {
            read_uri(self.base, uri)?
        } else {
            return Err("image has neither uri nor bufferView".into());
        };
        let img = image::load_from_memory(&bytes)
            .map_err(|e| e.to_string())?
            .to_rgb32f();
        let n = (img.width() as usize * img.height() as usize).max(1);
        let sum = img.pixels().fold(Vec3::ZERO, |acc, p| {
            acc + Vec3::new(
                srgb_to_linear(p[0]),
                srgb_to_linear(p[1]),
                srgb_to_linear(p[2]),
            )
        });
        Ok(sum / n as f32)
    }
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Triangles of a triangle list, strip or fan (front faces counter-clockwise).
fn to_triangles(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[0], idx[i], idx[i + 1]])
            .collect(),
        _ => Vec::new(),
    }
}

// ---------------------------------------------------------------------------------------
// Export

/// An f32 as the JSON number with the same shortest decimal form (559.2, not 559.2000122).
fn num(x: f32) -> Value {
    x.to_string()
        .parse::<f64>()
        .map_or(Value::Null, |v| json!(v))
}

fn nums(xs: &[f32]) -> Value {
    Value::Array(xs.iter().map(|&x| num(x)).collect())
}

fn mat4_array(m: Affine3A) -> Value {
    nums(&Mat4::from(m).to_cols_array())
}

/// The glTF JSON and binary buffer of a scene.
fn build(scene: &Scene, embed: bool) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut materials = Vec::new();
    let mut nodes = Vec::new();
    let mut uses_strength = false;
    for (i, o) in scene.objects.iter().enumerate() {
        // Positions.
        let offset = bin.len();
        for p in &o.mesh.positions {
            for c in p.to_array() {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        let (lo, hi) = o.mesh.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let (lo, hi) = if o.mesh.positions.is_empty() {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset, "target": 34962}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5126, "count": o.mesh.positions.len(),
            "type": "VEC3", "min": nums(&lo.to_array()), "max": nums(&hi.to_array())
        }));
        // Indices.
        // glTF: a node whose transform mirrors (negative determinant) has clockwise front
        // faces; the reader flips them back, so write them flipped.
        let mirrored = o.world_from_object.matrix3.determinant() < 0.0;
        let offset = bin.len();
        for t in &o.mesh.triangles {
            let t = if mirrored { [t[0], t[2], t[1]] } else { *t };
            for v in t {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset, "target": 34963}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5125, "count": 3 * o.mesh.triangles.len(), "type": "SCALAR"
        }));
        // Material.
        let m = &o.material;
        let r = m.reflectance;
        let e = m.emitted_radiance;
        let emax = e.max_element();
        let mut mat = json!({
            "name": o.name,
            "pbrMetallicRoughness": {"baseColorFactor": nums(&[r.x, r.y, r.z, 1.0]), "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "doubleSided": m.double_sided,
        });
        if emax > 1.0 {
            uses_strength = true;
            mat["emissiveFactor"] = nums(&(e / emax).to_array());
            mat["extensions"] =
                json!({"KHR_materials_emissive_strength": {"emissiveStrength": num(emax)}});
        } else if emax > 0.0 {
            mat["emissiveFactor"] = nums(&e.to_array());
        }
        materials.push(mat);
        meshes.push(json!({
            "name": o.name,
            "primitives": [{"attributes": {"POSITION": 2 * i}, "indices": 2 * i + 1, "material": i, "mode": 4}]
        }));
        let mut extras = serde_json::Map::new();
        if let Some(role) = o.role {
            extras.insert("shrad_role".into(), json!(role.name()));
        }
        if let Some(h) = o.patch_size {
            extras.insert("shrad_patch_size".into(), num(h));
        }
        let mut node = json!({"name": o.name, "mesh": i});
        if o.world_from_object != Affine3A::IDENTITY {
            node["matrix"] = mat4_array(o.world_from_object);
        }
        if !extras.is_empty() {
            node["extras"] = Value::Object(extras);
        }
        nodes.push(node);
    }
    let mut root = json!({
        "asset": {"version": "2.0", "generator": "shrad"},
        "scene": 0,
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
    });
    if let Some(cam) = &scene.camera {
        let size = scene
            .bounds()
            .map_or(1.0, |(lo, hi)| (hi - lo).length())
            .max(f32::MIN_POSITIVE);
        let mut persp = json!({"yfov": num(cam.yfov), "znear": num(1e-3 * size)});
        if let Some(a) = cam.aspect_ratio {
            persp["aspectRatio"] = num(a);
        }
        root["cameras"] = json!([{"type": "perspective", "perspective": persp}]);
        root["nodes"]
            .as_array_mut()
            .expect("nodes is an array")
            .push(
                json!({"name": "camera", "camera": 0, "matrix": mat4_array(cam.world_from_camera)}),
            );
    }
    let n_nodes = root["nodes"].as_array().map_or(0, Vec::len);
    root["scenes"] = json!([{"name": scene.source, "nodes": (0..n_nodes).collect::<Vec<_>>()}]);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if embed {
        buffer["uri"] = json!(format!(
            "data:application/octet-stream;base64,{}",
            base64::encode(&bin)
        ));
    }
    root["buffers"] = json!([buffer]);
    if uses_strength {
        root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    (root, bin)
}

/// Write `bytes` to `path` through a temporary file beside it and a rename, so no
/// half-written file is ever left at `path`.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    let io = |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| SceneError::invalid(path, "not a file path"))?
        .to_string_lossy();
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}

/// Write the scene as glTF 2.0: a `.gltf` with the buffer embedded as a base64 data URI,
/// or, when `path` ends in `.glb`, a binary glTF. Each object is one node (its
/// `world_from_object` as a matrix) with one mesh and one material (`baseColorFactor` =
/// reflectance, `emissiveFactor` x `KHR_materials_emissive_strength` = emitted radiance,
/// `doubleSided`); the role and patch size go to the node's `extras` (`shrad_role`,
/// `shrad_patch_size`); the camera is a node of its own. Animations are not written.
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let (root, bin) = build(scene, !glb);
    let bytes = if glb {
        let mut text = serde_json::to_vec(&root).expect("JSON serialises");
        while text.len() % 4 != 0 {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    } else {
        let mut t = serde_json::to_vec_pretty(&root).expect("JSON serialises");
        t.push(b'\n');
        t
    };
    write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_counter_clockwise_order() {
        assert_eq!(
            to_triangles(Mode::TriangleStrip, &[0, 1, 2, 3, 4]),
            vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
        assert_eq!(
            to_triangles(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        assert_eq!(
            to_triangles(Mode::Triangles, &[0, 1, 2, 3]),
            vec![[0, 1, 2]]
        );
        assert!(to_triangles(Mode::TriangleStrip, &[0, 1]).is_empty());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b%2"), "a b%2");
        assert_eq!(percent_decode("%zz%41"), "%zzA");
    }
}
