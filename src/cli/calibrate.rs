//! `drive-sim replay` and `drive-sim calibrate`: the simulator against measured data (or any
//! DRIVE log, e.g. a simulated one carrying an undeclared `--inject`ed effect).

use drive_sim::calibration::{
    self, Calibrated, CalibrationEvent, CalibrationOptions, CalibrationReport, ModelKind,
};
use drive_sim::error::Result;
use std::io::Write;
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Instant;

/// Options of `drive-sim replay`.
#[derive(Debug, Clone, clap::Args)]
pub struct ReplayArgs {
    /// The log whose commands are replayed (measured `.csv` or simulated `.mcap`).
    pub log: PathBuf,
    /// Output directory.
    #[arg(long, default_value = "out/replay")]
    pub out: PathBuf,
    /// How to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
    /// Model replayed: `simulator` (rapier) or `kinematic` (grey-box, fast).
    #[arg(long, default_value = "simulator")]
    pub model: String,
    /// Also score the replay on the test steps of this `calibration.json`, with its noise
    /// floor: replaying a twin (`--robot OUT/twin/robot.toml --terrain OUT/twin/terrain.toml`)
    /// reproduces that calibration's test score.
    #[arg(long, value_name = "CALIBRATION_JSON")]
    pub score_like: Option<PathBuf>,
}

/// Options of `drive-sim calibrate`.
#[derive(Debug, Clone, clap::Args)]
pub struct CalibrateArgs {
    /// The log to calibrate on (measured `.csv` or simulated `.mcap`); several logs of one
    /// robot are calibrated jointly: one robot, one terrain per log.
    #[arg(required = true, num_args = 1..)]
    pub logs: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out/calibration")]
    pub out: PathBuf,
    /// How to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
    /// Model calibrated: `simulator` (rapier) or `kinematic` (grey-box, fast).
    #[arg(long, default_value = "simulator")]
    pub model: String,
    /// Seed of the train / validation / test split and of the bootstraps.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Most effects added.
    #[arg(long, default_value_t = CalibrationOptions::default().max_effects)]
    pub max_effects: usize,
    /// Fit on at most this many training steps per evaluation (all by default).
    #[arg(long)]
    pub max_fit_steps: Option<usize>,
    /// Local solver: `levenberg-marquardt` (default) or `nelder-mead` (the first
    /// calibration's, to compare).
    #[arg(long, default_value = "levenberg-marquardt")]
    pub optimizer: String,
    /// Only these candidate effects (comma-separated registry names).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Option<Vec<String>>,
    /// Calibrate on the odd or even steps only (the twin is then judged on the other half with
    /// `compare --real-steps`), or on all of them.
    #[arg(long, value_parser = super::use_steps_parser(), default_value = "all")]
    pub use_steps: drive_sim::log::UseSteps,
    /// Skip equation discovery: the catalogue's effects only (much faster on measured data,
    /// where discovery refits every candidate term beside every selected effect).
    #[arg(long)]
    pub no_discovery: bool,
}

impl CalibrateArgs {
    /// The calibration these arguments ask for.
    fn request(&self) -> calibration::CalibrateRequest {
        calibration::CalibrateRequest {
            logs: self.logs.clone(),
            out: self.out.clone(),
            input: self.input.options(),
            model: self.model.clone(),
            optimizer: self.optimizer.clone(),
            seed: self.seed,
            max_effects: self.max_effects,
            max_fit_steps: self.max_fit_steps,
            candidates: self.candidates.clone(),
            use_steps: self.use_steps,
            discover: !self.no_discovery,
        }
    }
}

