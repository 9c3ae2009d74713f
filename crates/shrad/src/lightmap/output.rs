//! A lightmapped bake's files: the glTF and the lightmap beside it (linear OpenEXR or RGBM).
//!
//! - `OUT.glb` (or `.gltf` and `.bin`): each object one mesh, its vertices the patch corners
//!   split along chart seams (world positions, `NORMAL`, `TEXCOORD_1` into the atlas); two
//!   PNG images in the buffer, 8-bit sRGB:
//!   - texture 0, **the lit surface**: `clamp(exposure * (rho E + M) / pi)`, the lightmap
//!     times the albedo, plus the emission: the base colour of one unlit material
//!     (`KHR_materials_unlit`) on `TEXCOORD_1`, and its emissive texture too (a viewer
//!     without the unlit extension shows it as emission), so it looks the same anywhere;
//!   - texture 1, **the lightmap** for three.js's `lightMap` on `uv1`:
//!     `clamp(lightmap_scale * E / pi)`, named in the material's
//!     `extras.shrad_lightmap` with the `lightMapIntensity` (`2 pi`) that
//!     makes a `MeshBasicMaterial` of the object's albedo (`node.extras.shrad_albedo`) show
//!     the same light (examples/threejs-lightmap).
//! - `OUT.lightmap.exr`: linear RGB float, `E / pi` (W/m^2/sr, unclamped): the radiance of
//!   a white surface at each texel; times the albedo it is what shrad's picture shows.
//!   Or, with [`LightmapFormat::Rgbm`], `OUT.lightmap.png`: the same values as RGBM in an
//!   8-bit RGBA PNG, `E / pi = rgb * a * multiplier` ([`super::rgbm`]), the multiplier in
//!   `asset.extras.shrad.lightmap.rgbm`.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde_json::{json, Value};
use shrad_scene::gltf_builder::{bounds, join_glb, BufferAt, GltfBuffer};
use shrad_scene::StagedFiles;

use super::texel::Texels;
use super::{rgbm, Layout, LightmapFormat, LightmapOptions};
use crate::bake::{object_mesh_node, Baked};
use crate::engine::Engine;
use crate::render::{Shading, SurfaceLight};
use crate::{Error, World};

/// The lightmap PNG's scale relative to the exposure (`lightmap_scale = 0.5 exposure`):
/// `E / pi` exceeds the lit surface's
/// radiance by `1 / rho`, so it is stored at half the exposure to keep its highlights.
const LIGHTMAP_SCALE: f32 = 0.5;

/// One object's mesh over its charts.
struct ChartMesh {
    object: usize,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uv1: Vec<Vec2>,
    triangles: Vec<[u32; 3]>,
}

/// Every object's mesh: patch corners welded within a chart (by shading vertex), split
/// between charts; triangles counter-clockwise about the patch's normal.
fn chart_meshes(world: &World, layout: &Layout) -> Vec<ChartMesh> {
    let p = &world.patches;
    let mut out: Vec<ChartMesh> = Vec::new();
    let mut index = std::collections::HashMap::new();
    for (c, chart) in layout.charts.iter().enumerate() {
        if out.last().is_none_or(|m| m.object != chart.object) {
            out.push(ChartMesh {
                object: chart.object,
                positions: Vec::new(),
                normals: Vec::new(),
                uv1: Vec::new(),
                triangles: Vec::new(),
            });
            index.clear();
        }
        let m = out.last_mut().expect("pushed above");
        for &i in &chart.patches {
            let corners = super::chart::patch_corners(world, i);
            let ids: Vec<u32> = (0..corners.len())
                .map(|k| {
                    // Welded by shading vertex and atlas point: an object's own UVs may
                    // have seams inside one chart.
                    let xy = layout.corners[i][k];
                    let key = (c, p.corner_vertex[i][k], (xy * 256.0).round().as_ivec2());
                    *index.entry(key).or_insert_with(|| {
                        m.positions.push(corners[k]);
                        m.normals.push(p.normal[i]);
                        m.uv1.push(layout.uv(xy));
                        m.positions.len() as u32 - 1
                    })
                })
                .collect();
            let turn = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
            let flip = turn.dot(p.normal[i]) < 0.0;
            for t in if ids.len() == 4 {
                &[[0, 1, 2], [0, 2, 3]][..]
            } else {
                &[[0, 1, 2]][..]
            } {
                let [a, b, c] = t.map(|k| ids[k]);
                m.triangles.push(if flip { [a, c, b] } else { [a, b, c] });
            }
        }
    }
    out
}

