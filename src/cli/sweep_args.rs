//! Command-line arguments of `drive-sim sweep` and `drive-sim sweep-merge`.

use drive_sim::harness::sweep::{select_shard, RunOptions, Shard, ShardChoice};
use drive_sim::harness::Result;
use std::path::PathBuf;

/// Arguments of `drive-sim sweep`.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// Sweep matrix file (TOML), e.g. sweeps/example.toml.
    pub matrix: PathBuf,
    /// Output directory: one sub-directory per run, named by its id.
    #[arg(long, default_value = "runs")]
    pub out: PathBuf,
    /// Shard `i/n` (0-based): runs the specs whose index mod n is i. Without it, the shard
    /// comes from the batch system (SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or
    /// AWS_BATCH_JOB_ARRAY_INDEX), else the whole sweep runs.
    #[arg(long)]
    pub shard: Option<Shard>,
    /// Number of shards, for a Kubernetes Indexed Job or an AWS Batch array (their index
    /// variable does not say how many tasks there are); optional check for a SLURM array.
    #[arg(long, conflicts_with = "shard")]
    pub shard_count: Option<usize>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Keep each run's MCAP log (`<out>/<id>/<id>.mcap`), not only its figures.
    #[arg(long)]
    pub keep_logs: bool,
}

impl SweepArgs {
    /// The shard these arguments and `env` (a variable lookup, e.g. the process environment)
    /// select, with where it came from.
    pub fn shard_choice(&self, env: &dyn Fn(&str) -> Option<String>) -> Result<ShardChoice> {
        select_shard(self.shard, self.shard_count, env)
    }

    /// The run options of the shard `shard`.
    pub fn options(&self, shard: Shard) -> RunOptions {
        RunOptions {
            out_dir: self.out.clone(),
            shard,
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

    fn no_env(_: &str) -> Option<String> {
        None
    }

    #[test]
    fn shard_and_defaults_parse() {
        let c =
            Cli::try_parse_from(["x", "m.toml", "--shard", "1/3", "--threads", "2", "--keep-logs"]).unwrap();
        assert_eq!(c.sweep.shard, Some(Shard::new(1, 3).unwrap()));
        assert!(c.sweep.keep_logs);
        let shard = c.sweep.shard_choice(&no_env).unwrap().shard;
        let o = c.sweep.options(shard);
        assert_eq!(
            (o.out_dir, o.threads, o.shard),
            (PathBuf::from("runs"), Some(2), shard)
        );
        let d = Cli::try_parse_from(["x", "m.toml"]).unwrap();
        assert_eq!(d.sweep.shard_choice(&no_env).unwrap().shard, Shard::default());
        assert!(!d.sweep.keep_logs);
        let err = Cli::try_parse_from(["x", "m.toml", "--shard", "3/3"])
            .unwrap_err()
            .to_string();
        assert!(err.contains("below the count"), "{err}");
        // --shard-count is for the batch systems; with --shard it would say the count twice.
        assert!(Cli::try_parse_from(["x", "m.toml", "--shard", "0/2", "--shard-count", "2"]).is_err());
        let k = Cli::try_parse_from(["x", "m.toml", "--shard-count", "4"]).unwrap();
        let env = |n: &str| (n == "JOB_COMPLETION_INDEX").then(|| "3".to_string());
        assert_eq!(
            k.sweep.shard_choice(&env).unwrap().shard,
            Shard::new(3, 4).unwrap()
        );
    }
}
