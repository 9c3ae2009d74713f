//! The engine alone, for comparison with what the viewer shows: frames per second on a
//! static scene and while an object is dragged back and forth every frame (as the browser
//! test does), without a server or a browser.
//!
//! `cargo run --release -p shrad-view --example engine_rate -- cornell 20000 short_block`

use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::solver::SolverChoice;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_name = args.first().map(String::as_str).unwrap_or("cornell");
    let patches: usize = args
        .get(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(20_000);
    let scene = shrad::scene::load(std::path::Path::new(scene_name), &Default::default())?;
    let mut engine = Engine::new(
        scene,
        shrad::PatchSizing::Count(patches),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("dispersive", "default")?,
    )?;
    let object = match args.get(2) {
        Some(name) => engine.object(name)?,
        None => (0..engine.roles().len())
            .find(|&o| engine.roles()[o] == shrad::scene::Role::Interior)
            .context("the scene has no interior object")?,
    };
    engine.converge(2);
    let seconds = Duration::from_secs(5);
    let t = Instant::now();
    let mut frames = 0;
    while t.elapsed() < seconds {
        engine.step();
        frames += 1;
    }
    let static_rate = frames as f64 / t.elapsed().as_secs_f64();
    // Back and forth along x by a fifth of the scene's size, one move per frame.
    let (lo, hi) = engine.world().scene.bounds().context("empty scene")?;
    let reach = 0.2 * (hi - lo).x;
    let rest = engine.transform(object);
    let t = Instant::now();
    let mut frames = 0;
    while t.elapsed() < seconds {
        let phase = (t.elapsed().as_secs_f64() * std::f64::consts::PI).sin() as f32;
        engine.set_transform(
            object,
            Affine3A::from_translation(Vec3::X * reach * phase) * rest,
        )?;
        engine.step();
        frames += 1;
    }
    let moving_rate = frames as f64 / t.elapsed().as_secs_f64();
    println!(
        "{scene_name} at {} patches, dispersive default: {static_rate:.1} frames/s static, {moving_rate:.1} frames/s while '{}' moves every frame",
        engine.world().patches.len(),
        engine.world().scene.objects[object].name
    );
    Ok(())
}
