//! The analysis of DRIVE logs behind `drive-sim analyze` and the demo: each log read, analysed
//! with the paper's parameters for its robot, and the logs reported together.

use crate::error::{Error, Result};
use drive_sim_analysis::smoother::KernelCovariance;
use drive_sim_analysis::{Analysis, AnalysisParams, SmootherParams};
use drive_sim_log::DriveLog;
use drive_sim_report::analysis_report::{write_analysis_report_of, AnalysisReportFiles, LogSummary};
use std::path::PathBuf;

/// What to analyse and how.
#[derive(Debug, Clone)]
pub struct AnalyzeOptions {
    /// Logs: `.mcap` written by `drive-sim run`, or measured `.csv` (JSON beside it).
    pub logs: Vec<PathBuf>,
    /// Output directory.
    pub out: PathBuf,
    /// Transfer-function grid resolution in vx (m/s) and wz (rad/s).
    pub resolution: f64,
    /// Kernel variance Σ = diag(v, v); `None`: [`paper_kernel_variance`] of the log's robot.
    pub kernel_variance: Option<f64>,
    /// Keep steps whose pose contradicts the encoders (see
    /// [`drive_sim_analysis::segment::POSE_CONTRADICTION_M_S`]); excluded by default.
    pub keep_pose_contradictions: bool,
    /// How to open inputs a log does not describe itself (rosbag2 bags: robot, terrain, roles).
    pub input: drive_sim_log::OpenOptions,
}

/// What [`analyze_logs`] tells its caller as it goes.
#[derive(Debug, Clone, Copy)]
pub enum AnalyzeEvent<'a> {
    /// Reading this log.
    Reading(&'a std::path::Path),
    /// Analysing this log.
    Analysing(&'a DriveLog),
    /// What reading a log left out or assumed.
    Note(&'a str),
}

/// The paper's kernel variance for a robot: 0.25 for the Husky (lessons learned), 0.64 for
/// the Warthog figures, used for any other robot too.
pub fn paper_kernel_variance(robot: &str) -> f64 {
    drive_sim_analysis::smoother::KernelCovariance::paper_variance(robot)
}

/// The transfer-function grid resolutions accepted, m/s and rad/s: 0.01 gives grids of about
/// 10⁶ cells on the Warthog's command space (the paper uses 0.1).
pub const RESOLUTION_RANGE: (f64, f64) = (0.01, 2.0);

fn bad_option(field: &str, message: String) -> Error {
    Error::config("<command line>", field, message)
}

/// The analysis parameters of `opts` for a log of `robot`.
pub fn analysis_params(opts: &AnalyzeOptions, robot: &str) -> Result<AnalysisParams> {
    let (lo, hi) = RESOLUTION_RANGE;
    if !(opts.resolution.is_finite() && (lo..=hi).contains(&opts.resolution)) {
        return Err(bad_option(
            "--resolution",
            format!(
                "must be in [{lo}, {hi}] m/s (vx) and rad/s (wz), got {} (a finer grid has \
                 millions of cells per axis pair and does not fit in memory)",
                opts.resolution
            ),
        ));
    }
    let variance = opts
        .kernel_variance
        .unwrap_or_else(|| paper_kernel_variance(robot));
    if !(variance > 0.0 && variance <= 100.0 && variance.is_finite()) {
        return Err(bad_option(
            "--kernel-variance",
            format!("must be in (0, 100] (m/s)² and (rad/s)², got {variance}"),
        ));
    }
    Ok(AnalysisParams {
        smoother: SmootherParams {
            resolution_vx_m_s: opts.resolution,
            resolution_wz_rad_s: opts.resolution,
            covariance: KernelCovariance {
                var_vx: variance,
                var_wz: variance,
            },
            ..SmootherParams::default()
        },
        pose_contradiction_m_s: if opts.keep_pose_contradictions {
            None
        } else {
            AnalysisParams::default().pose_contradiction_m_s
        },
        ..AnalysisParams::default()
    })
}

/// The analyses and the report files of [`analyze_logs`].
#[derive(Debug)]
pub struct AnalyzedLogs {
    /// One per log, in order.
    pub analyses: Vec<Analysis>,
    /// What the report wrote.
    pub files: AnalysisReportFiles,
}

/// Analyses one log with `opts`'s parameters; returns what the report needs of the log, so that
/// the log can be dropped.
pub fn analyse_log(opts: &AnalyzeOptions, log: &DriveLog) -> Result<(LogSummary, Analysis)> {
    let a = drive_sim_analysis::analyze(log, &analysis_params(opts, &log.meta.robot)?)?;
    Ok((LogSummary::of(log, &a), a))
}

/// Reads, analyses and reports the logs of `opts`, one log at a time: each is dropped once
/// analysed, so that peak memory is that of the largest log, not of all of them.
pub fn analyze_logs(opts: &AnalyzeOptions, progress: &mut dyn FnMut(AnalyzeEvent)) -> Result<AnalyzedLogs> {
    // Parameters and the output folder first: bad input fails before any log is read.
    analysis_params(opts, "")?;
    let staged = drive_sim_model::output::StagedDir::begin(&opts.out, "--out")?;
    let mut done = Vec::new();
    for path in &opts.logs {
        progress(AnalyzeEvent::Reading(path));
        let opened = drive_sim_log::open(path, &opts.input)?;
        for n in &opened.notes {
            progress(AnalyzeEvent::Note(n));
        }
        for w in &opened.warnings {
            progress(AnalyzeEvent::Note(&format!("warning: {w}")));
        }
        let log = opened.log;
        progress(AnalyzeEvent::Analysing(&log));
        let (summary, a) = analyse_log(opts, &log)?;
        for e in &a.exclusions {
            progress(AnalyzeEvent::Note(&format!(
                "warning: {}: step {} excluded: {}",
                log.meta.name, e.step, e.reason
            )));
        }
        if !a.steady_command_changes.is_empty() {
            let steps: Vec<String> = a
                .steady_command_changes
                .iter()
                .map(|c| c.step.to_string())
                .collect();
            progress(AnalyzeEvent::Note(&format!(
                "{}: the steady windows of step(s) {} record another command in a few samples (the next step's, recorded early): each is analysed under the command it holds (summary.json, `steady_command_changes`)",
                log.meta.name,
                steps.join(", ")
            )));
        }
        done.push((summary, a));
    }
    // The folder appears whole, or (on any error above) not at all.
    let mut out = report(done, staged.path())?;
    let inputs = opts
        .logs
        .iter()
        .map(|p| drive_sim_model::provenance::InputFile::of_file("log", p))
        .collect();
    let options = serde_json::json!({
        "resolution": opts.resolution,
        "kernel_variance": opts.kernel_variance,
        "keep_pose_contradictions": opts.keep_pose_contradictions,
        "robot": opts.input.robot,
        "terrain": opts.input.terrain,
        "roles": opts.input.roles,
    });
    drive_sim_model::provenance::stamp_json_file(
        &out.files.summary,
        &drive_sim_model::provenance::Provenance::new(inputs, options),
    )?;
    out.files.relocate(&|p| staged.final_path(p));
    staged.commit()?;
    Ok(out)
}

/// Writes the report of analysed logs into `out`.
pub fn report(done: Vec<(LogSummary, Analysis)>, out: &std::path::Path) -> Result<AnalyzedLogs> {
    let items: Vec<(&LogSummary, &Analysis)> = done.iter().map(|(s, a)| (s, a)).collect();
    let files = write_analysis_report_of(&items, out)?;
    Ok(AnalyzedLogs {
        analyses: done.into_iter().map(|(_, a)| a).collect(),
        files,
    })
}
