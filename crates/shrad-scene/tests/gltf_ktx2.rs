//! `KHR_texture_basisu`: a base colour texture whose image is KTX2 / Basis Universal (what
//! gltfpack's `-tc` and glTF-Transform's `etc1s` / `uastc` write, the extension required and
//! no PNG fallback) is transcoded to RGBA by the pure-Rust `basisu` crate.
//!
//! The fixtures (`tests/data/ktx2/`, made by Binomial's own encoder: `encode.mjs`) are one
//! 64 x 64 checker of 8-texel squares, (230, 50, 25) where `(x / 8 + y / 8)` is odd, else
//! (25, 75, 230), as ETC1S, UASTC with zstd and mip levels, and UASTC with zstd alone. Each
//! decodes to the checker within one 8-bit step (ETC1S is lossy; the flat squares keep it
//! close). Before, a file that required the extension was refused and one that only used
//! it lost its texture (the factor alone, with a warning).

use std::path::Path;

use serde_json::json;
use shrad_scene::srgb_to_linear;

use crate::common::gltf_bin::Bin;
use crate::common::load_gltf_json;

const SUITE: &str = "ktx2";

fn fixture(name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ktx2")
        .join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The checker's sRGB colour at texel `(x, y)`.
fn checker(x: u32, y: u32) -> [u8; 3] {
    match (x / 8 + y / 8) % 2 {
        1 => [230, 50, 25],
        _ => [25, 75, 230],
    }
}

/// A textured quad whose base colour image is `ktx2` (a KTX2 file), embedded in the
/// buffer, the extension required.
fn textured_quad(ktx2: &[u8]) -> serde_json::Value {
    let mut b = Bin::default();
    let (pos, idx) = b.unit_square();
    let uv_bytes: Vec<u8> = [0.0f32, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let uv = b.accessor(&uv_bytes, 4, "VEC2", 5126, json!({}));
    let image_view = b.view(ktx2, json!({}));
    b.finish(json!({
        "extensionsUsed": ["KHR_texture_basisu"],
        "extensionsRequired": ["KHR_texture_basisu"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Card", "mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 0
        }]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"extensions": {"KHR_texture_basisu": {"source": 0}}}],
        "images": [{"bufferView": image_view, "mimeType": "image/ktx2"}]
    }))
}

#[test]
fn basis_universal_textures_decode_to_their_image() {
    for name in ["etc1s", "uastc", "uastc_zstd"] {
        let s = load_gltf_json(
            SUITE,
            name,
            &textured_quad(&fixture(&format!("{name}.ktx2"))),
        );
        let tex = s.objects[0]
            .material
            .base_color_texture
            .as_ref()
            .unwrap_or_else(|| panic!("{name}: no texture ({:?})", s.warnings));
        let img = &tex.image;
        assert_eq!((img.width(), img.height()), (64, 64), "{name}");
        let mut worst = 0f32;
        for y in 0..64 {
            for x in 0..64 {
                let want = checker(x, y).map(|c| srgb_to_linear(f32::from(c) / 255.0));
                let got = img.texel(x, y);
                // One 8-bit sRGB step near the checker's colours is under 1.2e-2 in linear.
                worst = worst.max((got - glam::Vec3::from(want)).abs().max_element());
            }
        }
        assert!(worst < 1.2e-2, "{name}: a texel is {worst} off the checker");
        assert!(
            !s.warnings.iter().any(|w| w.contains("KTX2")),
            "{name}: {:?}",
            s.warnings
        );
    }
}

#[test]
fn a_corrupt_ktx2_image_warns_and_the_factor_is_used() {
    let mut bytes = fixture("etc1s.ktx2");
    // Cut the file after its header and level index: the data is not there.
    bytes.truncate(120);
    let s = load_gltf_json(SUITE, "corrupt", &textured_quad(&bytes));
    assert!(s.objects[0].material.base_color_texture.is_none());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("base colour image 0") && w.contains("KTX2")),
        "{:?}",
        s.warnings
    );
}

/// Every byte of each fixture flipped in turn: each load gives the texture or a warning,
/// never a panic (a hook counts panics even where the transcoder's guard catches them).
#[test]
fn flipped_bytes_never_panic() {
    crate::common::panics::count_panics();
    let before = crate::common::panics::panics().outside_draco;
    let mut loads = 0;
    for name in ["etc1s", "uastc", "uastc_zstd"] {
        let bytes = fixture(&format!("{name}.ktx2"));
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0xA5;
            let _ = load_gltf_json(SUITE, &format!("flip-{name}"), &textured_quad(&b));
            loads += 1;
        }
    }
    let after = crate::common::panics::panics().outside_draco;
    assert_eq!(
        after,
        before,
        "{} of {loads} corrupt loads panicked",
        after - before
    );
}
