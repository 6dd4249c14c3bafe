//! `drive-sim judge REAL --robot TWIN --terrain TWIN --out DIR`: can `compare` tell the real
//! run from a run of the twin? ([`crate::experiments::judge`]).

use crate::calibration::twin;
use crate::experiments::judge::{self, JudgeOptions, JudgeRequest};
use std::path::PathBuf;

/// Options of `drive-sim judge`.
#[derive(Debug, Clone, clap::Args)]
pub struct JudgeArgs {
    /// The real log (measured `.csv`, `.mcap` or a bag).
    pub real: PathBuf,
    /// The real steps to judge against: all, or the half the twin was not calibrated on
    /// (`calibrate --use-steps`, `tune --choose-on`).
    #[arg(long, value_enum, default_value = "all")]
    pub real_steps: crate::log::UseSteps,
    /// Runs of the twin compared with the real run and with each reference.
    #[arg(long, default_value_t = JudgeOptions::default().sims)]
    pub sims: u32,
    /// Runs of the twin that take the real run's place (the smallest p-value is
    /// 1 / (references + 1)).
    #[arg(long, default_value_t = JudgeOptions::default().references)]
    pub references: u32,
    /// DRIVE steps of each run (default: as many as the judged real steps, so that the T/U
    /// hulls compare like with like).
    #[arg(long)]
    pub steps: Option<u32>,
    /// First seed: the runs are seeds SEED.., the references SEED+5000...
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Smoother of the compared maps (as `compare --tf-smoother`).
    #[arg(long, value_enum, default_value = "kernel")]
    pub tf_smoother: crate::compare::TfSmoother,
    /// Bootstrap resamples of each comparison's intervals.
    #[arg(long, default_value_t = JudgeOptions::default().resamples)]
    pub resamples: usize,
    /// Level of compare's tests and of the judgement.
    #[arg(long, default_value_t = JudgeOptions::default().alpha)]
    pub alpha: f64,
    /// Output directory.
    #[arg(long, default_value = "out/judge")]
    pub out: PathBuf,
    /// The twin (`--robot`, `--terrain`: names or files, e.g. `OUT/twin/robot.toml`; default
    /// the log's robot and terrain), and how to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
}

impl JudgeArgs {
    fn options(&self) -> JudgeOptions {
        JudgeOptions {
            real_steps: self.real_steps,
            steps: self.steps,
            seed: self.seed,
            sims: self.sims,
            references: self.references,
            tf_smoother: self.tf_smoother,
            resamples: self.resamples,
            alpha: self.alpha,
        }
    }
}

/// Reads the log and the twin, checks everything, judges, writes and prints.
pub fn judge(args: &JudgeArgs) -> anyhow::Result<()> {
    let opts = args.options();
    opts.validate()?;
    eprintln!("drive-sim: reading {}", args.real.display());
    let log = super::input::open_log(&args.real, &args.input)?;
    let models = super::input::starting_models(&log, &args.input)?;
    let model = twin::lift_effects(&models.robot, &models.terrain)?;
    let staged = crate::output::StagedDir::begin(&args.out, "--out")?;
    let t0 = std::time::Instant::now();
    let outcome = judge::judge(
        &JudgeRequest {
            real: &log,
            model: &model,
            opts: &opts,
        },
        &|line| eprintln!("drive-sim: [{:>6.1} s] {line}", t0.elapsed().as_secs_f64()),
    )?;
    let provenance = models.provenance(
        &args.real,
        serde_json::json!({
            "options": opts,
            "robot": args.input.robot,
            "terrain": args.input.terrain,
        }),
    );
    let written = judge::write::write_judge(&outcome, &provenance, staged.path())?;
    staged.commit()?;
    println!("{}", judge::write::table(&outcome));
    eprintln!(
        "drive-sim: wrote {} files into {} ({:.0} s)",
        written.len(),
        args.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
