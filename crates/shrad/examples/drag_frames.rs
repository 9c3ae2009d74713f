//! A named object dragged back and forth, one move a frame, as the viewer's browser test
//! drags it (by a fifth of the scene's width along x): the median and 90th percentile
//! frame, the rays a frame, and the error against the reference at the drag's end and after
//! the still frames that follow it.
//!
//! `cargo run --release -p shrad --example drag_frames -- [scene] [patches] [object] [frames] [still_frames]`
//! (defaults: `cornell 20000 short_block 300 60`).

use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::solver::SolverChoice;

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(((v.len() as f64 * q) as usize).min(v.len().saturating_sub(1)))
        .copied()
        .unwrap_or(f64::NAN)
}

fn error_line(label: &str, engine: &mut Engine) {
    let e = engine.error();
    println!(
        "error {label}: overall {:.3} %, boundary {:.3} %, interior {:.3} %",
        100.0 * e.overall,
        100.0 * e.boundary,
        100.0 * e.interior
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or(default.to_string());
    let scene = shrad::scene::load(
        std::path::Path::new(&arg(0, "cornell")),
        &Default::default(),
    )?;
    let patches: usize = arg(1, "20000").parse()?;
    let frames: usize = arg(3, "300").parse()?;
    let still: usize = arg(4, "60").parse()?;
    let mut engine = Engine::new(
        scene,
        shrad::PatchSizing::Count(patches),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("dispersive", "default")?,
    )?;
    let object = engine.object(&arg(2, "short_block"))?;
    engine.converge(2);
    let reach = 0.2 * engine.world().scene.bounds().ok_or("empty scene")?.size().x;
    let rest = engine.transform(object);
    let (mut ms, mut rays) = (Vec::new(), Vec::new());
    for k in 0..frames {
        let phase = (k as f32 * 0.045).sin();
        engine.set_transform(
            object,
            Affine3A::from_translation(Vec3::X * reach * phase) * rest,
        )?;
        let stats = engine.step();
        ms.push(stats.frame_ms);
        rays.push(stats.rays_cast as f64);
    }
    println!(
        "{} patches, {frames} frames dragging: frame median {:.2} ms, p90 {:.2} ms; rays median {:.0}",
        engine.world().patches.len(),
        percentile(&mut ms, 0.5),
        percentile(&mut ms, 0.9),
        percentile(&mut rays, 0.5)
    );
    error_line("at the drag's end", &mut engine);
    for _ in 0..still {
        engine.step();
    }
    error_line(&format!("after {still} still frames"), &mut engine);
    Ok(())
}
