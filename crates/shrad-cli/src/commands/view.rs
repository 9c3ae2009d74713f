//! `shrad view`: watch and steer a scene's global illumination live in a browser. The
//! server, the engine thread and the page are the library's (`shrad_view`); this file only
//! turns the command line into its `ServeOptions`.

use std::net::{IpAddr, Ipv4Addr};
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use shrad_scene::Scene;

use crate::common::{sizing, SceneArgs};
use crate::settings::FileSettings;
use crate::solver_args::SolverArgs;

/// Options of `shrad view`.
#[derive(Args)]
#[command(mut_arg("solver", |a| a.help(
    "The solver the page starts with (the page can switch it) [default: the scene file's `solver`, else dispersive]"
)))]
pub struct ViewArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Address to bind. Anything but a loopback address needs a token: one is generated
    /// (unless --token gives it) and printed in the URL, as Jupyter does.
    #[arg(long, default_value_t = IpAddr::V4(Ipv4Addr::LOCALHOST))]
    host: IpAddr,
    /// The token every page, file and WebSocket request must carry (`?token=...`, at
    /// least 16 letters, digits or - . _ ~); on loopback too when given.
    #[arg(long, value_name = "TOKEN")]
    token: Option<String>,
    /// Clients at once; one more is refused with a message the page shows.
    #[arg(long, value_name = "N", default_value_t = shrad_view::access::DEFAULT_MAX_CLIENTS)]
    max_clients: usize,
    /// Every client watches: nobody moves objects, changes lights, solvers or settings
    /// (otherwise the first client steers until it hands over).
    #[arg(long)]
    watch_only: bool,
    /// Port (0: any free port; the URL printed says which).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// The page's folder, with src/ and node_modules/three [default: this repository's
    /// web/, set up by scripts/setup-browser].
    #[arg(long, value_name = "DIR")]
    web: Option<PathBuf>,
}

/// Serve until Ctrl-C.
pub fn run(mut args: ViewArgs, scene: Scene, file: &FileSettings) -> Result<()> {
    let quiet = args.scene.quiet;
    // A live view starts on a live solver, not on the reference the other commands default to.
    if args.solver.solver.is_none() && file.solver.is_none() {
        args.solver.solver = Some("dispersive".to_string());
    }
    let choice = args.solver.choice(file, quiet)?;
    let preset = args
        .solver
        .preset
        .clone()
        .or_else(|| file.preset.clone())
        .unwrap_or_else(|| "default".to_string());
    let sizing = sizing(&args.scene, &scene)?;
    let mut options = shrad_view::ServeOptions::new(scene);
    options.sizing = sizing;
    options.backend = args.scene.backend.backend();
    options.solver = choice.name().to_string();
    options.preset = preset;
    options.choice = Some(choice);
    // The page's error button measures against the engine's fast reference, with the
    // reference flags given (`--rays-per-patch`, `--direct-samples`), as `render --compare`
    // does against the standard one.
    options.reference = Some(
        args.solver
            .reference_over(shrad::reference::ReferenceOptions::fast())?,
    );
    // The library makes a token for a host that is not loopback.
    options.host = args.host;
    options.access = shrad_view::AccessOptions {
        token: args.token,
        max_clients: args.max_clients,
        watch_only: args.watch_only,
        ..Default::default()
    };
    options.port = args.port;
    if let Some(web) = args.web {
        options.web_root = web;
    }
    // Before "patching and precomputing..." is said: a short token, no client allowed or a
    // page that is not there are refused at once, and the message made them look refused
    // after the work.
    shrad_view::check_options(&options)?;
    if !quiet {
        let patches = match sizing {
            shrad::PatchSizing::Count(n) => format!("about {n} patches"),
            shrad::PatchSizing::Size(h) => format!("patches of size {h}"),
        };
        eprintln!(
            "shrad view: {}: {patches}, {} solver ({} preset); patching and precomputing...",
            options.scene.source, options.solver, options.preset
        );
    }
    shrad_view::serve(options).context("shrad view")
}
