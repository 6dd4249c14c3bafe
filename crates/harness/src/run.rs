//! One DRIVE run in closed loop on the simulator, logged to MCAP as it goes (what `drive-sim
//! run` and the demo do): the log streams to `<out>/<name>.mcap.partial`, renamed when the run
//! completes, and a `<name>.run.json` summary is written beside it.

use crate::error::{Error, Result};
use drive_sim_log::mcap::{McapSummary, McapWriter};
use drive_sim_log::{DriveLog, Frame, LogMeta, Nominal, Origin};
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::output::write_json_atomic as write_json;
use drive_sim_model::provenance::{InputFile, Provenance};
use drive_sim_model::robot::{Robot, BUILTIN_ROBOTS};
use drive_sim_model::terrain::{Terrain, BUILTIN_TERRAINS};
use drive_sim_protocol::sampler::{make_sampler_for, Sampler};
use drive_sim_protocol::samplers::matched::Matched;
use drive_sim_protocol::{run_drive_cancellable, CancelToken, FrameSink, ProtocolConfig, RunSummary};
use drive_sim_sim::{SimConfig, Simulator};
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
    /// Overwrite a log of the same name made with other options (otherwise refused).
    pub force: bool,
    /// The safe area of this deployment, replacing the robot file's (sites differ: the paper's
    /// Warthog sites were 740 to 1900 m² around the 900 m² minimum).
    pub safe_area: Option<drive_sim_model::robot::SafeArea>,
    /// Stops this run as SIGINT would the process (polled beside the process-wide flag).
    pub cancel: Option<CancelToken>,
    /// A log (any `drive-sim` input) whose commands' quadrants this run draws in, step by
    /// step, in place of `sampler` (the run's sampler is then `matched-quadrants`,
    /// [`drive_sim_protocol::samplers::matched`]): a run made to be compared with that log,
    /// drawn as the twin's runs that `tune`, `twin` and `judge` compare with it are, so that
    /// its medians are not moved by the two draws' luck.
    pub draw_like: Option<PathBuf>,
}

/// The sampler name a run drawn in another log's quadrants records.
pub const MATCHED_SAMPLER: &str = drive_sim_protocol::samplers::matched::NAME;

/// Most steps a run may ask for: 100 000 steps are about 7 simulated days of DRIVE.
pub const MAX_STEPS: u32 = 100_000;
/// Physics rates accepted, Hz: below, the 20 Hz logging is not resolved; above, a run takes
/// hours for no change in the result (see `SimConfig::physics_hz`).
pub const PHYSICS_HZ_RANGE: (f64, f64) = (20.0, 5_000.0);

impl RunRequest {
    /// The sampler the run records: `sampler`, or [`MATCHED_SAMPLER`] when it draws like a log.
    pub fn sampler_name(&self) -> &str {
        match self.draw_like {
            Some(_) => MATCHED_SAMPLER,
            None => &self.sampler,
        }
    }

    /// The validation pass of a run's numbers and names, before anything is loaded or
    /// simulated: steps, physics rate, log name.
    pub fn validate(&self) -> Result<()> {
        let cl = "<command line>";
        if self.steps == 0 || self.steps > MAX_STEPS {
            return Err(Error::config(
                cl,
                "--steps",
                format!("must be in 1..={MAX_STEPS} steps, got {}", self.steps),
            ));
        }
        let (lo, hi) = PHYSICS_HZ_RANGE;
        let hz = self.sim.physics_hz;
        if !(hz.is_finite() && (lo..=hi).contains(&hz)) {
            return Err(Error::config(
                cl,
                "--physics-hz",
                format!("must be in [{lo}, {hi}] Hz, got {hz}"),
            ));
        }
        if let Some(n) = &self.name {
            drive_sim_model::output::check_file_name("--name", n)?;
        }
        Ok(())
    }
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
    /// Version, schema version, file hashes and the options that made the log.
    pub provenance: Provenance,
}

/// What [`record_run`] tells its caller while it runs.
#[derive(Debug, Clone, Copy)]
pub enum RunEvent<'a> {
    /// Every input is valid and loaded and the log is open: the simulation starts.
    Started {
        /// The robot's name.
        robot: &'a str,
        /// The terrain's name.
        terrain: &'a str,
        /// The log being written.
        log: &'a Path,
    },
    /// This many steps are complete.
    StepDone(u32),
    /// The run failed; what was simulated is kept in this (not complete) log.
    Failed {
        /// The partial log.
        partial: &'a Path,
    },
    /// The run was interrupted (SIGINT / SIGTERM); what was simulated is closed, readable, in
    /// this log.
    Interrupted {
        /// The `NAME.interrupted.mcap` log.
        log: &'a Path,
    },
}

