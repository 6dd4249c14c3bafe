//! `drive-sim judge REAL --robot TWIN --terrain TWIN --out DIR`: can `compare` tell the real
//! run from a run of the twin? ([`drive_sim::compare::judge`]).

use drive_sim::calibration::twin;
use drive_sim::compare::judge::interval::{self, IntervalOptions, IntervalRequest};
use drive_sim::compare::judge::{self, JudgeOptions, JudgeRequest};
use std::path::PathBuf;

/// Options of `drive-sim judge`.
#[derive(Debug, Clone, clap::Args)]
pub struct JudgeArgs {
    /// The real log (measured `.csv`, `.mcap` or a bag).
    pub real: PathBuf,
    /// The real steps to judge against: all, or the half the twin was not calibrated on
    /// (`calibrate --use-steps`, `tune --choose-on`).
    #[arg(long, value_parser = super::use_steps_parser(), default_value = "all")]
    pub real_steps: drive_sim::log::UseSteps,
    /// Runs of the twin compared with the real run and with each reference.
    #[arg(long, default_value_t = JudgeOptions::default().sims)]
    pub sims: u32,
    /// Runs of the twin that take the real run's place, drawn as the real steps were: for a half
    /// (`--real-steps odd|even`), that half of a run as long as the real log (the smallest
    /// p-value is 1 / (references + 1)).
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
    #[arg(long, value_parser = super::tf_smoother_parser(), default_value = "kernel")]
    pub tf_smoother: drive_sim::compare::TfSmoother,
    /// Bootstrap resamples of each comparison's intervals.
    #[arg(long, default_value_t = JudgeOptions::default().resamples)]
    pub resamples: usize,
    /// Level of compare's tests and of the judgement.
    #[arg(long, default_value_t = JudgeOptions::default().alpha)]
    pub alpha: f64,
    /// Also a confidence set for each of these parameters of the twin (effect names or
    /// parameter keys, as `tune --tune` takes them; comma-separated or repeated): the values at
    /// which this test cannot tell the real run from the twin's runs, one parameter moving and
    /// the others at the twin's values. About 6-12 judgements per parameter. When the twin is
    /// given as files, writes OUT/twin/robot.toml and terrain.toml with each set in its value's
    /// comment.
    #[arg(long, value_delimiter = ',')]
    pub interval: Vec<String>,
    /// Box to walk a parameter in, `KEY=LOWER:UPPER` (default: the registry's search box for
    /// this log's commands).
    #[arg(long = "interval-box", value_name = "KEY=LOWER:UPPER")]
    pub interval_box: Vec<String>,
    /// Bisections of the gap between the last value in the set and the first outside it.
    #[arg(long, default_value_t = IntervalOptions::default().refine)]
    pub interval_refine: u32,
    /// Most judgements per side of one parameter (steps outwards and bisections).
    #[arg(long, default_value_t = IntervalOptions::default().max_per_side)]
    pub interval_max_per_side: u32,
    /// Set an effect parameter of the twin on top of its files, `NAME=VALUE` (repeatable, as
    /// `tune --inject`): judge a variant without writing its files.
    #[arg(long = "inject", value_name = "EFFECT=VALUE")]
    pub inject: Vec<String>,
    /// Another real run of the same robot on the same ground (repeatable): compared with the
    /// judged steps as each twin run is, its loss is the robot's own difference, the yardstick
    /// beside the twin's mean loss.
    #[arg(long = "other-run", value_name = "LOG")]
    pub other_runs: Vec<PathBuf>,
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
    let iopts = IntervalOptions {
        refine: args.interval_refine,
        max_per_side: args.interval_max_per_side,
    };
    iopts.validate()?;
    let boxes = interval::parse_boxes(&args.interval_box)?;
    eprintln!("drive-sim: reading {}", args.real.display());
    let log = super::input::open_log(&args.real, &args.input)?;
    let models = super::input::starting_models(&log, &args.input)?;
    let mut model = twin::lift_effects(&models.robot, &models.terrain)?;
    for a in &args.inject {
        model.effects.apply_assignment(a)?;
    }
    let specs = if args.interval.is_empty() {
        Vec::new()
    } else {
        interval::interval_specs(&args.interval, &boxes, &model, &log)?
    };
    let twin_files = if args.interval.is_empty() {
        None
    } else {
        judge::write::read_twin_files(args.input.robot.as_deref(), args.input.terrain.as_deref())?
    };
    let others = args
        .other_runs
        .iter()
        .map(|p| super::input::open_log(p, &args.input))
        .collect::<drive_sim::Result<Vec<_>>>()?;
    // Another robot or ground is refused before the judgement's minutes.
    for other in &others {
        judge::check_same_ground(&log, other)?;
    }
    let staged = drive_sim::output::StagedDir::begin(&args.out, "--out")?;
    let t0 = std::time::Instant::now();
    let print = |event: &dyn std::fmt::Display| {
        eprintln!("drive-sim: [{:>6.1} s] {event}", t0.elapsed().as_secs_f64())
    };
    let request = JudgeRequest {
        real: &log,
        model: &model,
        opts: &opts,
    };
    let mut outcome = judge::judge(&request, &|e| print(e))?;
    let other_refs: Vec<&drive_sim::log::DriveLog> = others.iter().collect();
    outcome.yardsticks = judge::yardsticks(&judge::YardstickRequest {
        real: &log,
        others: &other_refs,
        others_half: None,
        model: &model,
        opts: &opts,
        twin_mean_loss: outcome.loss.real,
    })?;
    if !specs.is_empty() {
        outcome.intervals = interval::intervals(
            &IntervalRequest {
                judge: request,
                centre: &outcome,
                specs: &specs,
                opts: &iopts,
            },
            &|e| print(e),
        )?;
    }
    let provenance = models.provenance(
        &args.real,
        serde_json::json!({
            "options": opts,
            "robot": args.input.robot,
            "terrain": args.input.terrain,
            "inject": args.inject,
        }),
    );
    let mut written = judge::write::write_judge(&outcome, &provenance, staged.path())?;
    if !outcome.intervals.is_empty() {
        match &twin_files {
            Some(_) if !args.inject.is_empty() => eprintln!(
                "drive-sim: --inject changed the twin its files describe: the sets are in judge.json and judge.md only"
            ),
            Some(files) => {
                let twin = judge::write::write_annotated_twin(
                    [&files[0].1, &files[1].1],
                    &outcome.intervals,
                    &outcome.dataset,
                    opts.real_steps.as_str(),
                    &staged.path().join("twin"),
                )?;
                for key in &twin.unplaced {
                    eprintln!(
                        "drive-sim: `{key}` is set in neither {} nor {}: its set is in judge.json only",
                        files[0].0.display(),
                        files[1].0.display()
                    );
                }
                written.extend(twin.files);
            }
            None => eprintln!(
                "drive-sim: the twin is not given as two files (--robot FILE --terrain FILE): the sets are in judge.json and judge.md only"
            ),
        }
    }
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
