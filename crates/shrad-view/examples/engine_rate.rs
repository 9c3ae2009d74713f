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
    let mut steps = StepTimes::default();
    while t.elapsed() < seconds {
        steps.add(&engine.step());
        frames += 1;
    }
    println!("static: {}", steps.mean());
    let static_rate = frames as f64 / t.elapsed().as_secs_f64();
    // Back and forth along x by a fifth of the scene's size, one move per frame.
    let reach = 0.2
        * engine
            .world()
            .scene
            .bounds()
            .context("empty scene")?
            .size()
            .x;
    let rest = engine.transform(object);
    let t = Instant::now();
    let mut frames = 0;
    let mut steps = StepTimes::default();
    while t.elapsed() < seconds {
        let phase = (t.elapsed().as_secs_f64() * std::f64::consts::PI).sin() as f32;
        engine.set_transform(
            object,
            Affine3A::from_translation(Vec3::X * reach * phase) * rest,
        )?;
        steps.add(&engine.step());
        frames += 1;
    }
    println!("moving: {}", steps.mean());
    let moving_rate = frames as f64 / t.elapsed().as_secs_f64();
    // Left where it is: the frames after the drag (the object's first full update at rest),
    // as the engine takes them, then (after another drag) as the viewer does, under a budget
    // of twice the drag's mean frame (`shrad_view::settle_budget_ms`).
    let drag_ms = steps.ms[0] / steps.frames.max(1) as f64;
    let mut steps = StepTimes::default();
    for _ in 0..60 {
        steps.add(&engine.step());
    }
    println!("after the drag: {}", steps.mean());
    for k in 0..120 {
        let phase = (k as f32 * 0.05).sin();
        engine.set_transform(
            object,
            Affine3A::from_translation(Vec3::X * reach * phase) * rest,
        )?;
        engine.step();
    }
    let budget = shrad_view::settle_budget_ms(drag_ms);
    let mut steps = StepTimes::default();
    for _ in 0..60 {
        steps.add(&engine.step_within(budget)?);
    }
    println!(
        "after the drag, as the viewer ({budget:.1} ms budget): {}",
        steps.mean()
    );
    println!(
        "{scene_name} at {} patches, dispersive default: {static_rate:.1} frames/s static, {moving_rate:.1} frames/s while '{}' moves every frame",
        engine.world().patches.len(),
        engine.world().scene.objects[object].name
    );
    Ok(())
}

/// Sums of the dispersive steps' times, to print their means.
#[derive(Default)]
struct StepTimes {
    frames: usize,
    ms: [f64; 5],
    /// The longest frame (ms).
    max: f64,
}

impl StepTimes {
    fn add(&mut self, stats: &shrad::frame::FrameStats) {
        self.frames += 1;
        self.ms[0] += stats.frame_ms;
        self.max = self.max.max(stats.frame_ms);
        if let Some(d) = stats.dispersive() {
            for (sum, ms) in self.ms[1..].iter_mut().zip([
                d.direct_ms,
                d.objects_ms,
                d.to_boundary_ms,
                d.assemble_ms,
            ]) {
                *sum += ms;
            }
        }
    }

    fn mean(&self) -> String {
        let n = self.frames.max(1) as f64;
        let [frame, s1, s2, s3, s4] = self.ms.map(|x| x / n);
        format!(
            "{frame:.2} ms a frame (step 1 {s1:.2}, step 2 {s2:.2}, step 3 {s3:.2}, step 4 {s4:.2}; longest {:.1}) over {} frames",
            self.max, self.frames
        )
    }
}
