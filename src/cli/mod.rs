//! The `drive-sim` command line: what each subcommand does, and how it reports progress.

pub mod analyze;
pub mod calibrate;
pub mod compare;
pub mod demo;
pub mod input;
pub mod judge;
pub mod run;
pub mod samplers;
pub mod sweep;
pub mod sweep_args;
pub mod tune;
pub mod twin;

use clap::{Parser, Subcommand};
use drive_sim::robot::{Robot, BUILTIN_ROBOTS};
use drive_sim::terrain::{Terrain, BUILTIN_TERRAINS};
use std::io::Write;

/// Simulation-backed test harness for the DRIVE protocol.
#[derive(Debug, Parser)]
#[command(
    name = "drive-sim",
    version,
    about,
    long_about = None,
    after_help = "Exit codes: 0 success; 1 the run failed (a diverged simulation, a failed write); \
                  2 bad input (an option, file or name, reported before any long work); \
                  130 interrupted (Ctrl-C / SIGTERM; `run` and `sweep` close what they wrote)."
)]
pub struct Cli {
    /// What to do; without one, runs the demonstration (`drive-sim demo`).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The demonstration: DRIVE of the Warthog on asphalt, gravel and ice and of the Husky on
    /// mud, analysed together into one report (what `drive-sim` with no arguments runs).
    Demo(demo::DemoArgs),
    /// Runs DRIVE in closed loop on a simulated robot and terrain; writes an MCAP log.
    Run(run::RunArgs),
    /// Replays the commands of a measured (or simulated) log on the declared model and reports
    /// the error beside the ideal differential drive and the noise floor.
    Replay(calibrate::ReplayArgs),
    /// Closes the loop: baseline error, terrain calibration, residual, effects selected with
    /// evidence, error after, all on held-out steps; JSON + HTML report and a fitted terrain file.
    Calibrate(calibrate::CalibrateArgs),
    /// Compares a real log with simulated ones in the paper's terms (median ρ and slips, T/U
    /// areas, transfer-function difference maps) with bootstrap intervals and Holm-corrected
    /// verdicts; writes comparison.json, figures and report.html.
    Compare(compare::CompareArgs),
    /// Tunes a twin's parameters in closed loop: its own DRIVE runs scored by compare's
    /// statistics against half the real run's steps, checked on fresh seeds, judged on the
    /// other half; writes tune.json, twin/robot.toml, twin/terrain.toml and heldout/.
    Tune(tune::TuneArgs),
    /// Judges a twin: its runs compared with the real run and with runs of its own, and a
    /// Monte Carlo test of whether compare can tell the real run from the twin's; writes
    /// judge.json, judge.md and judge_rates.svg|png.
    Judge(judge::JudgeArgs),
    /// A twin of the robot from its runs, with no option needed: calibrated by replay, the
    /// knobs that move it towards the robot measured in closed loop, tuned, checked on fresh
    /// seeds and judged on steps its choice never saw; writes twin/robot.toml, its terrain
    /// file(s), the held-out twin's held_out/, twin.json and twin.md.
    Twin(twin::TwinArgs),
    /// Lists the robots (built-in and ./robots/*.toml).
    Robots,
    /// Lists the terrains (built-in and ./terrains/*.toml).
    Terrains,
    /// Shows what a rosbag2 bag of the DRIVE node holds: topics, types, counts, rates, time
    /// span, the roles it would use and what is missing, and the steps it would give.
    Inspect(input::InspectArgs),
    /// Lists the model effects (`--inject`, calibration candidates): stage, parameters with
    /// units, valid range, neutral value and calibration search box.
    Effects,
    /// Analyses DRIVE logs (simulated .mcap or measured .csv): slips, transfer functions, ρ,
    /// risk; writes summary.json, figures and report.html. Several logs are compared.
    Analyze(analyze::AnalyzeArgs),
    /// Compares the sampling strategies on the same budget with the simulator: transfer-function
    /// error against the open-loop truth, coverage, interruptions, energy.
    Samplers(samplers::SamplersArgs),
    /// Runs a sweep matrix (robots × terrains × samplers × seeds), sharded and resumable.
    Sweep(sweep_args::SweepArgs),
    /// Merges sweep output directories (e.g. one per shard) into merged.json and merged.csv.
    SweepMerge(sweep_args::MergeArgs),
}

