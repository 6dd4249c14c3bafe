//! The analysis of DRIVE logs behind `drive-sim analyze` and the demo: each log read, analysed
//! with the paper's parameters for its robot, and the logs reported together.

use crate::analysis::smoother::KernelCovariance;
use crate::analysis::{Analysis, AnalysisParams, SmootherParams};
use crate::error::{Error, Result};
use crate::log::DriveLog;
use crate::report::analysis_report::{write_analysis_report, AnalysisReportFiles};
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
}

/// What [`analyze_logs`] tells its caller as it goes.
#[derive(Debug, Clone, Copy)]
pub enum AnalyzeEvent<'a> {
    /// Reading this log.
    Reading(&'a std::path::Path),
    /// Analysing this log.
    Analysing(&'a DriveLog),
}

/// The paper's kernel variance for a robot: 0.25 for the Husky (lessons learned), 0.64 for
/// the Warthog figures, used for any other robot too.
pub fn paper_kernel_variance(robot: &str) -> f64 {
    if robot == "husky" {
        0.25
    } else {
        0.64
    }
}

fn bad_option(field: &str, message: String) -> Error {
    Error::config("<command line>", field, message)
}

/// The analysis parameters of `opts` for a log of `robot`.
pub fn analysis_params(opts: &AnalyzeOptions, robot: &str) -> Result<AnalysisParams> {
    if !(opts.resolution > 0.0 && opts.resolution.is_finite()) {
        return Err(bad_option(
            "--resolution",
            format!("must be > 0, got {}", opts.resolution),
        ));
    }
    let variance = opts
        .kernel_variance
        .unwrap_or_else(|| paper_kernel_variance(robot));
    if !(variance > 0.0 && variance.is_finite()) {
        return Err(bad_option(
            "--kernel-variance",
            format!("must be > 0, got {variance}"),
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

/// Reads, analyses and reports the logs of `opts`.
pub fn analyze_logs(opts: &AnalyzeOptions, progress: &mut dyn FnMut(AnalyzeEvent)) -> Result<AnalyzedLogs> {
    // Parameters first: a bad option fails before any log is read.
    analysis_params(opts, "")?;
    let mut logs = Vec::new();
    for path in &opts.logs {
        progress(AnalyzeEvent::Reading(path));
        logs.push(crate::log::read_log(path)?);
    }
    let mut analyses = Vec::new();
    for log in &logs {
        progress(AnalyzeEvent::Analysing(log));
        analyses.push(crate::analysis::analyze(
            log,
            &analysis_params(opts, &log.meta.robot)?,
        )?);
    }
    let items: Vec<_> = logs.iter().zip(&analyses).collect();
    let files = write_analysis_report(&items, &opts.out)?;
    Ok(AnalyzedLogs { analyses, files })
}