/// Replays a log on the declared model and reports how far it is, beside the IDD and the floor.
pub fn replay(args: &ReplayArgs) -> anyhow::Result<()> {
    let kind = ModelKind::parse(&args.model)?;
    eprintln!("drive-sim: reading {}", args.log.display());
    let log = super::input::open_log(&args.log, &args.input)?;
    eprintln!(
        "drive-sim: replaying {} steps of {} on the {} model",
        log.steps().len(),
        log.meta.name,
        args.model
    );
    // `--robot` / `--terrain` (names or files, e.g. a twin) choose the model replayed.
    let models = super::input::starting_models(&log, &args.input)?;
    let score = match &args.score_like {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| drive_sim::Error::io(p, e))?;
            Some(calibration::ScoreSteps::from_json(&text, p)?)
        }
        None => None,
    };
    let staged = drive_sim::output::StagedDir::begin(&args.out, "--out")?;
    let request = calibration::ReplayRequest {
        log: &log,
        log_file: &args.log,
        models: &models,
        kind,
        score: score.as_ref(),
        provenance_options: serde_json::json!({
            "model": args.model,
            "robot": args.input.robot,
            "terrain": args.input.terrain,
            "roles": args.input.roles,
            "score_like": args.score_like,
        }),
    };
    let outcome = calibration::replay_into(&request, staged.path())?;
    staged.commit()?;
    let cmp = &outcome.comparison;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<28} {:>10} {:>10} {:>10}",
        "all steps", "IDD", "model", "floor"
    )?;
    for (name, unit, f) in error_rows() {
        writeln!(
            out,
            "{:<28} {:>10.4} {:>10.4} {:>10.4}",
            format!("{name} [{unit}]"),
            f(&cmp.idd),
            f(&cmp.model),
            f(&cmp.floor)
        )?;
    }
    if let Some(t) = &cmp.test {
        writeln!(
            out,
            "score on the calibration's {} test steps (its noise floor): {:.4}",
            score.as_ref().map_or(0, |s| s.steps.len()),
            t.score
        )?;
    }
    // The files as they are named after the staged directory was committed.
    let committed = |p: &std::path::Path| args.out.join(p.file_name().unwrap_or_default());
    eprintln!(
        "drive-sim: wrote {} and {}",
        committed(&outcome.mcap).display(),
        committed(&outcome.json).display()
    );
    Ok(())
}

type Row = (&'static str, &'static str, fn(&calibration::ErrorSummary) -> f64);

fn error_rows() -> Vec<Row> {
    vec![
        ("steady vx RMSE", "m/s", |e| e.steady_vx_m_s),
        ("steady vy RMSE", "m/s", |e| e.steady_vy_m_s),
        ("steady wz RMSE", "rad/s", |e| e.steady_wz_rad_s),
        ("steady wheel RMSE", "rad/s", |e| e.steady_wheel_rad_s),
        ("transient vx RMSE", "m/s", |e| e.transient_vx_m_s),
        ("transient wheel RMSE", "rad/s", |e| e.transient_wheel_rad_s),
        ("pose error over 2 s", "m", |e| e.pose_translation_2s_m),
        ("yaw error over 2 s", "rad", |e| e.pose_rotation_2s_rad),
    ]
}

/// Runs the whole loop and writes its report, its timings and its figures.
pub fn calibrate(args: &CalibrateArgs) -> anyhow::Result<()> {
    let clock = OnceLock::new();
    let done = calibration::calibrate_logs(&args.request(), &|event| print_progress(&clock, event))?;
    match done {
        Calibrated::Single(outcome) => print_single(args, &outcome),
        Calibrated::Joint(outcome) => print_joint(args, &outcome),
    }
}

/// Progress of a calibration on stderr: what was read as it is, each stage's findings with the
/// time since the calibration started.
fn print_progress(clock: &OnceLock<Instant>, event: &CalibrationEvent) {
    use CalibrationEvent as E;
    match event {
        E::Reading { .. } | E::Note { .. } | E::Warning { .. } | E::LogNote { .. } => {
            eprintln!("drive-sim: {event}")
        }
        E::Calibrating { .. } | E::CalibratingJointly { .. } => {
            eprintln!("drive-sim: {event}");
            clock.get_or_init(Instant::now);
        }
        _ => eprintln!(
            "drive-sim: [{:>6.1} s] {event}",
            clock.get_or_init(Instant::now).elapsed().as_secs_f64()
        ),
    }
}

