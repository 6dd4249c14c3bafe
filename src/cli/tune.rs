//! `drive-sim tune REAL --tune NAMES --out DIR`: a twin's parameters chosen in closed loop by
//! `compare`'s statistics ([`drive_sim::compare::tune`]).

use drive_sim::calibration::twin;
use drive_sim::compare::tune::{self, search::SearchOptions, TuneOptions, TuneRequest};
use std::io::Write;
use std::path::PathBuf;

/// Options of `drive-sim tune`.
#[derive(Debug, Clone, clap::Args)]
pub struct TuneArgs {
    /// The real log (measured `.csv`, `.mcap` or a bag).
    pub real: PathBuf,
    /// What to tune, comma-separated: effects (all their parameters), effect parameters, or
    /// simulator base parameters (`terrain.friction.peak_lateral`); `drive-sim effects` lists
    /// the effects.
    #[arg(long, value_delimiter = ',', required = true)]
    pub tune: Vec<String>,
    /// Choose on the real log's odd or even steps (the other half then judges the choice), or
    /// on all of them (no held-out judgement).
    #[arg(long, value_parser = super::use_steps_parser(), default_value = "odd")]
    pub choose_on: drive_sim::log::UseSteps,
    /// A search box instead of the registry's, `KEY=LOWER:UPPER` (repeatable; an effect
    /// parameter's key or a base parameter's name), e.g. `turning_resistance_scale=0.5:1.5`.
    #[arg(long = "box", value_name = "KEY=LOWER:UPPER")]
    pub boxes: Vec<String>,
    /// Set an effect parameter of the starting model first, `NAME=VALUE` (repeatable; e.g.
    /// `wheel_speed_saturation_rad_s=0` switches the declared limit off).
    #[arg(long = "inject", value_name = "EFFECT=VALUE")]
    pub inject: Vec<String>,
    /// DRIVE steps of each simulated run (default: as many as the real steps the choice uses,
    /// so that the T/U hulls compare like with like).
    #[arg(long)]
    pub steps: Option<u32>,
    /// First seed: the search runs seeds SEED.., the check SEED+1000.., the judgement SEED+2000...
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seeds each point of the search is run with.
    #[arg(long, default_value_t = TuneOptions::default().choose_seeds)]
    pub seeds: u32,
    /// Fresh seeds of the check (and of the held-out judgement).
    #[arg(long, default_value_t = TuneOptions::default().check_seeds)]
    pub check_seeds: u32,
    /// Most points the search evaluates.
    #[arg(long, default_value_t = SearchOptions::default().max_evaluations)]
    pub max_evaluations: usize,
    /// Bootstrap resamples of the loss's intervals during the search (the judgement uses
    /// compare's 2000).
    #[arg(long, default_value_t = TuneOptions::default().loss_resamples)]
    pub loss_resamples: usize,
    /// Smoother of the compared maps, in the loss and the judgement (as `compare --tf-smoother`).
    #[arg(long, value_parser = super::tf_smoother_parser(), default_value = "kernel")]
    pub tf_smoother: drive_sim::compare::TfSmoother,
    /// Output directory.
    #[arg(long, default_value = "out/tune")]
    pub out: PathBuf,
    /// The starting model (`--robot`, `--terrain`: names or files, e.g. a calibrated twin's;
    /// default the log's robot and terrain), and how to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
}

impl TuneArgs {
    fn options(&self) -> TuneOptions {
        TuneOptions {
            choose_on: self.choose_on,
            steps: self.steps,
            seed: self.seed,
            choose_seeds: self.seeds,
            check_seeds: self.check_seeds,
            search: SearchOptions {
                max_evaluations: self.max_evaluations,
                ..SearchOptions::default()
            },
            loss_resamples: self.loss_resamples,
            tf_smoother: self.tf_smoother,
        }
    }

