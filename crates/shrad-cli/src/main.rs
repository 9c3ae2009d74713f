//! The `shrad` command line: parses options, loads the scene and calls the library. It
//! holds no algorithm; each command is a file of `commands/`.

// First: `say!` is seen by the modules after it.
#[macro_use]
mod say;

mod commands;
mod common;
mod progress;
mod settings;
mod solver_args;

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

use commands::{animate, bake, bench, info, options, render, view};

/// Global illumination (radiosity) for dynamic scenes: the dispersive SH method of Wang, Liu
/// and Wu (2007), its probe-grid baseline and a converged reference solver.
#[derive(Parser)]
#[command(name = "shrad", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve a scene and write a picture (PNG, optionally linear EXR and patch CSV).
    Render(render::RenderArgs),
    /// Print what a scene contains: objects, roles, materials, patches.
    Info(info::InfoArgs),
    /// Run an animated scene frame by frame: a PNG per frame, a GIF (and MP4 when ffmpeg is
    /// installed) and DIR/stats.csv with the paper's Table 3 columns and the error.
    Animate(animate::AnimateArgs),
    /// Reproduce the paper's Tables 1-3 and Figures 2-3 in one run: grid (G = 4, 5) and
    /// dispersive (default and paper preset) on the same scenes, times, memory and error.
    Bench(bench::BenchArgs),
    /// Solve a scene and write its light per vertex as glTF (COLOR_0, unlit) for three.js,
    /// Blender or Godot; --frames N bakes an animation as N files.
    Bake(bake::BakeArgs),
    /// Watch and steer the scene's global illumination live in a browser: serves a page on
    /// 127.0.0.1 (unless --host) and prints its URL; Ctrl-C stops.
    View(view::ViewArgs),
    /// List every solver setting (the keys of --set and [settings.solver]) with its default
    /// in each preset, its range and what it does.
    Options(options::OptionsArgs),
}

/// Load the scene of `args` and check its `[settings.solver]`.
fn load(args: &common::SceneArgs) -> Result<(shrad_scene::Scene, settings::FileSettings)> {
    let scene = common::load_scene(args)?;
    let file = settings::from_file(&scene.source, &scene.settings.solver)?;
    Ok((scene, file))
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Render(args) => {
            let (scene, file) = load(&args.scene)?;
            render::run(args, scene, &file)
        }
        Command::Info(args) => {
            let (scene, file) = load(&args.scene)?;
            info::run(args, scene, &file)
        }
        Command::Animate(args) => {
            let (scene, file) = load(&args.scene)?;
            animate::run(args, scene, &file)
        }
        Command::Bake(args) => {
            let (scene, file) = load(&args.scene)?;
            bake::run(args, scene, &file)
        }
        Command::View(args) => {
            let (scene, file) = load(&args.scene)?;
            view::run(args, scene, &file)
        }
        Command::Bench(args) => bench::run(args),
        Command::Options(args) => options::run(args),
    }
}

/// On Ctrl-C or SIGTERM, remove the outputs' temporary and staged files before exiting
/// (130, as a shell reports an interrupt): a bake's sequence is all or nothing, stopped
/// too. The viewer handles its own signals (it stops its server).
fn remove_unfinished_on_signal() {
    let handler = || {
        shrad_scene::remove_unfinished();
        std::process::exit(130);
    };
    if let Err(e) = ctrlc::set_handler(handler) {
        eprintln!("warning: no Ctrl-C handler ({e}): a stopped command may leave temporary files");
    }
}

fn main() -> ExitCode {
    let command = Cli::parse().command;
    if !matches!(command, Command::View(_)) {
        remove_unfinished_on_signal();
    }
    match run(command) {
        Ok(()) if say::failed() => ExitCode::FAILURE,
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
