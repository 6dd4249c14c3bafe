//! The demonstration run by `drive-sim` with no arguments: simulated DRIVE runs on contrasting
//! terrains, analysed together, so a first-time user gets the paper's figures in one command.

use super::analyze::{analyse_log, report, AnalyzeEvent, AnalyzeOptions, AnalyzedLogs};
use super::run::{record_run_with_log, RunEvent, RunReport, RunRequest};
use crate::error::Result;
use drive_sim_sim::{SensorNoise, SimConfig};
use std::path::PathBuf;

/// Settings of the demonstration.
#[derive(Debug, Clone)]
pub struct DemoOptions {
    /// Steps per run (paper: at least 150).
    pub steps: u32,
    /// Seed of the runs.
    pub seed: u64,
    /// Output directory: logs in `<out>/logs`, the report in `<out>`.
    pub out: PathBuf,
}

impl Default for DemoOptions {
    fn default() -> Self {
        Self {
            steps: 150,
            seed: 7,
            out: PathBuf::from("out/demo"),
        }
    }
}

/// The scenarios of the demonstration: the Warthog on the paper's contrasting terrains, and the
/// Husky on mud, where its motors saturate.
pub const SCENARIOS: &[(&str, &str)] = &[
    ("warthog", "asphalt"),
    ("warthog", "gravel"),
    ("warthog", "ice"),
    ("husky", "mud"),
];

/// What the demonstration tells its caller as it goes.
#[derive(Debug, Clone, Copy)]
pub enum DemoEvent<'a> {
    /// Starting the run of this robot on this terrain.
    Running {
        /// Robot name.
        robot: &'a str,
        /// Terrain name.
        terrain: &'a str,
    },
    /// A run's progress.
    Run(RunEvent<'a>),
    /// A run is complete.
    RunDone(&'a RunReport),
    /// The analysis's progress.
    Analysis(AnalyzeEvent<'a>),
}

/// What the demonstration made.
#[derive(Debug)]
pub struct Demo {
    /// One per scenario.
    pub runs: Vec<RunReport>,
    /// Their analysis and report.
    pub analysis: AnalyzedLogs,
}

/// The run request of one scenario.
pub fn scenario_request(opts: &DemoOptions, robot: &str, terrain: &str) -> RunRequest {
    RunRequest {
        robot: robot.to_string(),
        terrain: terrain.to_string(),
        steps: opts.steps,
        sampler: "uniform-wheel".into(),
        sim: SimConfig {
            seed: opts.seed,
            noise: SensorNoise::typical(),
            ..SimConfig::default()
        },
        injected: vec![],
        // The demo's logs are its own products: a rerun with other options replaces them.
        force: true,
        out: opts.out.join("logs"),
        name: None,
        safe_area: None,
        cancel: None,
        draw_like: None,
    }
}

/// Runs the scenarios, then reports their analyses together. Each run is analysed from the
/// frames it has just written, then its log is dropped: memory holds one run at a time.
pub fn run_demo(opts: &DemoOptions, progress: &mut dyn FnMut(DemoEvent)) -> Result<Demo> {
    let mut runs = Vec::new();
    let mut done = Vec::new();
    for (robot, terrain) in SCENARIOS {
        progress(DemoEvent::Running { robot, terrain });
        let (r, log) = record_run_with_log(&scenario_request(opts, robot, terrain), &mut |e| {
            progress(DemoEvent::Run(e))
        })?;
        progress(DemoEvent::RunDone(&r));
        let analyze_opts = AnalyzeOptions {
            logs: vec![r.mcap.clone()],
            out: opts.out.clone(),
            resolution: 0.1,
            kernel_variance: None,
            keep_pose_contradictions: false,
            input: Default::default(),
        };
        progress(DemoEvent::Analysis(AnalyzeEvent::Analysing(&log)));
        done.push(analyse_log(&analyze_opts, &log)?);
        runs.push(r);
    }
    let analysis = report(done, &opts.out)?;
    Ok(Demo { runs, analysis })
}
