//! docs/cli.md is every command's `--help`, as `shrad` prints it: a user reading the docs
//! finds each option there (a pass over the docs found a third of them only in `--help`).
//! Regenerate it with `SHRAD_BLESS=1 cargo test -p shrad-cli --test all cli_doc`.

use crate::common::{repo, shrad};

/// The commands `shrad --help` lists (not `help` itself).
fn commands(top: &str) -> Vec<String> {
    top.lines()
        .skip_while(|l| l.trim() != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

fn help(args: &[&str]) -> String {
    let o = shrad(args);
    assert!(o.status.success(), "shrad {args:?}: {o:?}");
    String::from_utf8(o.stdout).unwrap()
}

/// What docs/cli.md must hold.
fn cli_reference() -> String {
    let top = help(&["--help"]);
    let mut doc = String::from(
        "# Command line\n\n\
         Every command's `--help`, as `shrad` prints it (regenerated with `SHRAD_BLESS=1 cargo \
         test -p shrad-cli --test all cli_doc`; that test fails when this page is out of date). \
         Solver settings (`--set KEY=VALUE`) are in [options.md](options.md), scene files in \
         [scene-format.md](scene-format.md), the viewer in [viewer.md](viewer.md).\n",
    );
    doc += &format!("\n## shrad\n\n```text\n{top}```\n");
    let commands = commands(&top);
    assert!(commands.len() >= 7, "{commands:?} from {top}");
    for c in &commands {
        doc += &format!("\n## shrad {c}\n\n```text\n{}```\n", help(&[c, "--help"]));
    }
    doc
}

#[test]
fn docs_cli_md_is_every_commands_help() {
    let want = cli_reference();
    let path = repo().join("docs/cli.md");
    if std::env::var_os("SHRAD_BLESS").is_some() {
        std::fs::write(&path, &want).unwrap();
    }
    let doc = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        doc == want,
        "docs/cli.md is out of date: regenerate it with SHRAD_BLESS=1 cargo test -p shrad-cli --test all cli_doc"
    );
    for option in [
        "--patch-size",
        "--export-patches",
        "--warmup",
        "--texel-size",
        "--port",
    ] {
        assert!(doc.contains(option), "{option}");
    }
}
