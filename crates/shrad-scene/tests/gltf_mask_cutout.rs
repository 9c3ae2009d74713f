//! `alphaMode: MASK` with a base colour texture, resolved in geometry at load
//! (`gltf_io/cutout.rs`): each triangle is replaced by the parts of it whose alpha is at
//! least `alphaCutoff`, found by subdividing it in UV space.
//!
//! The fixture is a unit quad "Leaf" in the plane y = 0 whose position is its texture
//! coordinate (x = u, z = v), so a kept triangle's centroid x is its u, and a floor quad
//! (opaque, untextured) so that a scene is left when the leaf is cut away whole.

use serde_json::{json, Value};
use shrad_scene::{Object, Scene};

/// An RGBA PNG of `w x h` green texels whose alpha at texel `(x, y)` is `alpha(x, y)`, as a
/// data URI.
fn png(w: u32, h: u32, alpha: impl Fn(u32, u32) -> u8) -> String {
    crate::common::rgba_png_uri(w, h, [60, 160, 60], alpha)
}

fn f32s(data: &[f32]) -> Vec<u8> {
    data.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The leaf quad (indices repeated `copies` times: each copy is cut on its own) with
/// material `leaf` (texture 0 is image `uri` with sampler `sampler`), and the floor.
fn file(leaf: Value, uri: &str, sampler: Value, copies: usize) -> Value {
    // Copy k of the leaf is raised by k mm: copies at one place would be one surface
    // (the loader drops repeated triangles).
    let pos: Vec<f32> = (0..copies)
        .flat_map(|k| {
            let y = k as f32 * 1e-3;
            [0., y, 0., 0., y, 1., 1., y, 1., 1., y, 0.]
        })
        .collect();
    let floor = [-1., -1., -1., -1., -1., 2., 2., -1., 2., 2., -1., -1.];
    let uv = [0., 0., 0., 1., 1., 1., 1., 0.].repeat(copies);
    let idx: Vec<u8> = (0..copies as u16)
        .flat_map(|k| [0u16, 1, 2, 0, 2, 3].map(|i| 4 * k + i))
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let mut bytes = [f32s(&pos), f32s(&floor), f32s(&uv)].concat();
    let idx_offset = bytes.len();
    bytes.extend_from_slice(&idx);
    let floor_idx_offset = bytes.len();
    bytes.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let view =
        |offset: usize, len: usize| json!({"buffer": 0, "byteOffset": offset, "byteLength": len});
    let vec3 = |v: usize, data: &[f32]| {
        let (lo, hi) =
            data.chunks(3)
                .fold(([f32::MAX; 3], [f32::MIN; 3]), |(mut lo, mut hi), p| {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                    (lo, hi)
                });
        json!({"bufferView": v, "componentType": 5126, "count": data.len() / 3, "type": "VEC3",
               "min": lo, "max": hi})
    };
    let (p_len, f_len, uv_len) = (4 * pos.len(), 4 * floor.len(), 4 * uv.len());
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"name": "Leaf", "mesh": 0}, {"name": "Floor", "mesh": 1}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 3,
                             "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 1}, "indices": 4, "material": 1}]}
        ],
        "materials": [leaf, {"name": "Floor", "pbrMetallicRoughness": {"metallicFactor": 0.0}}],
        "images": [{"uri": uri}],
        "samplers": [sampler],
        "textures": [{"source": 0, "sampler": 0}],
        "accessors": [
            vec3(0, &pos),
            vec3(1, &floor),
            {"bufferView": 2, "componentType": 5126, "count": 4 * copies, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6 * copies, "type": "SCALAR"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [view(0, p_len), view(p_len, f_len), view(p_len + f_len, uv_len),
                        view(idx_offset, idx.len()), view(floor_idx_offset, 12)],
        "buffers": [{"byteLength": bytes.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", base64::encode(&bytes))}]
    })
}

/// A MASK material of texture 0 (with `texture_info` merged into its texture info), with
/// `extra` merged into the material.
fn mask(texture_info: Value, extra: Value) -> Value {
    let mut info = json!({"index": 0});
    info.as_object_mut()
        .unwrap()
        .extend(texture_info.as_object().unwrap().clone());
    let mut m = json!({"name": "Leaves", "alphaMode": "MASK",
        "pbrMetallicRoughness": {"metallicFactor": 0.0, "baseColorTexture": info}});
    m.as_object_mut()
        .unwrap()
        .extend(extra.as_object().unwrap().clone());
    m
}

fn load_json(name: &str, root: &Value) -> Scene {
    crate::common::load_gltf_json("gltf-mask-cutout", name, root)
}

fn leaf(s: &Scene) -> Option<&Object> {
    s.objects.iter().find(|o| o.name == "Leaf")
}

fn said(s: &Scene, part: &str) -> bool {
    s.warnings.iter().any(|w| w.contains(part))
}

/// The total area of the leaf's triangles and the least and greatest centroid u (= x).
fn coverage(o: &Object) -> (f32, f32, f32) {
    let m = &o.mesh;
    let mut area = 0.0;
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for (t, tri) in m.triangles.iter().enumerate() {
        area += m.triangle_area(t);
        let c = tri
            .iter()
            .map(|&i| m.positions[i as usize])
            .sum::<glam::Vec3>()
            / 3.0;
        // Positions and texture coordinates were interpolated alike.
        let uv = tri
            .iter()
            .map(|&i| m.uvs[0][i as usize])
            .sum::<glam::Vec2>()
            / 3.0;
        assert!(
            (uv.x - c.x).abs() < 1e-5 && (uv.y - c.z).abs() < 1e-5,
            "{uv} {c}"
        );
        lo = lo.min(c.x);
        hi = hi.max(c.x);
    }
    (area, lo, hi)
}

/// Left half of a 4 x 4 texture transparent, right half opaque: what is left covers the
/// right half exactly (area 1/2, every centroid at u >= 1/2), with a warning counting the
/// triangles the cut made.
#[test]
fn a_half_transparent_texture_keeps_the_opaque_half() {
    let uri = png(4, 4, |x, _| if x < 2 { 0 } else { 255 });
    let s = load_json(
        "half",
        &file(mask(json!({}), json!({})), &uri, json!({}), 1),
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    let (area, lo, _) = coverage(o);
    assert!((area - 0.5).abs() < 1e-4, "area {area}: {:?}", s.warnings);
    assert!(lo >= 0.5 - 1e-6, "a kept centroid at u = {lo}");
    let n = o.mesh.triangles.len();
    assert!(
        said(
            &s,
            &format!(
                "materials[0] 'Leaves' alphaMode MASK cut-outs resolved to {n} triangle(s) from 2"
            )
        ),
        "{:?}",
        s.warnings
    );
}

/// Alpha 0.5 everywhere: a cutoff of 0.3 keeps the quad as it is (2 triangles, silently), a
/// cutoff of 0.7 cuts it away whole (left out with a warning).
#[test]
fn the_cutoff_decides_for_a_uniform_alpha() {
    let uri = png(4, 4, |_, _| 128);
    let s = load_json(
        "cutoff-low",
        &file(
            mask(json!({}), json!({"alphaCutoff": 0.3})),
            &uri,
            json!({}),
            1,
        ),
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    assert_eq!(o.mesh.triangles.len(), 2);
    assert!(!said(&s, "MASK"), "{:?}", s.warnings);
    let s = load_json(
        "cutoff-high",
        &file(
            mask(json!({}), json!({"alphaCutoff": 0.7})),
            &uri,
            json!({}),
            1,
        ),
    );
    assert!(leaf(&s).is_none(), "{:?}", s.warnings);
    assert!(
        said(
            &s,
            "skipped (it neither reflects nor blocks light): materials[0] 'Leaves' is alphaMode MASK and its base colour alpha is below its alphaCutoff 0.7 everywhere on it"
        ),
        "{:?}",
        s.warnings
    );
}

/// `KHR_texture_transform` offset (1/2, 0) moves the opaque half of the texture onto the
/// left half of the quad (REPEAT), and the kept part with it.
#[test]
fn a_texture_transform_moves_the_kept_part() {
    let uri = png(4, 4, |x, _| if x < 2 { 0 } else { 255 });
    let info = json!({"extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0]}}});
    let s = load_json(
        "transform",
        &file(mask(info, json!({})), &uri, json!({}), 1),
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    let (area, _, hi) = coverage(o);
    assert!((area - 0.5).abs() < 1e-4, "area {area}");
    assert!(hi <= 0.5 + 1e-6, "a kept centroid at u = {hi}");
}

/// An all-opaque MASK texture cuts nothing: the 2 triangles and 4 vertices stay as they
/// were, without a warning.
#[test]
fn an_opaque_mask_texture_is_left_whole() {
    let uri = png(4, 4, |_, _| 255);
    let s = load_json(
        "opaque",
        &file(mask(json!({}), json!({})), &uri, json!({}), 1),
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    assert_eq!(o.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(o.mesh.positions.len(), 4);
    assert!(!said(&s, "MASK"), "{:?}", s.warnings);
}

/// The triangles cut-outs add to a file are capped (2 million): a 64 x 64 alpha checker
/// (NEAREST) cuts each triangle of the quad into 2048 pieces, so 1200 copies of it would
/// make 2.4 million; the triangles past the cap stay whole, with one warning.
#[test]
fn the_cap_on_added_triangles_is_honoured_with_a_warning() {
    let uri = png(64, 64, |x, y| if (x + y) % 2 == 0 { 0 } else { 255 });
    let sampler = json!({"magFilter": 9728, "minFilter": 9728});
    let s = load_json("cap", &file(mask(json!({}), json!({})), &uri, sampler, 600));
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    let n = o.mesh.triangles.len();
    assert!(n <= 2_000_000 + 1200, "{n} triangles");
    assert!(n > 1_900_000, "{n} triangles");
    // A triangle left whole is half the unit quad.
    let whole = (0..n)
        .filter(|&t| (o.mesh.triangle_area(t) - 0.5).abs() < 1e-6)
        .count();
    assert!(whole > 0, "no triangle was left whole past the cap");
    let cap = "alphaMode MASK cut-outs stopped at 2000000 added triangles";
    assert_eq!(
        s.warnings.iter().filter(|w| w.contains(cap)).count(),
        1,
        "{:?}",
        s.warnings
    );
}
