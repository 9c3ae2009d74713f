//! The lightmap as RGBM for 8-bit pipelines (`LightmapFormat::Rgbm`, `shrad bake
//! --lightmap --lightmap-format rgbm`): the PNG beside the glTF, decoded with the
//! multiplier the glTF states, gives back the EXR of the same state texel by texel within
//! half a step of its 8 bits, over the Cornell box lit by its ceiling light and a bulb.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Vec3};
use shrad::bake::BakeOptions;
use shrad::engine::Engine;
use shrad::lightmap::{rgbm, LightmapFormat, LightmapOptions};
use shrad::solver::SolverChoice;
use shrad::{NoProgress, PatchSizing};
use shrad_scene::{Light, LightKind};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-lightmap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The JSON chunk of a `.glb`.
fn glb_json(path: &Path) -> serde_json::Value {
    let bytes = std::fs::read(path).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// Bake `e` to `d/c.glb` with the lightmap beside it in `format`; the names in `d`.
fn bake(e: &mut Engine, d: &Path, format: LightmapFormat) -> Vec<String> {
    let opts = LightmapOptions {
        resolution: Some(256),
        format,
        ..LightmapOptions::default()
    };
    let no_passes = BakeOptions {
        passes: 0,
        ..Default::default()
    };
    let path = d.join("c.glb");
    shrad::lightmap::bake_with_progress(e, &path, &no_passes, &opts, &NoProgress).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|f| f.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn rgbm_png_decodes_to_the_exr_within_8_bits() {
    let mut scene = shrad::scene::cornell_box();
    scene.lights.push(Light {
        world_from_light: Affine3A::from_translation(Vec3::new(420.0, 380.0, 120.0)),
        ..Light::new("bulb", LightKind::Point, 683.0 * 1.6e5)
    });
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(400),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    let (a, b) = (dir("rgbm-exr"), dir("rgbm-png"));
    assert_eq!(
        bake(&mut e, &a, LightmapFormat::Exr),
        ["c.glb", "c.lightmap.exr"]
    );
    assert_eq!(
        bake(&mut e, &b, LightmapFormat::Rgbm),
        ["c.glb", "c.lightmap.png"]
    );
    let exr = shrad::image_io::read_exr(&a.join("c.lightmap.exr")).unwrap();
    let png = image::open(b.join("c.lightmap.png")).unwrap();
    assert_eq!(png.color(), image::ColorType::Rgba8);
    let png = png.into_rgba8();
    assert_eq!(png.dimensions(), (exr.width, exr.height));
    // The multiplier the glTF states: a power of two over the EXR's largest value.
    let stated = &glb_json(&b.join("c.glb"))["asset"]["extras"]["shrad"]["lightmap"]["rgbm"];
    assert_eq!(stated["file"], "c.lightmap.png");
    let m = stated["multiplier"].as_f64().unwrap() as f32;
    assert_eq!(m, rgbm::multiplier(&exr.pixels));
    let top = exr
        .pixels
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    assert!(top <= m && m < 2.0 * top, "multiplier {m}, largest {top}");
    // Texel by texel, within half a step of the texel's own 8 bits.
    let (mut lit, mut dimmest, mut worst) = (0, f32::INFINITY, 0.0f32);
    for (px, want) in png.pixels().zip(&exr.pixels) {
        let got = rgbm::decode(px.0, m);
        let err = (got - *want).abs().max_element();
        assert!(
            err <= 1.001 * rgbm::tolerance(px.0, m),
            "{want} read back as {got} ({px:?})"
        );
        if want.max_element() > 0.0 {
            lit += 1;
            dimmest = dimmest.min(want.max_element());
            worst = worst.max(err / want.max_element());
        }
    }
    assert!(lit > exr.pixels.len() / 2, "{lit} texels lit");
    // Every lit texel to better than 1 % of its own brightest channel: 8 bits where it is;
    // a plain linear 8-bit texture at the same range would be off by half a step of the
    // largest value at the dimmest.
    let plain = 0.5 / 255.0 * m / dimmest;
    assert!(worst < 0.01, "worst relative error {:.2} %", 100.0 * worst);
    println!(
        "RGBM: multiplier {m}, largest {top:.4}, dimmest lit {dimmest:.3e} (range {:.0}:1), {lit} texels lit; worst relative error {:.2} % (linear 8 bits: {:.1} %)",
        top / dimmest,
        100.0 * worst,
        100.0 * plain
    );
}