/// An 8-bit sRGB PNG of `values * scale`, clamped to [0, 1].
fn png(values: &[Vec3], width: u32, height: u32, scale: f32) -> Result<Vec<u8>, String> {
    let encode = |x: f32| {
        let x = (x * scale).clamp(0.0, 1.0);
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    };
    let rgb: Vec<u8> = values
        .iter()
        .flat_map(|v| v.to_array().map(encode))
        .collect();
    let mut bytes = Vec::new();
    image::RgbImage::from_raw(width, height, rgb)
        .ok_or("lightmap image size")?
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// The mean albedo of object `o`'s patches (area-weighted), for a `lightMap` material.
fn object_albedo(world: &World, o: usize) -> Vec3 {
    let p = &world.patches;
    let (mut sum, mut area) = (Vec3::ZERO, 0.0);
    for i in p.range(o) {
        sum += world.reflectance[i] * p.area[i];
        area += p.area[i];
    }
    if area > 0.0 {
        sum / area
    } else {
        Vec3::ZERO
    }
}

/// The meshes and nodes, in `buffer`; adds to `baked`'s counts.
fn meshes_and_nodes(
    world: &World,
    layout: &Layout,
    buffer: &mut GltfBuffer,
    baked: &mut Baked,
) -> (Vec<Value>, Vec<Value>) {
    let (mut meshes, mut nodes) = (Vec::new(), Vec::new());
    for m in chart_meshes(world, layout) {
        let (lo, hi) = bounds(&m.positions);
        let attributes = json!({
            "POSITION": buffer.vec3s(&m.positions, Some((json!(lo.to_array()), json!(hi.to_array())))),
            "NORMAL": buffer.vec3s(&m.normals, None),
            // The same set twice: glTF wants TEXCOORD_0 before TEXCOORD_1, and three.js's
            // lightMap reads uv1.
            "TEXCOORD_0": buffer.vec2s(&m.uv1),
            "TEXCOORD_1": buffer.vec2s(&m.uv1),
        });
        let primitive = (attributes, buffer.triangles(&m.triangles));
        let albedo = json!({"shrad_albedo": object_albedo(world, m.object).to_array()});
        let (mesh, node) = object_mesh_node(world, m.object, meshes.len(), primitive, albedo);
        meshes.push(mesh);
        nodes.push(node);
        baked.meshes += 1;
        baked.vertices += m.positions.len();
        baked.triangles += m.triangles.len();
    }
    (meshes, nodes)
}

/// The material, textures, images and sampler (JSON) of the two PNGs in buffer views
/// `lit` and `lightmap`.
fn material_json(lit: usize, lightmap: usize) -> Value {
    let on_uv1 = |index: usize| json!({"index": index, "texCoord": 1});
    json!({
        "materials": [{
            "name": "shrad lightmap (unlit)",
            "pbrMetallicRoughness": {
                "baseColorTexture": on_uv1(0),
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "emissiveTexture": on_uv1(0),
            "emissiveFactor": [1.0, 1.0, 1.0],
            "extensions": {"KHR_materials_unlit": {}},
            "extras": {"shrad_lightmap": {
                "lightMap": on_uv1(1),
                // The texel holds `LIGHTMAP_SCALE exposure E / pi` and three.js's basic
                // material shows `texel * intensity / pi * colour`: `exposure rho E / pi`.
                "lightMapIntensity": std::f32::consts::PI / LIGHTMAP_SCALE,
                "color": "node.extras.shrad_albedo",
            }},
        }],
        "textures": [{"source": 0, "sampler": 0, "name": "lit"}, {"source": 1, "sampler": 0, "name": "lightMap"}],
        "images": [
            {"bufferView": lit, "mimeType": "image/png", "name": "lit"},
            {"bufferView": lightmap, "mimeType": "image/png", "name": "lightMap"},
        ],
        "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}],
    })
}

/// The glTF (JSON and buffer) of the engine's state with its lightmap `texels`.
fn build(
    engine: &Engine,
    layout: &Layout,
    texels: &Texels,
    exposure: f32,
    beside: Value,
    at: BufferAt<'_>,
) -> Result<(Value, Vec<u8>, Baked), String> {
    let world = engine.world();
    let mut buffer = GltfBuffer::new();
    let mut baked = Baked {
        time: world.time,
        exposure,
        ..Baked::default()
    };
    let (meshes, nodes) = meshes_and_nodes(world, layout, &mut buffer, &mut baked);
    let (w, h) = (texels.width, texels.height);
    let lit = buffer.blob(&png(&texels.radiance, w, h, exposure)?);
    let lightmap = buffer.blob(&png(&texels.irradiance, w, h, LIGHTMAP_SCALE * exposure)?);
    let buffer = buffer.finish(at);
    let mut root = material_json(lit, lightmap);
    let mut more = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("shrad ", env!("CARGO_PKG_VERSION"), " bake --lightmap"),
            "extras": {"shrad": {
                "source": world.scene.source, "time": world.time,
                "solver": engine.solver_choice().name(), "exposure": exposure,
                "lightmap": {
                    "width": w, "height": h, "texel_size": layout.texel, "charts": layout.charts.len(),
                    "lit": "texture 0: clamp(exposure * (rho E + M) / pi), sRGB",
                    "lightMap": format!("texture 1: clamp({LIGHTMAP_SCALE} * exposure * E / pi), sRGB"),
                },
            }},
        },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"name": world.scene.source, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes,
        "accessors": buffer.accessors, "bufferViews": buffer.buffer_views, "buffers": buffer.buffers,
    });
    if let (Some(l), Value::Object(b)) = (
        more.pointer_mut("/asset/extras/shrad/lightmap")
            .and_then(Value::as_object_mut),
        beside,
    ) {
        l.extend(b);
    }
    if let (Some(r), Value::Object(m)) = (root.as_object_mut(), more) {
        r.extend(m);
    }
    Ok((root, buffer.bin, baked))
}

