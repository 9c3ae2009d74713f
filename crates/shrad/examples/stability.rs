//! Is the light stable in time (issue 22, item 3)? Three runs on the built-in room with its
//! dispersive default, each against shrad's reference on the same patches, written as CSV
//! files into `out` and summarised on stdout:
//!
//! 1. `settling.csv`: an object moves for 16 frames and stops; then, frame by frame, the error
//!    against a reference solve of the stopped state (spec 8: overall, boundary, interior).
//!    Settling without overshoot means this error falls and never rises again by more than
//!    noise.
//! 2. `still.csv`: a converged scene left still, frame by frame: how much the radiosity
//!    changed since the frame before (area-weighted, relative, L1; and the largest patch's
//!    relative change), with sleep as in the default and with it off.
//! 3. `slow.csv`: an object moving slowly (0.25 % of the room's width a frame); per frame,
//!    the change of the wall patches far from it (beyond a quarter of the room's width from
//!    its box) since the frame before, for the dispersive default and for two reference
//!    solves of the same two states: flicker is the dispersive change beyond the reference's.
//!
//! `cargo run --release -p shrad --example stability -- [patches] [out]` (default 20000,
//! `docs/figures/stability`; `SHRAD_SET="key=value ..."` changes solver settings);
//! `docs/make_figures.sh stability` runs it and plots them.
use std::fmt::Write as _;

use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::{room, Role, RoomParams};
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let patches: usize = match args.next() {
        Some(s) => s
            .parse()
            .map_err(|_| format!("patches: '{s}' is not a count"))?,
        None => 20_000,
    };
    let out = std::path::PathBuf::from(args.next().unwrap_or("docs/figures/stability".into()));
    std::fs::create_dir_all(&out)?;
    let engine = |sleep: bool| -> Result<Engine, shrad::Error> {
        let scene = room(&RoomParams {
            objects: 8,
            patches,
            big_object_patches: None,
        });
        let mut e = Engine::new(
            scene,
            PatchSizing::Count(patches),
            Backend::Auto,
            SolverChoice::Dispersive(Default::default()),
        )?;
        if !sleep {
            e.set_option("sleep_tolerance", "0")?;
        }
        // Extra settings (`key=value`) from the environment, for experiments.
        for kv in std::env::var("SHRAD_SET")
            .unwrap_or_default()
            .split_whitespace()
        {
            let Some((k, v)) = kv.split_once('=') else {
                return Err(shrad::Error::Invalid(format!(
                    "SHRAD_SET: {kv} is not key=value"
                )));
            };
            e.set_option(k, v)?;
        }
        e.converge(3);
        Ok(e)
    };
    let reference = ReferenceOptions::default();
    let mut e = engine(true)?;
    let mover = largest_interior(&e);
    let rest = e.transform(mover);
    let width = e
        .world()
        .scene
        .bounds()
        .ok_or("the room has no bounds")?
        .size()
        .x;
    println!(
        "room at {} patches; mover: object {mover}",
        e.world().patches.len()
    );

    // 1. Settling after a stop.
    for k in 1..=16 {
        let at = Affine3A::from_translation(Vec3::X * 0.01 * width * k as f32) * rest;
        e.set_transform(mover, at)?;
        e.step();
    }
    let (stopped, _) = solve(e.world(), &reference, &NoProgress);
    let mut csv =
        String::from("frame_after_stop,overall_pct,boundary_pct,interior_pct,objects_updated\n");
    let mut errors = Vec::new();
    for k in 0..=48 {
        let mut updated = Vec::new();
        if k > 0 {
            updated = e.step().objects_updated;
        }
        let r = relative_error(&e.world().patches, e.radiosity(), &stopped);
        let _ = writeln!(
            csv,
            "{k},{:.4},{:.4},{:.4},{}",
            100.0 * r.overall,
            100.0 * r.boundary,
            100.0 * r.interior,
            updated
                .iter()
                .map(|o| o.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        );
        errors.push(r.overall);
    }
    std::fs::write(out.join("settling.csv"), csv)?;
    let rise = errors
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0f64, f64::max);
    println!(
        "settling: error {:.2} % at the stop, {:.2} % 48 frames later; largest rise from one frame to the next {:.3} points",
        100.0 * errors[0],
        100.0 * errors[errors.len() - 1],
        100.0 * rise
    );

    // 2. A still scene, with and without sleep.
    let mut csv = String::from("sleep,frame,mean_change_pct,largest_patch_change_pct\n");
    for sleep in [true, false] {
        let mut e = engine(sleep)?;
        for _ in 0..3 * e.frames_to_converge(1) {
            e.step();
        }
        let mut before = e.radiosity().to_vec();
        let mut worst = (0.0f64, 0.0f64);
        for k in 1..=32 {
            e.step();
            let (mean, largest) = change(&e, &before, |_| true);
            let _ = writeln!(
                csv,
                "{sleep},{k},{:.5},{:.5}",
                100.0 * mean,
                100.0 * largest
            );
            worst = (worst.0.max(mean), worst.1.max(largest));
            before = e.radiosity().to_vec();
        }
        println!(
            "still, sleep {}: frame-to-frame change at most {:.4} % (mean over the patches), {:.4} % (one patch)",
            if sleep { "on" } else { "off" },
            100.0 * worst.0,
            100.0 * worst.1
        );
    }
    std::fs::write(out.join("still.csv"), csv)?;

    // 3. Slow motion: the far walls' change against the reference's.
    let mut e = engine(true)?;
    let mut csv = String::from("frame,dispersive_far_change_pct,reference_far_change_pct\n");
    let (mut previous, _) = solve(e.world(), &reference, &NoProgress);
    let mut before = e.radiosity().to_vec();
    let mut beyond = 0.0f64;
    for k in 1..=16 {
        let at = Affine3A::from_translation(Vec3::X * 0.0025 * width * k as f32) * rest;
        e.set_transform(mover, at)?;
        e.step();
        let world = e.world();
        let p = &world.patches;
        let near = shrad::scene::Aabb::from_points(p.range(mover).map(|i| p.centre[i]))
            .ok_or("the mover has no patches")?
            .padded(Vec3::splat(0.25 * width));
        let far = |i: usize| {
            world.patches.role(i) == Role::Boundary && !near.contains(world.patches.centre[i])
        };
        let (ours, _) = change(&e, &before, far);
        let (now, _) = solve(world, &reference, &NoProgress);
        let theirs = change_between(world, &previous, &now, far);
        let _ = writeln!(csv, "{k},{:.5},{:.5}", 100.0 * ours, 100.0 * theirs);
        beyond = beyond.max(ours - theirs);
        before = e.radiosity().to_vec();
        previous = now;
    }
    std::fs::write(out.join("slow.csv"), csv)?;
    println!(
        "slow motion: the far walls' frame-to-frame change exceeds the reference's by at most {:.4} points",
        100.0 * beyond
    );
    Ok(())
}