struct Sink<'a, 'b> {
    /// The log; `None` for a run kept in memory only.
    writer: Option<McapWriter>,
    /// Frames also kept in memory, for a caller that analyses the run without reading the log
    /// back.
    kept: Option<Vec<Frame>>,
    /// The caller's own sink, after the log.
    also: Option<&'b mut dyn FrameSink>,
    progress: &'a mut dyn FnMut(RunEvent),
}

impl FrameSink for Sink<'_, '_> {
    fn frame(&mut self, frame: &Frame) -> drive_sim_model::Result<()> {
        if let Some(k) = &mut self.kept {
            k.push(*frame);
        }
        if let Some(w) = &mut self.writer {
            w.write_frame(frame)?;
        }
        match self.also.as_deref_mut() {
            Some(a) => a.frame(frame),
            None => Ok(()),
        }
    }
    fn step_done(&mut self, completed: u32) {
        if let Some(a) = self.also.as_deref_mut() {
            a.step_done(completed);
        }
        (self.progress)(RunEvent::StepDone(completed));
    }
}

/// What a library caller adds to a [`RunRequest`] that the command line does not set.
#[derive(Default)]
pub struct RunHooks<'a> {
    /// Draws the commands instead of the registered sampler `req.sampler` names; that name
    /// then only labels the run (the log's origin, the options in its provenance).
    pub sampler: Option<&'a mut dyn Sampler>,
    /// Hears every frame and every completed step too, as they come (after the log).
    pub also: Option<&'a mut dyn FrameSink>,
    /// Writes nothing (no log, no `run.json`; `req.out`, `req.name` and `req.force` are not
    /// used): the report names no log (an empty path, no bytes, no messages) and the run's log
    /// is returned in memory only.
    pub in_memory: bool,
}

/// Runs DRIVE as `req` says and writes `<out>/<name>.mcap` and `<out>/<name>.run.json`.
/// Everything is checked before the first physics step; `progress` hears of each completed
/// step, and of a failure with the partial log it leaves (never a complete-looking one).
pub fn record_run(req: &RunRequest, progress: &mut dyn FnMut(RunEvent)) -> Result<RunReport> {
    record(req, RunHooks::default(), false, progress).map(|(r, _)| r)
}

/// [`record_run`], also returning the run's log as written (built from the same frames), for
/// analysing it without decoding the MCAP file again.
pub fn record_run_with_log(
    req: &RunRequest,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<(RunReport, DriveLog)> {
    let (r, log) = record(req, RunHooks::default(), true, progress)?;
    Ok((r, log.expect("frames were kept")))
}

/// [`record_run_with_log`] with a library caller's [`RunHooks`]: its own sampler, its own
/// frame sink, or nothing written.
pub fn record_run_with(
    req: &RunRequest,
    hooks: RunHooks<'_>,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<(RunReport, DriveLog)> {
    let (r, log) = record(req, hooks, true, progress)?;
    Ok((r, log.expect("frames were kept")))
}

/// A run's inputs loaded and checked, and its outputs named, before the first physics step.
struct Prepared {
    robot: Robot,
    robot_file: PathBuf,
    terrain: Terrain,
    terrain_file: PathBuf,
    protocol: ProtocolConfig,
    /// The registered sampler, unless the caller brought its own.
    registered: Option<Box<dyn Sampler>>,
    sim: Simulator,
    provenance: Provenance,
    meta: LogMeta,
    mcap_path: PathBuf,
    json_path: PathBuf,
}

/// The validation pass and the loading of a run: nothing is loaded, created or simulated on
/// bad input; with `write`, the output folder exists and a log of the same name made with
/// other options is refused.
fn prepare(req: &RunRequest, own_sampler: bool, write: bool) -> Result<Prepared> {
    req.validate()?;
    let (mut robot, robot_file) = Robot::resolve(&req.robot)?;
    if let Some(a) = &req.safe_area {
        // The robot file's own rules judge the deployment's area (its range, in metres).
        robot.safe_area = a.clone();
        drive_sim_model::config::Validate::validate(&robot)
            .map_err(|(field, why)| Error::config("--safe-area", field, why))?;
    }
    let (terrain, terrain_file) = Terrain::resolve(&req.terrain)?;
    let seed = req.sim.seed;
    let protocol = ProtocolConfig::for_run(&robot, &terrain, req.steps);
    let registered: Option<Box<dyn Sampler>> = match (own_sampler, &req.draw_like) {
        (true, _) => None,
        (false, Some(like)) => Some(Box::new(Matched::new(&commands_of(like)?, seed)?)),
        (false, None) => Some(
            make_sampler_for(&req.sampler, seed, &protocol)
                .ok_or_else(|| super::unknown_sampler(&req.sampler))?,
        ),
    };
    let sim = Simulator::new(&robot, &terrain, req.sim.clone())?;

    let name = req
        .name
        .clone()
        .unwrap_or_else(|| format!("{}_{}_s{}", robot.name, terrain.name, seed));
    drive_sim_model::output::check_file_name("--name", &name)?;
    if write {
        drive_sim_model::output::ensure_dir(&req.out, "--out")?;
    }
    let mut inputs = vec![
        InputFile::of_model("robot", &robot_file, BUILTIN_ROBOTS),
        InputFile::of_model("terrain", &terrain_file, BUILTIN_TERRAINS),
    ];
    if let Some(like) = &req.draw_like {
        inputs.push(InputFile::of_file("draw_like", like));
    }
    let provenance = Provenance::new(inputs, run_options(req, &robot_file, &terrain_file));
    let mcap_path = req.out.join(format!("{name}.mcap"));
    let json_path = req.out.join(format!("{name}.run.json"));
    if write && !req.force {
        refuse_other_options(&mcap_path, &json_path, &provenance.options)?;
    }
    let meta = LogMeta {
        name,
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
            sampler: req.sampler_name().to_string(),
            injected: req.injected.clone(),
        },
    };
    Ok(Prepared {
        robot,
        robot_file,
        terrain,
        terrain_file,
        protocol,
        registered,
        sim,
        provenance,
        meta,
        mcap_path,
        json_path,
    })
}

