//! `drive-sim compare REAL SIM... --out DIR`: does the simulation reproduce the real run?

use drive_sim::analysis::bootstrap::Bootstrap;
use drive_sim::compare::{
    compare as run_compare, write::verdict_text, write::write_comparison, CompareOptions, Input,
};
use std::path::PathBuf;

/// Options of `drive-sim compare`.
#[derive(Debug, Clone, clap::Args)]
pub struct CompareArgs {
    /// The real log (measured `.csv`, `.mcap` or a bag).
    pub real: PathBuf,
    /// One or more simulated logs of the same robot (e.g. `drive-sim run` on a twin, or a
    /// `drive-sim replay` of the real commands, which is compared paired by step).
    #[arg(required = true)]
    pub sims: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out/compare")]
    pub out: PathBuf,
    /// Bootstrap resamples per interval.
    #[arg(long, default_value_t = Bootstrap::default().resamples)]
    pub resamples: usize,
    /// Seed of the bootstrap draws.
    #[arg(long, default_value_t = Bootstrap::default().seed)]
    pub seed: u64,
    /// Family-wise significance level (Holm).
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Permutations of the maps' test (0: skip it).
    #[arg(long, default_value_t = CompareOptions::default().tf_permutations)]
    pub permutations: usize,
    /// Smoother of the compared maps: `kernel` (the paper's weighted mean) or `local-linear`
    /// (a weighted plane: no bias from which commands a run drew on a sloped map).
    #[arg(long, value_parser = super::tf_smoother_parser(), default_value = "kernel")]
    pub tf_smoother: drive_sim::compare::TfSmoother,
    /// Halvings of the real run whose mean split-half RMS is the maps' yardstick (its odd and
    /// even steps, then random balanced halvings); 1: the odd and even steps alone.
    #[arg(long, default_value_t = drive_sim::compare::DEFAULT_YARDSTICK_SPLITS)]
    pub yardstick_splits: usize,
    /// Compare only the real log's odd or even steps (e.g. those a twin was not calibrated on,
    /// `calibrate --use-steps`), or all of them.
    #[arg(long, value_parser = super::use_steps_parser(), default_value = "all")]
    pub real_steps: drive_sim::log::UseSteps,
    /// How to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
}

/// Reads the logs, compares them, writes the report and prints the verdict table.
pub fn compare(args: &CompareArgs) -> anyhow::Result<()> {
    let opts = CompareOptions {
        bootstrap: Bootstrap {
            resamples: args.resamples,
            seed: args.seed,
            ..Bootstrap::default()
        },
        alpha: args.alpha,
        tf_permutations: args.permutations,
        tf_smoother: args.tf_smoother,
        tf_yardstick_splits: args.yardstick_splits,
        ..CompareOptions::default()
    };
    opts.validate()?;
    if args.out.is_file() {
        anyhow::bail!("--out {}: is a file, not a directory", args.out.display());
    }
    eprintln!("drive-sim: reading {}", args.real.display());
    let real = args
        .real_steps
        .select(&super::input::open_log(&args.real, &args.input)?);
    let mut sims = Vec::new();
    for p in &args.sims {
        eprintln!("drive-sim: reading {}", p.display());
        sims.push(super::input::open_log(p, &args.input)?);
    }
    let inputs: Vec<Input> = sims
        .iter()
        .zip(&args.sims)
        .map(|(log, f)| Input {
            log,
            file: Some(f.as_path()),
        })
        .collect();
    let report = run_compare(
        Input {
            log: &real,
            file: Some(args.real.as_path()),
        },
        &inputs,
        &opts,
    )?;
    let files = write_comparison(
        &report,
        &real.meta.nominal.command_space().polygon_body(),
        &args.out,
    )?;
    print!("{}", verdict_text(&report));
    eprintln!(
        "drive-sim: wrote {} files into {}",
        files.len(),
        args.out.display()
    );
    Ok(())
}