fn largest_interior(e: &Engine) -> usize {
    let p = &e.world().patches;
    (0..p.object_role.len())
        .filter(|&o| p.object_role[o] == Role::Interior)
        .max_by_key(|&o| p.range(o).len())
        .unwrap_or(0)
}

/// The change of the engine's radiosity since `before` over the patches `which`: area-weighted
/// relative L1 (`sum A |dB| / sum A B`), and the largest single patch's `|dB| / B`.
fn change(e: &Engine, before: &[Vec3], which: impl Fn(usize) -> bool) -> (f64, f64) {
    let now = e.radiosity();
    // A patch below a millionth of the brightest is black: its rounding residue (1e-12,
    // then 0, then 2e-12: the inside of a closed box) is no change a picture shows.
    let floor = 1e-6 * now.iter().map(|b| b.element_sum()).fold(0.0, f32::max) as f64;
    let largest = (0..now.len())
        .filter(|&i| which(i))
        .map(|i| {
            let b = now[i].element_sum().max(before[i].element_sum()) as f64;
            let d = (now[i] - before[i]).abs().element_sum() as f64;
            if b > floor.max(1e-12) {
                d / b
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max);
    (change_between(e.world(), before, now, which), largest)
}

fn change_between(
    world: &shrad::World,
    a: &[Vec3],
    b: &[Vec3],
    which: impl Fn(usize) -> bool,
) -> f64 {
    let p = &world.patches;
    let (mut d, mut t) = (0.0f64, 0.0f64);
    for i in (0..a.len()).filter(|&i| which(i)) {
        let area = p.area[i] as f64;
        d += area * (b[i] - a[i]).abs().element_sum() as f64;
        t += area * b[i].element_sum() as f64;
    }
    if t > 0.0 {
        d / t
    } else {
        0.0
    }
}