/// `calibrate LOG`: the twin check, the report, the time per stage and the files written.
fn print_single(args: &CalibrateArgs, outcome: &calibration::CalibrateOutcome) -> anyhow::Result<()> {
    let (report, timings, files) = (&outcome.report, &outcome.timings, &outcome.files);
    if let Some(check) = &report.twin_check {
        match check.failure_note() {
            Some(note) => eprintln!("drive-sim: warning: the twin does not run: {note}"),
            None => eprintln!(
                "drive-sim: twin check: a {}-step DRIVE of the twin ran ({} interruptions)",
                check.steps,
                check.interruptions.unwrap_or_default()
            ),
        }
        super::input::twin_hints(&args.logs[0], &args.out, args.use_steps);
    }
    print_report(report)?;
    eprintln!("drive-sim: time per stage:");
    for line in timings.lines() {
        eprintln!("drive-sim:   {line}");
    }
    eprintln!(
        "drive-sim: wrote {} files into {}",
        files.len(),
        args.out.display()
    );
    Ok(())
}

/// `calibrate LOG1 LOG2 ...` ([`calibration::joint`]): the robot's parameters beside each
/// log's own fit, each log's scores and terrain, the files written.
fn print_joint(args: &CalibrateArgs, outcome: &calibration::JointOutcome) -> anyhow::Result<()> {
    let report = &outcome.report;
    if !outcome.failed_twins.is_empty() {
        eprintln!(
            "drive-sim: warning: the twin does not run its own DRIVE with the terrain of {} (calibration.json, notes)",
            outcome.failed_twins.join(", ")
        );
    }
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "joint calibration of {} ({} model) on {} logs; effects: {}",
        report.robot,
        report.model_kind,
        report.logs.len(),
        if report.effects.is_empty() {
            "none".to_string()
        } else {
            report.effects.join(", ")
        }
    )?;
    for p in &report.robot_params {
        let single: Vec<String> = report
            .singles
            .iter()
            .map(|r| twin_param(r, &p.name).map_or("-".to_string(), |q| with_interval(&q)))
            .collect();
        writeln!(
            out,
            "robot {} = {} (each log alone: {})",
            p.name,
            with_interval(p),
            single.join("; ")
        )?;
    }
    for l in &report.logs {
        writeln!(
            out,
            "log {} ({}): test score {:.3} joint, {:.3} its own calibration; {}",
            l.dataset,
            l.terrain_file,
            l.joint.score,
            l.single_score,
            l.terrain_params
                .iter()
                .map(|p| format!("{} = {}", p.name, with_interval(p)))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
    }
    writeln!(
        out,
        "joint fit: {} ({} evaluations)",
        report.fit.status, report.fit.evaluations
    )?;
    for n in &report.notes {
        writeln!(out, "  note: {n}")?;
    }
    eprintln!(
        "drive-sim: wrote {} files into {}",
        outcome.files.len(),
        args.out.display()
    );
    Ok(())
}

/// The fitted parameter `name` of a single-log report, as its twin holds it.
fn twin_param(r: &CalibrationReport, name: &str) -> Option<calibration::FittedParam> {
    calibration::twin::fitted_params(r)
        .into_iter()
        .find(|p| p.name == name)
}

/// `value ± se` or `value` alone, for an interval printed in a table.
fn with_interval(p: &calibration::FittedParam) -> String {
    match (p.se, p.ci95) {
        (Some(se), Some(ci)) => format!(
            "{:.4} ± {:.4} [{:.4}, {:.4}]{}",
            p.value,
            se,
            ci[0],
            ci[1],
            if p.identifiable == Some(false) {
                " not identifiable"
            } else {
                ""
            }
        ),
        (Some(se), None) if se.is_infinite() => format!("{:.4} (not constrained by the data)", p.value),
        _ => format!("{:.4}{}", p.value, if p.at_bound { " (at bound)" } else { "" }),
    }
}

/// A single-log calibration on stdout: what the model lacks, the test scores, the choices and
/// the model they led to.
fn print_report(r: &CalibrationReport) -> Result<(), std::io::Error> {
    let mut out = std::io::stdout().lock();
    print_scores(&mut out, r)?;
    print_choices(&mut out, r)?;
    print_model(&mut out, r)
}

