//! `compare`: does a simulated DRIVE run reproduce a real one, in the paper's own terms?
//!
//! [`compare`] puts a real log and one or more simulated logs of the same robot side by side:
//! median steady-state ρ and slips (vx, vy, wz, each wheel), the area of T over U in both
//! frames, the transfer functions as difference maps (sim − real), and interruptions and time
//! efficiency where the real log records them (a measured CSV export does not).
//!
//! Every difference gets a bootstrap-by-step interval ([`drive_sim_analysis::bootstrap`], the same
//! definition `analyze` uses for its medians) that carries both runs' sampling error:
//! - **paired** when the simulated log replays the real log's commands (its metadata says so,
//!   [`drive_sim_log::Origin::Replayed`]): the same steps are drawn in both runs;
//! - **two-sample** otherwise: each run's steps are drawn independently.
//!
//! The p-values of the differences (two-sided, from the same resamples) are adjusted with
//! Holm's method over the six medians of each simulated log, so "no significant difference" is
//! a family-wise statement at the chosen level. A T/U area is judged by its tolerance (within
//! 5 percentage points); its bootstrap interval is reported but is not
//! a test (a resampled hull never exceeds the run's, see [`compare`]). The transfer-function RMS difference has no
//! bootstrap: it is judged against a yardstick, the same RMS between two halves of the real run
//! (its odd and even steps, and random balanced halvings: the quadratic mean over
//! `tf_yardstick_splits` of them, [`tf::SplitHalves`]), scaled to full size
//! ([`tf::yardstick_scale`]).
//!
//! The library computes ([`compare`] → [`ComparisonReport`]); [`mod@write`] writes
//! `comparison.json`, the figures and the report.
//!
//! Closing the loop on a twin: [`tune`] searches a twin's parameters in closed loop on
//! compare's statistics, and [`judge`] asks whether compare can tell the real run from the
//! twin's own runs at all (a Monte Carlo test against runs of the twin in the real run's place).
//!
//! ```no_run
//! use drive_sim_compare::{compare, CompareOptions, Input};
//! use std::path::Path;
//!
//! let real = drive_sim_log::read_log(Path::new("warthog_gravel.csv"))?;
//! let twin = drive_sim_log::read_log(Path::new("out/run/warthog_gravel_s0.mcap"))?;
//! let report = compare(
//!     Input { log: &real, file: None },
//!     &[Input { log: &twin, file: None }],
//!     &CompareOptions::default(),
//! )?;
//! let verdict = &report.sims[0].verdict;
//! println!("reproduces: {}; significant: {:?}", verdict.reproduces, verdict.significant);
//! # Ok::<(), drive_sim_compare::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod error;
pub use error::{Error, Result};

pub mod curvature;
pub mod judge;
pub mod loss;
mod metrics;
mod options;
mod prepared;
pub mod real_steps;
mod report;
pub mod scatter;
mod sim_comparison;
pub mod tf;
pub mod tune;
pub mod turn_memory;
pub mod write;

pub(crate) use metrics::{two_sample_diffs, StepRow};
pub use options::{CompareOptions, TfSmoother, DEFAULT_YARDSTICK_SPLITS};
pub use prepared::{PreparedReal, PreparedSim};
pub use report::{
    ComparisonReport, MetricDiff, Pairing, RunInfo, SimComparison, TfDiff, TimeDiff, Verdict, Warning,
};

use drive_sim_analysis::{analyze, Analysis, AnalysisParams, SmootherParams};
use drive_sim_log::{DriveLog, Origin};
use std::path::PathBuf;

/// The analysis `compare` runs on each log: default parameters without the smoother (the
/// comparison smooths on one common grid itself).
pub fn analysis_of(log: &DriveLog) -> Result<Analysis> {
    let params = AnalysisParams {
        smoother: SmootherParams {
            enabled: false,
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    };
    Ok(analyze(log, &params)?)
}

/// Whether a log records the protocol's interruptions and timing (simulated logs and bags do;
/// a measured CSV export does not).
pub fn records_time(log: &DriveLog) -> bool {
    match &log.meta.origin {
        Origin::Measured { file } => !file.to_ascii_lowercase().ends_with(".csv"),
        Origin::Replayed { .. } => false,
        Origin::Simulated { .. } => true,
    }
}

pub(crate) fn run_info(log: &DriveLog, a: &Analysis, file: Option<PathBuf>) -> RunInfo {
    let rec = records_time(log);
    RunInfo {
        name: log.meta.name.clone(),
        file,
        robot: log.meta.robot.clone(),
        terrain: log.meta.terrain.clone(),
        steps: a.steps.len(),
        interruptions: rec.then_some(log.interruptions.len()),
        time_efficiency: rec.then(|| log.time_efficiency()),
    }
}

/// A log to compare, with the file it came from (for the report).
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// The log.
    pub log: &'a DriveLog,
    /// Its file.
    pub file: Option<&'a std::path::Path>,
}

/// Compares `real` with each of `sims` (see the module doc). Refuses logs of another robot
/// than the real one's (bad input); warns, by name, of runs too short for an interval.
pub fn compare(real: Input, sims: &[Input], opts: &CompareOptions) -> Result<ComparisonReport> {
    // The cheap checks first: bad input is reported before the real log is analysed (the
    // options are checked first thing by `PreparedReal::new`).
    check_inputs(real, sims)?;
    compare_prepared(&PreparedReal::new(real, opts)?, sims)
}

/// Refuses an empty list of simulated logs and logs of another robot than the real one's.
fn check_inputs(real: Input, sims: &[Input]) -> Result<()> {
    if sims.is_empty() {
        return Err(Error::config("compare", "SIM", "give at least one simulated log"));
    }
    for s in sims {
        if s.log.meta.robot != real.log.meta.robot {
            return Err(Error::log(
                s.file
                    .map_or_else(|| s.log.meta.name.clone().into(), |f| f.to_path_buf()),
                "metadata: robot",
                format!(
                    "robot `{}` is not the real log's `{}` ({}): a comparison needs one robot",
                    s.log.meta.robot,
                    real.log.meta.robot,
                    real.file
                        .map_or_else(|| real.log.meta.name.clone(), |f| f.display().to_string())
                ),
            ));
        }
    }
    Ok(())
}

/// [`compare`] against a real side prepared once (with its options).
pub fn compare_prepared(prepared: &PreparedReal, sims: &[Input]) -> Result<ComparisonReport> {
    check_inputs(prepared.input, sims)?;
    let sims = sims
        .iter()
        .map(|s| PreparedSim::new(*s))
        .collect::<Result<Vec<_>>>()?;
    compare_prepared_sims(prepared, &sims)
}

/// [`compare`] of simulated logs analysed once against a real side prepared once.
pub fn compare_prepared_sims(prepared: &PreparedReal, sims: &[PreparedSim]) -> Result<ComparisonReport> {
    let real = prepared.input;
    check_inputs(real, &sims.iter().map(|s| s.input).collect::<Vec<_>>())?;
    let mut warnings = prepared.warnings.clone();
    let mut out = Vec::new();
    for sim in sims {
        out.push(sim_comparison::compare_one(prepared, sim, &mut warnings));
    }
    Ok(ComparisonReport {
        real: run_info(real.log, &prepared.analysis, real.file.map(|f| f.to_path_buf())),
        options: prepared.opts,
        sims: out,
        warnings,
    })
}
