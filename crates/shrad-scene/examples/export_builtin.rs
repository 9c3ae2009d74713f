//! Write a built-in scene as glTF and OBJ: regenerates `scenes/cornell.gltf`,
//! `scenes/cornell.obj` and `scenes/cornell.mtl`.
//!
//! ```text
//! cargo run -p shrad-scene --example export_builtin                # cornell into scenes/
//! cargo run -p shrad-scene --example export_builtin -- room out/   # another built-in, elsewhere
//! ```

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "cornell".into());
    let dir = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes"));
    std::fs::create_dir_all(&dir)?;
    let scene = shrad_scene::builtin(&name)?;
    let gltf = dir.join(format!("{name}.gltf"));
    let obj = dir.join(format!("{name}.obj"));
    shrad_scene::write_gltf(&scene, &gltf)?;
    shrad_scene::write_obj(&scene, &obj)?;
    println!("wrote {} and {} (+ .mtl)", gltf.display(), obj.display());
    Ok(())
}