/// What the model lacks, then every error on the test steps beside the IDD and the floor.
fn print_scores(out: &mut impl Write, r: &CalibrationReport) -> Result<(), std::io::Error> {
    let lacks = calibration::diagnosis::lacks_summary(r);
    if !lacks.is_empty() {
        writeln!(out, "what the model lacks:")?;
        for line in lacks {
            writeln!(out, "  {line}")?;
        }
    }
    writeln!(
        out,
        "{} ({} model): scores on {} test steps (fits on {} training steps, choices on {} validation steps)",
        r.dataset,
        r.model_kind,
        r.heldout_steps.len(),
        r.train_steps.len(),
        r.validation_steps.len()
    )?;
    writeln!(
        out,
        "{:<34} {:>10} {:>10} {:>10} {:>10}",
        "test", "IDD", "before", "after", "floor"
    )?;
    for row in &r.table {
        writeln!(
            out,
            "{:<34} {:>10.4} {:>10.4} {:>10.4} {:>10.4}",
            format!("{} [{}]", row.metric, row.unit),
            row.idd,
            row.sim_before,
            row.sim_after,
            row.floor
        )?;
    }
    Ok(())
}

/// The first round's ranking of the candidates, the best pair and the backward pass.
fn print_choices(out: &mut impl Write, r: &CalibrationReport) -> Result<(), std::io::Error> {
    if let Some(round) = r.rounds.first() {
        writeln!(
            out,
            "candidate effects, ranked by validation reduction (first round):"
        )?;
        writeln!(
            out,
            "  {:<30} {:>24} {:>18} {:>7}  fitted",
            "effect", "validation score before→after", "reduction ± se", "share"
        )?;
        for c in &round.ranking {
            let fitted: Vec<String> = c
                .params
                .iter()
                .map(|p| format!("{}={:.4}", p.name.trim_start_matches("effect."), p.value))
                .collect();
            writeln!(
                out,
                "  {:<30} {:>11.3} → {:>10.3} {:>9.3} ± {:<6.3} {:>6.1}%{}  {}",
                c.effect,
                c.heldout_before,
                c.heldout_after,
                c.reduction,
                c.reduction_se,
                100.0 * c.share,
                if c.significant { "*" } else { " " },
                fitted.join(", ")
            )?;
        }
        writeln!(out, "  (* = passes the selection rule)")?;
    }
    if let Some(best) = r.pairs.first() {
        writeln!(
            out,
            "best pair: {} (validation {:.3} -> {:.3} ± {:.3}){}",
            best.effect,
            best.heldout_before,
            best.heldout_after,
            best.reduction_se,
            if best.significant { ", added" } else { "" }
        )?;
    }
    for b in &r.backward {
        writeln!(
            out,
            "backward: without {} validation {:.3} -> {:.3} (± {:.3}){}",
            b.effect,
            b.score_with,
            b.score_without,
            b.se,
            if b.dropped { ", dropped" } else { ", kept" }
        )?;
    }
    Ok(())
}

/// The calibrated model's parameters and effects, the verdicts on the declared ones and the
/// test score.
fn print_model(out: &mut impl Write, r: &CalibrationReport) -> Result<(), std::io::Error> {
    // The values the final model holds (and the twin writes): the final joint fit's when it
    // refitted them beside the effects, else the base fit's.
    for p in calibration::twin::fitted_params(r)
        .iter()
        .filter(|p| !p.name.starts_with("effect."))
    {
        writeln!(out, "base parameter: {} = {}", p.name, with_interval(p))?;
    }
    if r.effects.is_empty() {
        writeln!(out, "effects added: none")?;
    } else {
        for e in &r.effects {
            let declared = r
                .declared_effects
                .iter()
                .any(|d| d.params.iter().any(|p| p.name == e.name));
            let how = if declared { "declared, refit" } else { "added" };
            writeln!(out, "effect {how}: {} = {}", e.name, with_interval(e))?;
        }
    }
    for d in &r.declared_effects {
        writeln!(out, "declared effect {}: {}", d.effect, d.verdict)?;
    }
    for s in &r.stand_ins {
        writeln!(out, "stand-in: {s} ended on a bound of its box")?;
    }
    writeln!(
        out,
        "test score: IDD {:.3}, declared {:.3}, calibrated {:.3} (reduction {:.3} ± {:.3}, bootstrap over test steps)",
        r.idd.score, r.before.score, r.after.score, r.total_reduction, r.total_reduction_se
    )?;
    writeln!(out, "converged: {}", r.status.converged)?;
    for n in &r.status.notes {
        writeln!(out, "  note: {n}")?;
    }
    Ok(())
}