    /// The command line that reproduces this tuning (`tune.json` → `provenance`, and the
    /// twin's header).
    fn reproduce(&self) -> String {
        let mut s = format!(
            "drive-sim tune {} --tune {} --choose-on {}{} --seed {} --seeds {} --check-seeds {} --max-evaluations {} --loss-resamples {}",
            self.real.display(),
            self.tune.join(","),
            self.choose_on.as_str(),
            self.steps.map_or_else(String::new, |s| format!(" --steps {s}")),
            self.seed,
            self.seeds,
            self.check_seeds,
            self.max_evaluations,
            self.loss_resamples
        );
        if self.tf_smoother != drive_sim::compare::TfSmoother::Kernel {
            s.push_str(" --tf-smoother local-linear");
        }
        for i in &self.inject {
            s.push_str(&format!(" --inject {i}"));
        }
        for b in &self.boxes {
            s.push_str(&format!(" --box {b}"));
        }
        for (flag, v) in [("--robot", &self.input.robot), ("--terrain", &self.input.terrain)] {
            if let Some(v) = v {
                s.push_str(&format!(" {flag} {v}"));
            }
        }
        s.push_str(&format!(" --out {}", self.out.display()));
        s
    }
}

/// Reads the log and the starting model, checks everything, tunes, writes and prints.
pub fn tune(args: &TuneArgs) -> anyhow::Result<()> {
    let opts = args.options();
    opts.validate()?;
    let boxes = args
        .boxes
        .iter()
        .map(|b| tune::BoxOverride::parse(b))
        .collect::<drive_sim::compare::Result<Vec<_>>>()?;
    eprintln!("drive-sim: reading {}", args.real.display());
    let log = super::input::open_log(&args.real, &args.input)?;
    let models = super::input::starting_models(&log, &args.input)?;
    let mut start = twin::lift_effects(&models.robot, &models.terrain)?;
    for a in &args.inject {
        start.effects.apply_assignment(a)?;
    }
    let staged = drive_sim::output::StagedDir::begin(&args.out, "--out")?;
    let t0 = std::time::Instant::now();
    let outcome = tune::tune(
        &TuneRequest {
            real: &log,
            start: &start,
            tune: &args.tune,
            boxes: &boxes,
            opts: &opts,
        },
        &|event| eprintln!("drive-sim: [{:>6.1} s] {event}", t0.elapsed().as_secs_f64()),
    )?;
    let start_source = format!(
        "robot `{}` and terrain `{}`{}",
        args.input.robot.as_deref().unwrap_or(&models.robot.name),
        args.input.terrain.as_deref().unwrap_or(&models.terrain.name),
        if args.inject.is_empty() {
            String::new()
        } else {
            format!(" with {}", args.inject.join(", "))
        }
    );
    let reproduce = args.reproduce();
    let files = tune::twin_of(&outcome, &start_source, &reproduce)?;
    let provenance = models.provenance(
        &args.real,
        serde_json::json!({
            "tune": args.tune,
            "choose_on": args.choose_on.as_str(),
            "inject": args.inject,
            "box": args.boxes,
            "options": opts,
            "robot": args.input.robot,
            "terrain": args.input.terrain,
            "reproduce": reproduce,
        }),
    );
    let written = tune::write::write_tune(
        &outcome,
        &files,
        &log.meta.nominal.command_space().polygon_body(),
        &provenance,
        staged.path(),
    )?;
    staged.commit()?;
    // As a write, not `print!`: a closed pipe is an error the caller handles, not a panic.
    std::io::stdout().write_all(tune::write::table(&outcome).as_bytes())?;
    super::input::twin_hints(&args.real, &args.out, args.choose_on);
    if outcome.accepted {
        // The tuned values carry no interval: the judge, inverted, gives one (minutes each).
        let names: Vec<String> = outcome
            .params
            .iter()
            .map(|p| p.name.trim_start_matches("effect.").to_string())
            .collect();
        eprintln!(
            "drive-sim: confidence sets for the tuned values (6-12 judgements each, on the steps they were chosen on): drive-sim judge {} --robot {} --terrain {} --real-steps {} --interval {}",
            args.real.display(),
            args.out.join("twin/robot.toml").display(),
            args.out.join("twin/terrain.toml").display(),
            args.choose_on.as_str(),
            names.join(",")
        );
    }
    eprintln!(
        "drive-sim: wrote {} files into {} ({:.0} s)",
        written.len(),
        args.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
