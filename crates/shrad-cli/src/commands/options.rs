//! `shrad options [SOLVER]`: every setting of a solver (or of all three) with its default in
//! each preset, its range and its doc, as Markdown tables, all read from the library
//! (`shrad::settings`). docs/options.md is this command's output.

use std::fmt::Write as _;

use anyhow::Result;
use clap::builder::PossibleValuesParser;
use clap::Args;
use shrad::settings::{describe, presets, SOLVERS};

/// Options of `shrad options`.
#[derive(Args)]
pub struct OptionsArgs {
    /// Only this solver [default: all of them].
    #[arg(value_parser = PossibleValuesParser::new(SOLVERS))]
    pub solver: Option<String>,
}

/// The table of one solver.
fn table(solver: &str) -> Result<String> {
    let presets = presets(solver)?;
    let keys = describe(solver)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## {solver}\n\n`--solver {solver}`; presets: {} (`--preset NAME`, the first is the default).\n",
        presets.join(", ")
    );
    let columns: Vec<String> = presets.iter().map(|p| format!("{p} preset")).collect();
    let _ = writeln!(
        s,
        "| key | {} | range | precomputes | what it does |",
        columns.join(" | ")
    );
    let _ = writeln!(s, "|---|{}---|---|---|", "---|".repeat(presets.len()));
    for k in keys {
        let defaults: Vec<&str> = k.defaults.iter().map(|(_, v)| v.as_str()).collect();
        let _ = writeln!(
            s,
            "| `{}` | {} | {} | {} | {} |",
            k.name,
            defaults.join(" | "),
            k.range.replace('|', "\\|"),
            if k.rebuilds { "yes" } else { "no" },
            k.doc.replace('|', "\\|")
        );
    }
    Ok(s)
}

/// Print the tables.
pub fn run(args: OptionsArgs) -> Result<()> {
    let solvers: Vec<&str> = match &args.solver {
        Some(s) => vec![s.as_str()],
        None => SOLVERS.to_vec(),
    };
    say!("# Solver settings\n");
    say!("The output of `shrad options`; docs/options.md is regenerated with `cargo run --release -p shrad-cli -- options > docs/options.md`.\n");
    say!("Each key is set with `--set KEY=VALUE` (repeatable) on `shrad render`, `animate`, `bake` and `view`, in a scene file's `[settings.solver]` table (with `solver` and `preset`), or from Python, by the same name (`-` may stand for `_`). A value outside its range is an error naming the key. \"precomputes\": changing it on a running engine runs the solver's precomputation again; \"-\": the preset's schedule does not use the key.\n");
    for solver in solvers {
        say!("{}", table(solver)?);
    }
    Ok(())
}