/// The light of the engine's current state as a picture shows it (smooth).
pub fn surface_light(engine: &Engine) -> SurfaceLight<'_> {
    let punctual = engine.solver.punctual_irradiance();
    SurfaceLight::new(
        engine.world(),
        engine.radiosity(),
        punctual,
        Shading::Smooth,
    )
}

/// The lightmap's EXR beside `path`: `out.glb` -> `out.lightmap.exr`.
pub fn exr_path(path: &Path) -> PathBuf {
    path.with_extension("lightmap.exr")
}

/// The lightmap's RGBM PNG beside `path`: `out.glb` -> `out.lightmap.png`.
pub fn rgbm_path(path: &Path) -> PathBuf {
    path.with_extension("lightmap.png")
}

/// The file name of `p`.
fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Stage the lightmap file beside `path` in `format`; what the glTF's
/// `asset.extras.shrad.lightmap` says of it.
fn stage_beside(
    path: &Path,
    texels: &Texels,
    format: LightmapFormat,
    staged: &mut StagedFiles,
) -> Result<Value, Error> {
    let (w, h) = (texels.width, texels.height);
    match format {
        LightmapFormat::Exr => {
            let exr = exr_path(path);
            staged.stage(&exr, |tmp| {
                exr::prelude::write_rgb_file(tmp, w as usize, h as usize, |x, y| {
                    texels.irradiance[y * w as usize + x].to_array().into()
                })
                .map_err(|e| e.to_string())
            })?;
            Ok(json!({
                "exr": file_name(&exr),
                "exr_holds": "E / pi, W/m^2/sr, linear RGB, unclamped (times the albedo: the radiance)",
            }))
        }
        LightmapFormat::Rgbm => {
            let file = rgbm_path(path);
            let m = rgbm::multiplier(&texels.irradiance);
            let bytes = rgbm::png(&texels.irradiance, w, h, m)
                .map_err(|e| Error::Output(file.clone(), e))?;
            staged.stage_bytes(&file, &bytes)?;
            Ok(json!({"rgbm": {
                "file": file_name(&file), "multiplier": m,
                "decode": "E / pi = (r, g, b) * a * multiplier; bytes / 255, linear (not sRGB), not premultiplied",
            }}))
        }
    }
}

/// Write the engine's state lightmapped to `path` (`.glb`, or `.gltf` and `.bin`) and its
/// lightmap file (`options.format`), to staged names in `staged` (renamed into place by
/// its commit).
pub fn stage(
    engine: &Engine,
    path: &Path,
    exposure: f32,
    options: &LightmapOptions,
    staged: &mut StagedFiles,
) -> Result<Baked, Error> {
    let world = engine.world();
    let layout = super::layout(world, options)?;
    let texels = super::texel::bake(world, &surface_light(engine), &layout);
    let bin_path = path.with_extension("bin");
    let bin_name = file_name(&bin_path);
    let glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let at = if glb {
        BufferAt::Glb
    } else {
        BufferAt::File(&bin_name)
    };
    let out = |e: String| Error::Output(path.into(), e);
    let beside = stage_beside(path, &texels, options.format, staged)?;
    // A path the caller can open (it was a description: "c.lightmap.exr (linear ...)").
    let (name, encoding) = match (&beside["exr"], &beside["rgbm"]) {
        (Value::String(exr), _) => (exr.clone(), "linear OpenEXR, E / pi".to_string()),
        (_, rgbm) => (
            rgbm["file"].as_str().unwrap_or_default().to_string(),
            format!("RGBM PNG: E / pi = rgb * a * {}", rgbm["multiplier"]),
        ),
    };
    let (root, bin, mut baked) =
        build(engine, &layout, &texels, exposure, beside, at).map_err(out)?;
    let json = serde_json::to_vec(&root).map_err(|e| out(e.to_string()))?;
    if glb {
        staged.stage_bytes(path, &join_glb(json, bin).map_err(out)?)?;
    } else {
        staged.stage_bytes(&bin_path, &bin)?;
        staged.stage_bytes(path, &json)?;
    }
    baked.path = path.to_path_buf();
    baked.warnings = layout.warnings;
    baked.lightmap_file = Some(path.with_file_name(name));
    baked.lightmap_encoding = Some(encoding);
    Ok(baked)
}
