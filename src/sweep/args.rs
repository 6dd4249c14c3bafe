//! Command-line arguments of the sweep subcommands, for the CLI to embed with
//! `#[command(flatten)]`.

use super::matrix::Shard;
use super::run::RunOptions;
use std::path::PathBuf;

/// Arguments of `drive-sim sweep`.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// Sweep matrix file (TOML), e.g. sweeps/example.toml.
    pub matrix: PathBuf,
    /// Output directory: one sub-directory per run, named by its id.
    #[arg(long, default_value = "runs")]
    pub out: PathBuf,
    /// Shard `i/n` (0-based): runs the specs whose index mod n is i.
    #[arg(long, default_value = "0/1")]
    pub shard: Shard,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

impl SweepArgs {
    /// The run options these arguments ask for.
    pub fn options(&self) -> RunOptions {
        RunOptions {
            out_dir: self.out.clone(),
            shard: self.shard,
            threads: self.threads,
        }
    }
}

/// Arguments of `drive-sim sweep-merge`.
#[derive(Debug, Clone, clap::Args)]
pub struct MergeArgs {
    /// Sweep output directories (e.g. one per shard).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Where to write merged.json and merged.csv.
    #[arg(long, default_value = "merged")]
    pub out: PathBuf,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        sweep: SweepArgs,
    }

    #[test]
    fn shard_and_defaults_parse() {
        let c = Cli::try_parse_from(["x", "m.toml", "--shard", "1/3", "--threads", "2"]).unwrap();
        assert_eq!(c.sweep.shard, Shard::new(1, 3).unwrap());
        let o = c.sweep.options();
        assert_eq!((o.out_dir, o.threads), (PathBuf::from("runs"), Some(2)));
        let d = Cli::try_parse_from(["x", "m.toml"]).unwrap();
        assert_eq!(d.sweep.shard, Shard::default());
        let err = Cli::try_parse_from(["x", "m.toml", "--shard", "3/3"])
            .unwrap_err()
            .to_string();
        assert!(err.contains("below the count"), "{err}");
    }
}
