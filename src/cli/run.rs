//! `drive-sim run`: DRIVE in closed loop on the simulated robot, logged to MCAP.

use drive_sim::effects::Effects;
pub use drive_sim::harness::run::{describe, RunReport};
use drive_sim::harness::run::{record_run, RunEvent, RunRequest};
use drive_sim::harness::Result;
use drive_sim::sim::{SensorNoise, SimConfig};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// Options of `drive-sim run`.
#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    /// Robot name (see `drive-sim robots`) or path to a robot TOML file.
    #[arg(long, default_value = "warthog")]
    pub robot: String,
    /// Terrain name (see `drive-sim terrains`) or path to a terrain TOML file.
    #[arg(long, default_value = "asphalt")]
    pub terrain: String,
    /// Steps to complete (paper: at least 150).
    #[arg(long, default_value_t = 150)]
    pub steps: u32,
    /// Seed of every random draw (commands, terrain roughness, sensor noise).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Sampling strategy (see `drive-sim samplers --list`).
    #[arg(long, default_value = "uniform-wheel")]
    pub sampler: String,
    /// Draw each step's command uniformly in U inside the quadrant (forward or backward,
    /// turning left or right) of this log's command of that step, in place of `--sampler`: a
    /// run to compare with that log, drawn as `tune`, `twin` and `judge` draw a twin's runs
    /// against it (a run's medians are its mix of quadrants).
    #[arg(long, value_name = "LOG", conflicts_with = "sampler")]
    pub draw_like: Option<PathBuf>,
    /// Sensor noise: `typical` field sensors or `off`.
    #[arg(long, default_value = "typical", value_parser = ["typical", "off"])]
    pub noise: String,
    /// Physics rate, Hz.
    #[arg(long, default_value_t = 100.0)]
    pub physics_hz: f64,
    /// Inject an effect the log's metadata does not declare, `NAME=VALUE` (repeatable), e.g.
    /// `--inject motor_gain_left=0.85`. Names: the parameters of the effect registry (`drive_sim::effects::REGISTRY`; `drive-sim effects` lists them).
    #[arg(long = "inject", value_name = "EFFECT=VALUE")]
    pub inject: Vec<String>,
    /// Output directory.
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Log name (file stem, no path separator); default `<robot>_<terrain>_s<seed>`.
    #[arg(long)]
    pub name: Option<String>,
    /// Overwrite a log of the same name made with other options (refused otherwise; a rerun
    /// with the same options always replaces it).
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// The deployment's safe area, `LENGTHxWIDTH` in metres (e.g. `50x25`), instead of the
    /// robot file's (the paper's minimum, 45 x 20 m for the Warthog): sites differ, and the
    /// interruptions and time efficiency with them.
    #[arg(long, value_name = "LxW", value_parser = parse_safe_area)]
    pub safe_area: Option<drive_sim::robot::SafeArea>,
}

/// `50x25` as a safe area of 50 m by 25 m.
fn parse_safe_area(s: &str) -> std::result::Result<drive_sim::robot::SafeArea, String> {
    let (l, w) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected LENGTHxWIDTH in metres (e.g. 50x25), got `{s}`"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("`{t}` is not a number of metres (in `{s}`)"))
    };
    Ok(drive_sim::robot::SafeArea {
        length_m: num(l)?,
        width_m: num(w)?,
    })
}

/// Runs DRIVE as the options say and writes `<out>/<name>.mcap` and `<out>/<name>.run.json`,
/// with a progress bar on stderr unless `--quiet`.
pub fn run(args: &RunArgs) -> Result<RunReport> {
    let mut effects = Effects::default();
    for a in &args.inject {
        effects.apply_assignment(a)?;
    }
    let sim_cfg = SimConfig {
        seed: args.seed,
        physics_hz: args.physics_hz,
        noise: noise_named(&args.noise),
        effects,
    };
    let req = RunRequest {
        robot: args.robot.clone(),
        terrain: args.terrain.clone(),
        steps: args.steps,
        sampler: args.sampler.clone(),
        sim: sim_cfg,
        injected: args.inject.clone(),
        out: args.out.clone(),
        name: args.name.clone(),
        force: args.force,
        safe_area: args.safe_area.clone(),
        cancel: None,
        draw_like: args.draw_like.clone(),
    };
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(args.steps as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} steps, {elapsed} elapsed, eta {eta}")
            .expect("the progress template is valid")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("{} on {}", args.robot, args.terrain));
    let report = record_run(&req, &mut |event| match event {
        // Said once the inputs are loaded and valid: bad input is reported without it.
        RunEvent::Started { robot, terrain, log } => bar.suspend(|| {
            eprintln!(
                "drive-sim: running DRIVE: {robot} on {terrain}, {} steps, seed {}, sampler {}, log {}",
                args.steps,
                args.seed,
                req.sampler_name(),
                log.display()
            )
        }),
        RunEvent::StepDone(n) => bar.set_position(n as u64),
        RunEvent::Interrupted { log } => {
            bar.abandon();
            eprintln!(
                "drive-sim: interrupted; the steps simulated so far are closed in {} (a valid, incomplete log)",
                log.display()
            );
        }
        RunEvent::Failed { partial } => {
            bar.abandon();
            eprintln!(
                "drive-sim: run failed; what was simulated is kept in {} (not a complete log)",
                partial.display()
            );
        }
    })?;
    bar.finish_and_clear();
    Ok(report)
}

/// The sensor noise named on the command line: `off` or `typical`.
pub fn noise_named(name: &str) -> SensorNoise {
    if name == "off" {
        SensorNoise::default()
    } else {
        SensorNoise::typical()
    }
}
