//! Per-step timing of the dispersive frame on one bench scene (a profiling aid):
//! `cargo run --release -p shrad-bench --example frame_profile -- room-77k [passes] [gather|splat]`.
use shrad::dispersive::{DispersiveOptions, ToBoundary};
use shrad::engine::Engine;
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad_bench::{build_world, median, scenes, StepMs};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "room-77k".into());
    let passes: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(4);
    let Some(spec) = scenes(false).into_iter().find(|s| s.name == name) else {
        let names: Vec<String> = scenes(false).into_iter().map(|s| s.name).collect();
        eprintln!("unknown scene {name}; known: {}", names.join(", "));
        std::process::exit(2);
    };
    let world = match build_world(&spec, Backend::Auto) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("{name}: {e}");
            std::process::exit(1);
        }
    };
    let mut options = DispersiveOptions::improved();
    match args.next().as_deref() {
        Some("gather") => options.to_boundary = ToBoundary::Gather,
        Some("splat") => options.to_boundary = ToBoundary::Splat,
        _ => {}
    }
    let patches = world.patches.len();
    let mut engine = match Engine::from_world(world, SolverChoice::Dispersive(options)) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("{name}: {e}");
            std::process::exit(1);
        }
    };
    let n = engine.frames_to_converge(1);
    for _ in 0..n {
        engine.step();
    }
    let frames: Vec<_> = (0..passes * n).map(|_| engine.step()).collect();
    let rows: Vec<(Vec<usize>, f64, StepMs)> = frames
        .iter()
        .map(|s| (s.objects_updated.clone(), s.frame_ms, StepMs::of(s)))
        .collect();
    let col =
        |f: fn(&(Vec<usize>, f64, StepMs)) -> f64| median(&rows.iter().map(f).collect::<Vec<_>>());
    println!(
        "{name}: {patches} patches, frame {:.1} ms (direct {:.2}, objects {:.1}, to boundary {:.1}, assemble {:.1})",
        col(|r| r.1),
        col(|r| r.2.direct),
        col(|r| r.2.objects),
        col(|r| r.2.to_boundary),
        col(|r| r.2.assemble)
    );
    for (objects, ms, steps) in &rows[..n.min(rows.len())] {
        println!(
            "  obj {objects:?}: {ms:.1} = {:.1} + {:.1} + {:.1}",
            steps.objects, steps.to_boundary, steps.assemble
        );
    }
}
