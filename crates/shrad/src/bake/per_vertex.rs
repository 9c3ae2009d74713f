//! The per-vertex glTF of one state ([`super::write_gltf`]): the display mesh posed in the
//! world, the light at each vertex as `COLOR_0` and `_RADIOSITY` (the module docs of
//! [`super`] say what each holds), written through `shrad_scene::gltf_builder`.

use std::path::Path;

use glam::Vec3;
use serde_json::{json, Value};
use shrad_scene::gltf_builder::{bounds, join_glb, BufferAt, GltfBuffer};
use shrad_scene::StagedFiles;

use super::{auto_exposure, check_exposure, is_glb_output, object_mesh_node, Baked};
use crate::engine::Engine;
use crate::view_data::DisplayMesh;
use crate::Error;

/// One object's lit mesh: world vertices, their normals and light, and triangles.
struct LitMesh {
    /// The object's index in the scene.
    object: usize,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    radiosity: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

/// The engine's display mesh in the world at its current pose, with the light at each
/// vertex; objects without patches are left out.
fn lit_meshes(engine: &Engine) -> Vec<LitMesh> {
    let world = engine.world();
    let p = &world.patches;
    let mesh = DisplayMesh::new(world);
    let radiosity = mesh.gather(&engine.vertex_colors());
    let normals = mesh.gather_patches(&p.normal);
    let mut out = Vec::new();
    for (o, d) in mesh.objects.into_iter().enumerate() {
        if d.triangles.is_empty() {
            continue;
        }
        let vertices = d.first_vertex as usize..d.first_vertex as usize + d.positions.len();
        let to_world = p.world_from_local[o];
        // A mirroring transform turns counter-clockwise triangles clockwise in the world.
        let flip = to_world.matrix3.determinant() < 0.0;
        out.push(LitMesh {
            object: o,
            positions: d
                .positions
                .iter()
                .map(|&q| to_world.transform_point3(q))
                .collect(),
            normals: normals[vertices.clone()].to_vec(),
            radiosity: radiosity[vertices].to_vec(),
            triangles: match flip {
                true => d.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
                false => d.triangles,
            },
        });
    }
    out
}

/// The glTF JSON and binary buffer of the engine's current state.
fn build(engine: &Engine, exposure: f32, at: BufferAt<'_>) -> (Value, Vec<u8>, Baked) {
    let world = engine.world();
    let mut buffer = GltfBuffer::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut baked = Baked {
        time: world.time,
        exposure,
        ..Baked::default()
    };
    for m in lit_meshes(engine) {
        let (lo, hi) = bounds(&m.positions);
        let colours: Vec<Vec3> = m
            .radiosity
            .iter()
            .map(|b| (*b * (exposure / std::f32::consts::PI)).clamp(Vec3::ZERO, Vec3::ONE))
            .collect();
        let min_max = (json!(lo.to_array()), json!(hi.to_array()));
        let attributes = json!({
            "POSITION": buffer.vec3s(&m.positions, Some(min_max)),
            "NORMAL": buffer.vec3s(&m.normals, None),
            "COLOR_0": buffer.vec3s(&colours, None),
            "_RADIOSITY": buffer.vec3s(&m.radiosity, None),
        });
        let primitive = (attributes, buffer.triangles(&m.triangles));
        let (mesh, node) = object_mesh_node(world, m.object, meshes.len(), primitive, json!({}));
        meshes.push(mesh);
        nodes.push(node);
        baked.meshes += 1;
        baked.vertices += m.positions.len();
        baked.triangles += m.triangles.len();
    }
    let buffer = buffer.finish(at);
    let root = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("shrad ", env!("CARGO_PKG_VERSION"), " bake"),
            "extras": {"shrad": {
                "source": world.scene.source,
                "time": world.time,
                "solver": engine.solver_choice().name(),
                "exposure": exposure,
                "COLOR_0": "clamp(exposure * B / pi, 0, 1), linear RGB",
                "_RADIOSITY": "B, W/m^2, linear RGB, unclamped",
            }},
        },
        "extensionsUsed": ["KHR_materials_unlit"],
        "materials": [{
            "name": "shrad baked light (unlit)",
            "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_unlit": {}},
        }],
        "scene": 0,
        "scenes": [{"name": world.scene.source, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": buffer.accessors,
        "bufferViews": buffer.buffer_views,
        "buffers": buffer.buffers,
    });
    (root, buffer.bin, baked)
}

/// [`write_gltf`] to staged names (added to `staged`, the `.bin` before the `.gltf` that
/// names it), renamed into place by [`StagedFiles::commit`].
pub(super) fn stage_gltf(
    engine: &Engine,
    path: &Path,
    exposure: Option<f32>,
    staged: &mut StagedFiles,
) -> Result<Baked, Error> {
    // A missing folder is `write_atomic`'s error, as with every output.
    let glb = is_glb_output(path)?;
    let exposure = match exposure {
        Some(e) => check_exposure(e)?,
        None => auto_exposure(engine),
    };
    let bin_path = path.with_extension("bin");
    let bin_name = bin_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let at = match glb {
        true => BufferAt::Glb,
        false => BufferAt::File(&bin_name),
    };
    let (root, bin, mut baked) = build(engine, exposure, at);
    let json = serde_json::to_vec(&root).map_err(|e| Error::Output(path.into(), e.to_string()))?;
    if glb {
        let bytes = join_glb(json, bin).map_err(|e| Error::Output(path.into(), e))?;
        staged.stage_bytes(path, &bytes)?;
    } else {
        staged.stage_bytes(&bin_path, &bin)?;
        staged.stage_bytes(path, &json)?;
    }
    baked.path = path.to_path_buf();
    Ok(baked)
}
