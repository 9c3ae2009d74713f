//! `shrad bench`: the paper's Tables 1-3 and Figures 2-3 in one run (`shrad_bench`), with a
//! progress bar; writes results.json, report.json, results.md and the plots.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use shrad_bench::{BenchOptions, SolverKind};

use crate::common::{describe_backend, BackendArg};

/// Options of `shrad bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Only the row nearest 75k patches (a few minutes).
    #[arg(long)]
    pub quick: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Reference solver: form-factor rays per patch [default: the bench protocol's 128,
    /// fewer than `render`'s, to fit the full run in minutes].
    #[arg(long)]
    pub rays_per_patch: Option<u32>,
    /// Only these scenes (comma-separated names, e.g. room-12k,big-18.5k-280).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Only these solvers (comma-separated: grid5, grid4, grid5-r32, dispersive, paper).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::ValueParser::new(parse_kind))]
    pub solvers: Vec<SolverKind>,
    /// Override every scene's target patch count (smoke tests; not the paper's sizes).
    #[arg(long, hide = true)]
    pub patches: Option<usize>,
    /// No progress bar and no informational lines (errors and warnings still print).
    #[arg(long, short)]
    pub quiet: bool,
}

fn parse_kind(s: &str) -> Result<SolverKind, String> {
    s.parse()
}

/// The protocol with the command line's changes.
fn options(args: &BenchArgs) -> Result<BenchOptions> {
    let mut options = BenchOptions::new(args.quick);
    if let Some(r) = args.rays_per_patch {
        if r == 0 {
            bail!("--rays-per-patch must be at least 1");
        }
        options.reference.rays_per_patch = r;
    }
    if !args.scenes.is_empty() {
        let all = shrad_bench::scenes(false);
        options.scenes = Vec::new();
        for name in &args.scenes {
            let spec = all.iter().find(|s| &s.name == name).with_context(|| {
                let names: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
                format!("unknown scene {name}; known: {}", names.join(", "))
            })?;
            options.scenes.push(spec.clone());
        }
    }
    if !args.solvers.is_empty() {
        options.set_solvers(&args.solvers);
    }
    if let Some(n) = args.patches {
        if !(100..=10_000_000).contains(&n) {
            bail!("--patches must be between 100 and 10000000, got {n}");
        }
        for spec in &mut options.scenes {
            spec.params.patches = n;
            if let Some(b) = spec.params.big_object_patches.as_mut() {
                *b = (*b).min(n / 2);
            }
        }
    }
    Ok(options)
}

/// Run the benchmark and write its files.
pub fn run(args: BenchArgs) -> Result<()> {
    let options = options(&args)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let command = std::env::args()
        .map(|a| if a.contains(' ') { format!("'{a}'") } else { a })
        .collect::<Vec<_>>()
        .join(" ");
    let quiet = args.quiet;
    if !quiet {
        let embree = shrad::vis::available_backends().contains(&shrad::vis::Backend::Embree);
        let name = if embree { "embree" } else { "bvh" };
        eprintln!("visibility: {}", describe_backend(name, BackendArg::Auto));
        eprintln!(
            "shrad bench: {} scenes, {} solver runs; reference with {} rays per patch; grids: {} warm-up + {} timed frames; dispersive: {} warm-up + {} timed passes (1 pass = 1 frame per interior object)",
            options.scenes.len(),
            options
                .scenes
                .iter()
                .map(|s| options.solvers_for(s).len())
                .sum::<usize>(),
            options.reference.rays_per_patch,
            options.grid_warmup,
            options.grid_timed,
            options.dispersive_warmup_passes,
            options.dispersive_timed_passes
        );
    }
    let bar = crate::progress::Bars::with_template(
        "{msg} [{bar:40}] {pos}/{len} steps ({elapsed}, eta {eta})",
    );
    let report = if quiet {
        shrad_bench::run(&options, &shrad::NoProgress, &|_| {})?
    } else {
        shrad_bench::run(&options, &bar, &|line| bar.println(line))?
    };
    // Warnings are said even with --quiet.
    shrad_bench::write_outputs(&report, &args.out, &command, &|w| eprintln!("warning: {w}"))?;
    if !quiet {
        eprintln!("{}", shrad_bench::summary(&report, &command));
        eprintln!(
            "wrote results.json, results.md, plots to {} ({:.0} s)",
            args.out.display(),
            report.seconds
        );
    }
    Ok(())
}
