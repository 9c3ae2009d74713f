//! The `shrad bench` command (being written).

use anyhow::Result;
use clap::Args;

/// Options of `shrad bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Only the row nearest 75k patches (a few minutes).
    #[arg(long)]
    pub quick: bool,
    /// Output directory.
    #[arg(long)]
    pub out: std::path::PathBuf,
}

/// Run the benchmark.
pub fn cmd_bench(_args: BenchArgs) -> Result<()> {
    anyhow::bail!("shrad bench is not written yet")
}