/// An error and its causes, `outer: inner`, each said once: a cause whose text the message
/// before it already ends with (a file error that names its I/O error) is not repeated.
fn describe_error(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// The parser of an option naming which steps of a log to use (`all`, `odd`, `even`).
pub fn use_steps_parser() -> impl clap::builder::TypedValueParser<Value = drive_sim::log::UseSteps> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    use drive_sim::log::UseSteps;
    PossibleValuesParser::new(UseSteps::ALL.map(|u| PossibleValue::new(u.as_str()).help(u.doc()))).map(|s| {
        UseSteps::ALL
            .into_iter()
            .find(|u| u.as_str() == s)
            .unwrap_or_default()
    })
}

/// The parser of `--tf-smoother` (`kernel`, `local-linear`).
pub fn tf_smoother_parser() -> impl clap::builder::TypedValueParser<Value = drive_sim::compare::TfSmoother> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    use drive_sim::compare::TfSmoother;
    PossibleValuesParser::new(TfSmoother::ALL.map(|t| PossibleValue::new(t.as_str()).help(t.doc()))).map(
        |s| {
            TfSmoother::ALL
                .into_iter()
                .find(|t| t.as_str() == s)
                .unwrap_or_default()
        },
    )
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(()) => 0,
        // A closed pipe (`drive-sim robots | head`) is the reader's choice, not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            0
        }
        Err(e)
            if e.chain().any(|c| {
                stage_error(c).is_some_and(|s| matches!(s.model, Some(drive_sim::Error::Interrupted { .. })))
            }) =>
        {
            eprintln!("drive-sim: {}", describe_error(&e));
            drive_sim::interrupt::EXIT_CODE
        }
        Err(e) => {
            eprintln!("drive-sim: error: {}", describe_error(&e));
            // Exit code 2 for bad input (as clap does for bad arguments), 1 for a failed run.
            if e.chain().any(|c| stage_error(c).is_some_and(|s| s.bad_input)) {
                2
            } else {
                1
            }
        }
    }
}

/// What a link of an error chain says of the failure when it is one of the library's errors:
/// whether the user's input is at fault, and the shared error it carries (an interrupt, a bad
/// file). Each stage's error wraps the shared one transparently, so it is asked, not the chain.
struct StageError<'a> {
    bad_input: bool,
    model: Option<&'a drive_sim::Error>,
}

fn stage_error<'a>(c: &'a (dyn std::error::Error + 'static)) -> Option<StageError<'a>> {
    macro_rules! try_stage {
        ($($t:ty),*) => {$(
            if let Some(e) = c.downcast_ref::<$t>() {
                return Some(StageError { bad_input: e.is_bad_input(), model: e.model() });
            }
        )*};
    }
    if let Some(e) = c.downcast_ref::<drive_sim::Error>() {
        return Some(StageError {
            bad_input: e.is_bad_input(),
            model: Some(e),
        });
    }
    try_stage!(
        drive_sim::analysis::Error,
        drive_sim::report::Error,
        drive_sim::harness::Error,
        drive_sim::calibration::Error,
        drive_sim::compare::Error,
        drive_sim::twin::Error
    );
    None
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => {
            drive_sim::interrupt::install();
            demo::demo(&demo::DemoArgs::default())
        }
        Some(Command::Demo(a)) => {
            drive_sim::interrupt::install();
            demo::demo(&a)
        }
        Some(Command::Run(a)) => {
            drive_sim::interrupt::install();
            let r = run::run(&a)?;
            println!("{}", run::describe(&r));
            Ok(())
        }
        Some(Command::Replay(a)) => calibrate::replay(&a),
        Some(Command::Calibrate(a)) => calibrate::calibrate(&a),
        Some(Command::Compare(a)) => compare::compare(&a),
        // No signal handler: Ctrl-C ends the process, and the staged output directory was
        // never committed, so nothing already written is touched.
        Some(Command::Tune(a)) => tune::tune(&a),
        Some(Command::Judge(a)) => judge::judge(&a),
        // As tune and judge: Ctrl-C ends the process before the staged directory is committed.
        Some(Command::Twin(a)) => twin::twin(&a),
        Some(Command::Robots) => list_robots(),
        Some(Command::Terrains) => list_terrains(),
        Some(Command::Effects) => list_effects(),
        Some(Command::Analyze(a)) => analyze::analyze(&a),
        Some(Command::Inspect(a)) => input::inspect(&a),
        Some(Command::Samplers(a)) => samplers::samplers(&a),
        Some(Command::Sweep(a)) => {
            drive_sim::interrupt::install();
            sweep::sweep(&a)
        }
        Some(Command::SweepMerge(a)) => sweep::sweep_merge(&a),
    }
}

