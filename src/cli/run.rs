//! `drive-sim run`: DRIVE in closed loop on the simulated robot, logged to MCAP.

use crate::effects::Effects;
use crate::error::{Error, Result};
use crate::log::mcap::{McapSummary, McapWriter};
use crate::log::{Frame, LogMeta, Nominal, Origin};
use crate::protocol::sampler::make_sampler_for;
use crate::protocol::{run_drive, FrameSink, ProtocolConfig, RunSummary};
use crate::robot::Robot;
use crate::sim::{SensorNoise, SimConfig, Simulator};
use crate::terrain::Terrain;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

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
    /// Log name (file stem); default `<robot>_<terrain>_s<seed>`.
    #[arg(long)]
    pub name: Option<String>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// What `run` wrote and measured, also saved as `<name>.run.json`.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// The log.
    pub mcap: PathBuf,
    /// Log size, bytes.
    pub mcap_bytes: u64,
    /// Messages per topic.
    pub messages_per_topic: std::collections::BTreeMap<String, u64>,
    /// Robot file used.
    pub robot_file: String,
    /// Terrain file used.
    pub terrain_file: String,
    /// Simulator settings (seed, physics rate, noise, injected effects).
    pub sim: SimConfig,
    /// Protocol settings.
    pub protocol: ProtocolConfig,
    /// Sampler.
    pub sampler: String,
    /// Steps, interruptions, time efficiency.
    pub summary: RunSummary,
    /// Wall-clock time of the simulation and logging, s.
    pub wall_s: f64,
    /// Simulated seconds per wall-clock second.
    pub real_time_factor: f64,
}

struct Sink {
    writer: McapWriter,
    bar: ProgressBar,
}

impl FrameSink for Sink {
    fn frame(&mut self, frame: &Frame) -> Result<()> {
        self.writer.write_frame(frame)
    }
    fn step_done(&mut self, completed: u32) {
        self.bar.set_position(completed as u64);
    }
}

/// Runs DRIVE as the options say and writes `<out>/<name>.mcap` and `<out>/<name>.run.json`.
pub fn run(args: &RunArgs) -> Result<RunReport> {
    let (robot, robot_file) = Robot::resolve(&args.robot)?;
    let (terrain, terrain_file) = Terrain::resolve(&args.terrain)?;
    let mut effects = Effects::default();
    for a in &args.inject {
        effects.apply_assignment(a)?;
    }
    if args.steps == 0 {
        return Err(Error::config("--steps", "steps", "must be at least 1"));
    }
    let protocol = ProtocolConfig::for_run(&robot, &terrain, args.steps);
    let mut sampler =
        make_sampler_for(&args.sampler, args.seed, &protocol).ok_or_else(|| Error::Unknown {
            kind: "sampler",
            name: args.sampler.clone(),
            available: crate::protocol::sampler::SAMPLERS.join(", "),
        })?;
    let noise = if args.noise == "off" {
        SensorNoise::default()
    } else {
        SensorNoise::typical()
    };
    let sim_cfg = SimConfig {
        seed: args.seed,
        physics_hz: args.physics_hz,
        noise,
        effects,
    };
    let mut sim = Simulator::new(&robot, &terrain, sim_cfg.clone())?;

    std::fs::create_dir_all(&args.out).map_err(|e| Error::io(&args.out, e))?;
    let name = args
        .name
        .clone()
        .unwrap_or_else(|| format!("{}_{}_s{}", robot.name, terrain.name, args.seed));
    let meta = LogMeta {
        name: name.clone(),
        robot: robot.name.clone(),
        terrain: terrain.name.clone(),
        rate_hz: protocol.rate_hz,
        window_s: protocol.window_s,
        windows_per_step: protocol.windows_per_step,
        samples_per_window: protocol.samples_per_window(),
        nominal: Nominal::from_robot(&robot),
        origin: Origin::Simulated {
            seed: args.seed,
            robot_file: robot_file.display().to_string(),
            terrain_file: terrain_file.display().to_string(),
            sampler: args.sampler.clone(),
            injected: args.inject.clone(),
        },
    };
    let mcap_path = args.out.join(format!("{name}.mcap"));
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(args.steps as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} steps, {elapsed} elapsed, eta {eta}")
            .map_err(|e| Error::Analysis(e.to_string()))?
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("{} on {}", robot.name, terrain.name));
    let mut sink = Sink {
        writer: McapWriter::create(&mcap_path, &meta)?,
        bar,
    };
    let t0 = Instant::now();
    let summary = match run_drive(&mut sim, &robot, sampler.as_mut(), &protocol, &mut sink) {
        Ok(s) => s,
        Err(e) => {
            sink.bar.abandon();
            eprintln!(
                "drive-sim: run failed; what was simulated is kept in {} (not a complete log)",
                sink.writer.partial_path().display()
            );
            return Err(e);
        }
    };
    let Sink { writer, bar } = sink;
    let McapSummary {
        path,
        bytes,
        messages_per_topic,
        ..
    } = writer.finish()?;
    let wall_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let report = RunReport {
        mcap: path,
        mcap_bytes: bytes,
        messages_per_topic,
        robot_file: robot_file.display().to_string(),
        terrain_file: terrain_file.display().to_string(),
        sim: sim_cfg,
        protocol,
        sampler: args.sampler.clone(),
        real_time_factor: summary.total_time_s / wall_s.max(1e-9),
        summary,
        wall_s,
    };
    write_json(&args.out.join(format!("{name}.run.json")), &report)?;
    Ok(report)
}

/// Writes pretty JSON, naming the file on failure.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::Analysis(format!("{}: {e}", path.display())))?;
    std::fs::write(path, text).map_err(|e| Error::io(path, e))
}

/// One line a user reads after a run.
pub fn describe(r: &RunReport) -> String {
    let s = &r.summary;
    format!(
        "{} steps, {} interruptions ({} commands abandoned), time efficiency {:.1} %; simulated {:.0} s in {:.2} s wall ({:.0}x real time); log {} ({:.1} MB)",
        s.steps_completed,
        s.interruptions,
        s.abandoned_commands,
        100.0 * s.time_efficiency,
        s.total_time_s,
        r.wall_s,
        r.real_time_factor,
        r.mcap.display(),
        r.mcap_bytes as f64 / 1e6
    )
}
