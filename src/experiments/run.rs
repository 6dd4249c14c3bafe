//! One DRIVE run in closed loop on the simulator, logged to MCAP as it goes (what `drive-sim
//! run` and the demo do): the log streams to `<out>/<name>.mcap.partial`, renamed when the run
//! completes, and a `<name>.run.json` summary is written beside it.

use super::write_json;
use crate::error::{Error, Result};
use crate::log::mcap::{McapSummary, McapWriter};
use crate::log::{DriveLog, Frame, LogMeta, Nominal, Origin};
use crate::protocol::sampler::make_sampler_for;
use crate::protocol::{run_drive, FrameSink, ProtocolConfig, RunSummary};
use crate::robot::Robot;
use crate::sim::{SimConfig, Simulator};
use crate::terrain::Terrain;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to run: robot and terrain (names or files), steps, sampler, simulator settings, and
/// where to write the log.
#[derive(Debug, Clone)]
pub struct RunRequest {
    /// Robot name or path to a robot TOML file.
    pub robot: String,
    /// Terrain name or path to a terrain TOML file.
    pub terrain: String,
    /// Steps to complete.
    pub steps: u32,
    /// Registered sampler name; seeded with `sim.seed`.
    pub sampler: String,
    /// Simulator settings: seed, physics rate, noise, effects.
    pub sim: SimConfig,
    /// The effects as the user wrote them (`NAME=VALUE`), recorded in the log's origin.
    pub injected: Vec<String>,
    /// Output directory.
    pub out: PathBuf,
    /// Log name (file stem); default `<robot>_<terrain>_s<seed>`.
    pub name: Option<String>,
}

/// What a run wrote and measured, also saved as `<name>.run.json`.
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

/// What [`record_run`] tells its caller while it runs.
#[derive(Debug, Clone, Copy)]
pub enum RunEvent<'a> {
    /// This many steps are complete.
    StepDone(u32),
    /// The run failed; what was simulated is kept in this (not complete) log.
    Failed {
        /// The partial log.
        partial: &'a Path,
    },
}

struct Sink<'a> {
    writer: McapWriter,
    /// Frames also kept in memory, for a caller that analyses the run without reading the log
    /// back.
    kept: Option<Vec<Frame>>,
    progress: &'a mut dyn FnMut(RunEvent),
}

impl FrameSink for Sink<'_> {
    fn frame(&mut self, frame: &Frame) -> Result<()> {
        if let Some(k) = &mut self.kept {
            k.push(*frame);
        }
        self.writer.write_frame(frame)
    }
    fn step_done(&mut self, completed: u32) {
        (self.progress)(RunEvent::StepDone(completed));
    }
}

/// Runs DRIVE as `req` says and writes `<out>/<name>.mcap` and `<out>/<name>.run.json`.
/// Everything is checked before the first physics step; `progress` hears of each completed
/// step, and of a failure with the partial log it leaves (never a complete-looking one).
pub fn record_run(req: &RunRequest, progress: &mut dyn FnMut(RunEvent)) -> Result<RunReport> {
    record(req, false, progress).map(|(r, _)| r)
}

/// [`record_run`], also returning the run's log as written (built from the same frames), for
/// analysing it without decoding the MCAP file again.
pub fn record_run_with_log(
    req: &RunRequest,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<(RunReport, DriveLog)> {
    let (r, log) = record(req, true, progress)?;
    Ok((r, log.expect("frames were kept")))
}

fn record(
    req: &RunRequest,
    keep_frames: bool,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<(RunReport, Option<DriveLog>)> {
    let (robot, robot_file) = Robot::resolve(&req.robot)?;
    let (terrain, terrain_file) = Terrain::resolve(&req.terrain)?;
    if req.steps == 0 {
        return Err(Error::config("--steps", "steps", "must be at least 1"));
    }
    let seed = req.sim.seed;
    let protocol = ProtocolConfig::for_run(&robot, &terrain, req.steps);
    let mut sampler = make_sampler_for(&req.sampler, seed, &protocol)
        .ok_or_else(|| super::unknown_sampler(&req.sampler))?;
    let mut sim = Simulator::new(&robot, &terrain, req.sim.clone())?;

    std::fs::create_dir_all(&req.out).map_err(|e| Error::io(&req.out, e))?;
    let name = req
        .name
        .clone()
        .unwrap_or_else(|| format!("{}_{}_s{}", robot.name, terrain.name, seed));
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
            seed,
            robot_file: robot_file.display().to_string(),
            terrain_file: terrain_file.display().to_string(),
            sampler: req.sampler.clone(),
            injected: req.injected.clone(),
        },
    };
    let mcap_path = req.out.join(format!("{name}.mcap"));
    let mut sink = Sink {
        writer: McapWriter::create(&mcap_path, &meta)?,
        kept: keep_frames.then(Vec::new),
        progress,
    };
    let t0 = Instant::now();
    let summary = match run_drive(&mut sim, &robot, sampler.as_mut(), &protocol, &mut sink) {
        Ok(s) => s,
        Err(e) => {
            let partial = sink.writer.partial_path().to_path_buf();
            (sink.progress)(RunEvent::Failed { partial: &partial });
            return Err(e);
        }
    };
    let McapSummary {
        path,
        bytes,
        messages_per_topic,
        ..
    } = sink.writer.finish()?;
    let log = sink.kept.map(|frames| DriveLog::from_frames(meta, &frames));
    let wall_s = t0.elapsed().as_secs_f64();
    let report = RunReport {
        mcap: path,
        mcap_bytes: bytes,
        messages_per_topic,
        robot_file: robot_file.display().to_string(),
        terrain_file: terrain_file.display().to_string(),
        sim: req.sim.clone(),
        protocol,
        sampler: req.sampler.clone(),
        real_time_factor: summary.total_time_s / wall_s.max(1e-9),
        summary,
        wall_s,
    };
    write_json(&req.out.join(format!("{name}.run.json")), &report)?;
    Ok((report, log))
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