fn record(
    req: &RunRequest,
    hooks: RunHooks<'_>,
    keep_frames: bool,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<(RunReport, Option<DriveLog>)> {
    let write = !hooks.in_memory;
    let mut p = prepare(req, hooks.sampler.is_some(), write)?;
    let writer = match write {
        true => Some(McapWriter::create_with_provenance(
            &p.mcap_path,
            &p.meta,
            Some(&Provenance {
                command: Vec::new(),
                ..p.provenance.clone()
            }),
        )?),
        false => None,
    };
    let mut sink = Sink {
        writer,
        kept: keep_frames.then(Vec::new),
        also: hooks.also,
        progress,
    };
    let log_path = if write {
        p.mcap_path.clone()
    } else {
        PathBuf::new()
    };
    (sink.progress)(RunEvent::Started {
        robot: &p.robot.name,
        terrain: &p.terrain.name,
        log: &log_path,
    });
    let sampler: &mut dyn Sampler = match (hooks.sampler, p.registered.as_deref_mut()) {
        (Some(s), _) => s,
        (None, Some(s)) => s,
        (None, None) => unreachable!("prepare builds the registered sampler when the caller brings none"),
    };
    let t0 = Instant::now();
    let run = run_drive_cancellable(
        &mut p.sim,
        &p.robot,
        sampler,
        &p.protocol,
        &mut sink,
        req.cancel.as_ref(),
    );
    let (summary, writer) = match (run, sink.writer.take()) {
        (Ok(s), writer) => (s, writer),
        (Err(e @ drive_sim_model::Error::Interrupted { .. }), Some(writer)) => {
            let closed = writer.finish_interrupted()?;
            (sink.progress)(RunEvent::Interrupted { log: &closed.path });
            return Err(e.into());
        }
        (Err(e), Some(writer)) => {
            let partial = writer.partial_path().to_path_buf();
            (sink.progress)(RunEvent::Failed { partial: &partial });
            return Err(e.into());
        }
        (Err(e), None) => return Err(e.into()),
    };
    let McapSummary {
        path,
        bytes,
        messages_per_topic,
        ..
    } = match writer {
        Some(w) => w.finish()?,
        None => McapSummary {
            path: PathBuf::new(),
            frames: 0,
            messages_per_topic: Default::default(),
            bytes: 0,
        },
    };
    let log = sink.kept.map(|frames| DriveLog::from_frames(p.meta, &frames));
    let wall_s = t0.elapsed().as_secs_f64();
    let report = RunReport {
        mcap: path,
        mcap_bytes: bytes,
        messages_per_topic,
        robot_file: p.robot_file.display().to_string(),
        terrain_file: p.terrain_file.display().to_string(),
        sim: req.sim.clone(),
        protocol: p.protocol,
        sampler: req.sampler_name().to_string(),
        real_time_factor: summary.total_time_s / wall_s.max(1e-9),
        summary,
        wall_s,
        provenance: p.provenance,
    };
    if write {
        write_json(&p.json_path, &report)?;
    }
    Ok((report, log))
}

/// One line a user reads after a run.
pub fn describe(r: &RunReport) -> String {
    let s = &r.summary;
    format!(
        "{} steps, {} interruptions ({} commands abandoned), time efficiency {:.1} % (data gathering as the paper counts it {:.1} %); simulated {:.0} s in {:.2} s wall ({:.0}x real time); log {} ({:.1} MB)",
        s.steps_completed,
        s.interruptions,
        s.abandoned_commands,
        100.0 * s.time_efficiency,
        100.0 * s.data_gathering_fraction,
        s.total_time_s,
        r.wall_s,
        r.real_time_factor,
        r.mcap.display(),
        r.mcap_bytes as f64 / 1e6
    )
}

/// The options that determine a run's log, by the command-line option that sets each (the
/// names an overwrite refusal reports).
fn run_options(req: &RunRequest, robot_file: &Path, terrain_file: &Path) -> serde_json::Value {
    let mut o = serde_json::json!({
        "--robot": robot_file.display().to_string(),
        "--terrain": terrain_file.display().to_string(),
        "--steps": req.steps,
        "--seed": req.sim.seed,
        "--sampler": req.sampler,
        "--physics-hz": req.sim.physics_hz,
        "--noise": noise_label(&serde_json::to_value(req.sim.noise).unwrap_or_default()),
        "--inject": req.sim.effects,
    });
    // Only when given: the options of earlier logs (without it) stay the same options.
    if let Some(a) = &req.safe_area {
        o["--safe-area"] = serde_json::json!([a.length_m, a.width_m]);
    }
    if let Some(like) = &req.draw_like {
        o["--sampler"] = serde_json::json!(MATCHED_SAMPLER);
        o["--draw-like"] = serde_json::json!(like.display().to_string());
    }
    o
}

/// The command of each step of the log at `like`; a log without a step is bad input naming it.
fn commands_of(like: &Path) -> Result<Vec<WheelSpeeds>> {
    let opened = drive_sim_log::open(like, &Default::default())?;
    let commands = opened.log.held_commands();
    if commands.is_empty() {
        return Err(Error::config(
            like,
            "--draw-like",
            "the log holds no DRIVE step whose quadrants to draw in",
        ));
    }
    Ok(commands)
}

/// `"off"` or `"typical"` for the sensor noise the command line names, else the values.
fn noise_label(noise: &serde_json::Value) -> serde_json::Value {
    use drive_sim_sim::SensorNoise;
    let named = [
        ("off", SensorNoise::default()),
        ("typical", SensorNoise::typical()),
    ];
    for (name, n) in named {
        if serde_json::to_value(n).ok().as_ref() == Some(noise) {
            return serde_json::Value::from(name);
        }
    }
    noise.clone()
}

/// The same options as recorded by an earlier run's `run.json` (also by versions that wrote
/// no provenance: read from the fields they did write).
fn recorded_options(run_json: &serde_json::Value) -> Option<serde_json::Value> {
    if let Some(o) = run_json.pointer("/provenance/options") {
        return Some(o.clone());
    }
    let sim = run_json.get("sim")?;
    Some(serde_json::json!({
        "--robot": run_json.get("robot_file")?,
        "--terrain": run_json.get("terrain_file")?,
        "--steps": run_json.pointer("/protocol/steps")?,
        "--seed": sim.get("seed")?,
        "--sampler": run_json.get("sampler")?,
        "--physics-hz": sim.get("physics_hz")?,
        "--noise": noise_label(sim.get("noise")?),
        "--inject": sim.get("effects")?,
    }))
}

/// Refuses to replace the log at `mcap` when it was made with options other than `options`
/// (a rerun with the same options gives the same bytes and may replace it).
fn refuse_other_options(mcap: &Path, run_json: &Path, options: &serde_json::Value) -> Result<()> {
    if !mcap.exists() {
        return Ok(());
    }
    let old = std::fs::read_to_string(run_json)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| recorded_options(&v));
    let differing: Vec<String> = match (&old, options.as_object()) {
        (Some(serde_json::Value::Object(old)), Some(new)) => new
            .iter()
            .filter(|(k, v)| old.get(k.as_str()) != Some(v))
            .map(|(k, v)| {
                let was = old
                    .get(k.as_str())
                    .map_or("(not recorded)".to_string(), |o| o.to_string());
                format!("{k} {v} (log: {was})")
            })
            .collect(),
        _ => {
            return Err(Error::config(
                mcap,
                "--name",
                format!(
                    "a log of this name exists and {} does not say which options made it; \
                     choose another --name or pass --force to overwrite it",
                    run_json.display()
                ),
            ))
        }
    };
    if differing.is_empty() {
        return Ok(());
    }
    Err(Error::config(
        mcap,
        "--name",
        format!(
            "a log of this name was made with other options: {}; choose another --name or pass --force to overwrite it",
            differing.join(", ")
        ),
    ))
}
