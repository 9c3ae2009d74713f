//! A development binary for the viewer server (the `shrad view` subcommand of shrad-cli
//! calls the same [`shrad_view::serve`]): `shrad-view SCENE [--patches N] [--solver S]
//! [--preset P] [--host H] [--token T] [--max-clients N] [--watch-only] [--port P] [--backend B] [--web DIR]`.

use std::net::IpAddr;
use std::path::PathBuf;

use anyhow::Result;
use clap::Parser;

/// Watch and steer a scene's global illumination live in a browser.
#[derive(Parser)]
#[command(name = "shrad-view", version)]
struct Args {
    /// A scene file (glTF, OBJ, TOML) or a built-in name (cornell, room).
    scene: PathBuf,
    /// Number of patches.
    #[arg(long, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(1..=50_000_000))]
    patches: u64,
    /// Solver: dispersive, grid or reference.
    #[arg(long, default_value = "dispersive")]
    solver: String,
    /// Preset of the solver: default or paper.
    #[arg(long, default_value = "default")]
    preset: String,
    /// Address to bind; anything but a loopback address needs a token (generated unless
    /// --token gives one, printed in the URL).
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
    /// The token every request must carry (`?token=...`); also on loopback when given.
    #[arg(long)]
    token: Option<String>,
    /// Clients at once; one more is refused with a message.
    #[arg(long, default_value_t = shrad_view::access::DEFAULT_MAX_CLIENTS)]
    max_clients: usize,
    /// Every client watches; nobody steers.
    #[arg(long)]
    watch_only: bool,
    /// Port (0: any free port).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// Visibility backend: auto, embree or bvh.
    #[arg(long, default_value = "auto")]
    backend: String,
    /// The page's folder (default: this repository's web/).
    #[arg(long)]
    web: Option<PathBuf>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let scene = shrad::scene::load(&args.scene, &Default::default())?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let mut options = shrad_view::ServeOptions::new(scene);
    options.sizing = shrad::PatchSizing::Count(args.patches as usize);
    options.solver = args.solver;
    options.preset = args.preset;
    options.host = args.host;
    options.access = shrad_view::AccessOptions {
        token: args.token,
        max_clients: args.max_clients,
        watch_only: args.watch_only,
        ..Default::default()
    };
    options.port = args.port;
    options.backend = match args.backend.as_str() {
        "auto" => shrad::vis::Backend::Auto,
        "embree" => shrad::vis::Backend::Embree,
        "bvh" => shrad::vis::Backend::Bvh,
        b => anyhow::bail!("unknown backend '{b}' (backends: auto, embree, bvh)"),
    };
    if let Some(web) = args.web {
        options.web_root = web;
    }
    shrad_view::serve(options)
}
