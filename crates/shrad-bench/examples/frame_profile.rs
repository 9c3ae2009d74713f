//! Per-step timing of the dispersive frame on one bench scene (a profiling aid):
//! `cargo run --release --example frame_profile -- room-77k [passes] [gather|splat]`.
use shrad::bench::{build_world, median, scenes};
use shrad::dispersive::Changes;
use shrad::dispersive::{Dispersive, DispersiveOptions, ToBoundary};
use shrad::vis::Backend;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "room-77k".into());
    let passes: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(4);
    let spec = scenes(false)
        .into_iter()
        .find(|s| s.name == name)
        .expect("scene name");
    let world = build_world(&spec, Backend::Auto).expect("world");
    let mut options = DispersiveOptions::improved();
    match args.next().as_deref() {
        Some("gather") => options.to_boundary = ToBoundary::Gather,
        Some("splat") => options.to_boundary = ToBoundary::Splat,
        _ => {}
    }
    let mut d = Dispersive::new(&world, options);
    let n = d.frames_per_pass();
    let ch = Changes::default();
    for _ in 0..n {
        d.step(&world, &ch);
    }
    let mut rows = Vec::new();
    for _ in 0..passes * n {
        rows.push(d.step(&world, &ch));
    }
    let col = |f: fn(&shrad::dispersive::FrameStats) -> f64| {
        median(&rows.iter().map(f).collect::<Vec<_>>())
    };
    println!(
        "{name}: {} patches, frame {:.1} ms (direct {:.2}, objects {:.1}, to boundary {:.1}, assemble {:.1})",
        world.patches.len(),
        col(|s| s.frame_ms),
        col(|s| s.direct_ms),
        col(|s| s.objects_ms),
        col(|s| s.to_boundary_ms),
        col(|s| s.assemble_ms)
    );
    for s in &rows[..n] {
        println!(
            "  obj {:?}: {:.1} = {:.1} + {:.1} + {:.1}",
            s.objects_updated, s.frame_ms, s.objects_ms, s.to_boundary_ms, s.assemble_ms
        );
    }
}