fn list_effects() -> anyhow::Result<()> {
    use drive_sim::effects::{ParamKind, SearchBox, REGISTRY};
    let mut out = std::io::stdout().lock();
    for e in REGISTRY.iter() {
        writeln!(out, "{} ({}): {}", e.name(), e.stage().as_str(), e.doc())?;
        if !e.kinematic() {
            writeln!(out, "    needs the simulator (the kinematic model cannot run it)")?;
        }
        if !e.generic() && !e.default_candidate() {
            writeln!(
                out,
                "    calibration tries it only when `--candidates` names it (not yet in the default catalogue)"
            )?;
        }
        if e.generic() {
            // One coefficient per library feature: listed by pattern, not one by one.
            let first = e.params().first().map_or("", |p| p.key);
            let stem = first.split("__").next().unwrap_or(first);
            writeln!(
                out,
                "    --inject {stem}__FEATURE=VALUE  coefficient of a feature ({} features: {}), neutral 0",
                e.params().len(),
                e.params()
                    .iter()
                    .map(|p| p.key.split("__").nth(1).unwrap_or(""))
                    .collect::<Vec<_>>()
                    .join(", ")
            )?;
            continue;
        }
        for p in e.params() {
            let range = match p.kind {
                ParamKind::Flag => "0 or 1".to_string(),
                ParamKind::Limit => format!("(0, {}], 0 or inf = off", p.max),
                ParamKind::Continuous => format!("[{}, {}]", p.min, p.max),
            };
            let search = match p.search {
                SearchBox::Fixed { lower, upper } => format!("[{lower}, {upper}]"),
                SearchBox::Reach { lower, upper, .. } => {
                    format!("[{lower}, {upper}] x the largest command")
                }
            };
            writeln!(
                out,
                "    --inject {}=VALUE  [{}]  valid {range}, neutral {}, calibration searches {search}",
                p.key, p.unit, p.neutral
            )?;
        }
    }
    Ok(())
}

fn list_robots() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>7} {:>7} {:>9} {:>10}  source",
        "robot", "mass_kg", "r_m", "b_m", "vmax_m_s", "wmax_rad_s"
    )?;
    for e in drive_sim::config::catalog("robot", BUILTIN_ROBOTS) {
        match drive_sim::config::parse_toml::<Robot>(&e.text, &e.origin) {
            Ok(r) => writeln!(
                out,
                "{:<10} {:>8.1} {:>7.3} {:>7.3} {:>9.2} {:>10.2}  {}",
                e.name,
                r.body.mass_kg,
                r.wheels.radius_m,
                r.wheels.baseline_m,
                r.limits.max_lin_m_s,
                r.limits.max_ang_rad_s,
                e.origin.display()
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}

fn list_terrains() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>8} {:>8}  description",
        "terrain", "mu_peak", "mu_slide", "c_roll"
    )?;
    for e in drive_sim::config::catalog("terrain", BUILTIN_TERRAINS) {
        match drive_sim::config::parse_toml::<Terrain>(&e.text, &e.origin) {
            Ok(t) => writeln!(
                out,
                "{:<10} {:>8.2} {:>8.2} {:>8.3}  {}",
                e.name,
                t.friction.peak_longitudinal,
                t.friction.sliding_longitudinal,
                t.resistance.rolling_coefficient,
                t.description
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}
