//! Where the time of loading a glTF with large textures goes: the whole `load`, and the
//! decoding (`TextureImage::decode`) and averaging (`TextureImage::mean`) of each distinct
//! image on their own.
//!
//!     cargo run -p shrad-scene --example texture_load_time -- FILE.glb [REPEATS]
//!
//! For a GLB, the images on buffer views are read straight from its binary chunk.

use std::time::Instant;

use shrad_scene::{load, LoadOptions, TextureImage};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: texture_load_time FILE.glb [REPEATS]")?;
    let repeats: usize = args.next().map_or(Ok(3), |r| r.parse())?;
    let bytes = std::fs::read(&path)?;
    for r in 0..repeats {
        let t = Instant::now();
        let scene = load(std::path::Path::new(&path), &LoadOptions::default())?;
        println!(
            "load #{r}: {:.3} s ({} objects, {} warnings)",
            t.elapsed().as_secs_f64(),
            scene.objects.len(),
            scene.warnings.len()
        );
    }
    if !bytes.starts_with(b"glTF") || bytes.len() < 20 {
        return Ok(());
    }
    let json_len = u32::from_le_bytes(bytes[12..16].try_into()?) as usize;
    let root: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len])?;
    let bin = bytes
        .get(20 + json_len + 8..)
        .ok_or("GLB without a binary chunk")?;
    let mut views: Vec<u64> = root["images"]
        .as_array()
        .map(|a| a.iter().filter_map(|i| i["bufferView"].as_u64()).collect())
        .unwrap_or_default();
    println!("{} images on {} buffer views", views.len(), {
        views.sort_unstable();
        views.dedup();
        views.len()
    });
    for v in views {
        let view = &root["bufferViews"][v as usize];
        let off = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = view["byteLength"].as_u64().unwrap_or(0) as usize;
        let png = bin.get(off..off + len).ok_or("view outside the chunk")?;
        let t = Instant::now();
        let image = TextureImage::decode(png, format!("view {v}"))?;
        let decode = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mean = image.mean();
        println!(
            "view {v}: {len} bytes -> {} x {}: decode {decode:.3} s, mean {:.3} s (mean {mean})",
            image.width(),
            image.height(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
