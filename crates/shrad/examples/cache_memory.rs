//! What the dispersive solver's Step 2 and Step 3 caches (`dispersive/caches.rs`) hold once
//! every object was updated, and the mean time of a static frame's Steps 2 and 3.
//!
//! `cargo run --release -p shrad --example cache_memory -- [scene] [patches]`
//! (e.g. `cornell 20000`, `room 77375`)
use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::frame::Changes;
use shrad::vis::Backend;
use shrad::{PatchSizing, World};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "cornell".into());
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let scene =
        shrad::scene::load(std::path::Path::new(&name), &Default::default()).expect("scene");
    let world = World::new(scene, PatchSizing::Count(patches), Backend::Auto).expect("world");
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).expect("solver");
    d.converge(&world, 2);
    let objects = d.interior_objects().max(1);
    println!(
        "{name} at {} patches, {objects} interior objects: caches {:.2} MB ({:.2} MB an object)",
        world.patches.len(),
        d.cache_bytes() as f64 / 1e6,
        d.cache_bytes() as f64 / 1e6 / objects as f64
    );
    let frames = 200;
    let (mut s2, mut s3) = (0.0, 0.0);
    for _ in 0..frames {
        let s = d.step(&world, &Changes::default());
        let steps = s.dispersive().expect("dispersive");
        s2 += steps.objects_ms;
        s3 += steps.to_boundary_ms;
    }
    println!(
        "static frame: step 2 {:.2} ms, step 3 {:.2} ms (mean of {frames})",
        s2 / frames as f64,
        s3 / frames as f64
    );
}
