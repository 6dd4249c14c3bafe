//! What a comparison found, as `comparison.json` holds it: per simulated log, the metrics with
//! their intervals, the transfer-function differences, the time, the curvature breakdown, the
//! verdict and the loss; named warnings. Users' scripts read these fields: add, don't rename.

use super::{curvature, loss, tf, CompareOptions};
use drive_sim_analysis::bootstrap::Interval;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One log as the comparison sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// Dataset name.
    pub name: String,
    /// File it was read from.
    pub file: Option<PathBuf>,
    /// Robot.
    pub robot: String,
    /// Terrain.
    pub terrain: String,
    /// Steps analysed.
    pub steps: usize,
    /// Interruptions, when the log records the protocol's state.
    pub interruptions: Option<usize>,
    /// Time efficiency (productive share of protocol time), when recorded.
    pub time_efficiency: Option<f64>,
}

/// How the two runs' steps were resampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pairing {
    /// The simulated log replays the real commands: steps drawn together (same step numbers).
    Paired,
    /// Independent runs: each run's steps drawn on their own.
    TwoSample,
}

/// A scalar metric of both runs and its difference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricDiff {
    /// Metric key, e.g. `median_rho`, `median_slip_vx`, `t_area_pct_body`.
    pub metric: String,
    /// Unit.
    pub unit: String,
    /// Value on the real run.
    pub real: f64,
    /// Its interval.
    pub real_ci95: Option<Interval>,
    /// Value on the simulated run.
    pub sim: f64,
    /// Its interval.
    pub sim_ci95: Option<Interval>,
    /// `sim − real`.
    pub difference: f64,
    /// Interval of the difference (both runs' sampling error).
    pub difference_ci95: Option<Interval>,
    /// Two-sided bootstrap p-value of a zero difference.
    pub p: f64,
    /// Holm-adjusted p-value over this simulated log's six medians; not a number (`null`) for a
    /// T/U area, which is judged by its tolerance (its bootstrap is biased: a resampled hull
    /// never exceeds the run's).
    pub p_holm: f64,
    /// The difference is significant at the family-wise level (never for a T/U area).
    pub significant: bool,
    /// Tolerance of the `reproduces` verdict on |difference| (T/U areas: 5 percentage points).
    pub tolerance: Option<f64>,
    /// |difference| within the tolerance.
    pub within_tolerance: Option<bool>,
}

/// Transfer-function difference of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TfDiff {
    /// Channel, e.g. `slip_vx_m_s`.
    pub channel: String,
    /// Unit.
    pub unit: String,
    /// RMS over the compared grid points of (sim − real).
    pub rms: f64,
    /// RMS between the real run's odd and even steps (same grid points).
    pub split_half_rms: f64,
    /// Quadratic mean of the split-half RMS over `yardstick_splits` halvings of the real run
    /// (the alternate steps and random balanced halvings, [`tf::SplitHalves`]; same grid
    /// points). `None` in files written before it existed, whose yardstick used
    /// `split_half_rms`.
    #[serde(default)]
    pub split_half_rms_mean: Option<f64>,
    /// Halvings behind `split_half_rms_mean`.
    #[serde(default)]
    pub yardstick_splits: Option<usize>,
    /// `split_half_rms_mean` scaled to the two full runs' sizes: the RMS expected from
    /// sampling alone.
    pub yardstick: f64,
    /// `rms / yardstick`.
    pub ratio: f64,
    /// `ratio ≤ tf_tolerance`.
    pub within: bool,
    /// Grid points compared.
    pub points: usize,
    /// Permutation p-value of the RMS difference (steps exchanged between the runs, see
    /// [`tf`]); `None` when not computed (`tf_permutations` 0).
    #[serde(default)]
    pub p_permutation: Option<f64>,
    /// The same, Holm-adjusted over the five channels.
    #[serde(default)]
    pub p_permutation_holm: Option<f64>,
}

/// Interruptions and time efficiency of both runs (one value per run: no interval).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimeDiff {
    /// Interruptions per completed step, real run.
    pub real_interruptions_per_step: f64,
    /// Same, simulated run.
    pub sim_interruptions_per_step: f64,
    /// Time efficiency of the real run.
    pub real_time_efficiency: f64,
    /// Time efficiency of the simulated run.
    pub sim_time_efficiency: f64,
}

/// The verdict on one simulated log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// No significant difference in the medians, T/U areas within tolerance, every transfer
    /// function within its yardstick: the twin reproduces the real run.
    pub reproduces: bool,
    /// Medians with a significant difference (Holm).
    pub significant: Vec<String>,
    /// T/U areas beyond the tolerance.
    pub areas_beyond_tolerance: Vec<String>,
    /// Transfer functions beyond the yardstick.
    pub tf_beyond_yardstick: Vec<String>,
    /// Transfer functions whose difference is beyond what exchanging the steps between the
    /// runs gives (permutation test, Holm over the five, at `alpha`): a calibrated diagnostic
    /// beside the yardstick, not part of `reproduces` (whose criterion is the yardstick).
    #[serde(default)]
    pub tf_significant: Vec<String>,
}

/// One simulated log against the real one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimComparison {
    /// The simulated log.
    pub sim: RunInfo,
    /// Resampling used.
    pub pairing: Pairing,
    /// Steps drawn together (paired) or the two runs' step counts (two-sample).
    pub steps_used: (usize, usize),
    /// Scalar metrics.
    pub metrics: Vec<MetricDiff>,
    /// Transfer-function differences.
    pub transfer: Vec<TfDiff>,
    /// Difference maps (sim − real) on the real run's grid.
    pub maps: tf::DiffMaps,
    /// Interruptions and time efficiency, when both logs record them.
    pub time: Option<TimeDiff>,
    /// Body against wheels by commanded curvature (a diagnostic, not in the verdict).
    #[serde(default)]
    pub curvature: curvature::CurvatureBreakdown,
    /// Both runs' step scatter (a diagnostic, not in the verdict or the loss); absent from
    /// files written before it existed.
    #[serde(default)]
    pub step_scatter: Option<super::scatter::ScatterDiff>,
    /// Both runs' turn memory (a diagnostic, not in the verdict or the loss); absent from files
    /// written before it existed.
    #[serde(default)]
    pub turn_memory: Option<super::turn_memory::TurnMemoryDiff>,
    /// Verdict.
    pub verdict: Verdict,
    /// The verdict in one number ([`loss::loss`]: each term 1 at its threshold, squared and
    /// summed), what `tune` minimises. Two 100-step runs of one exact model score 2.7-9.2
    /// against each other, mean 4.8 (`scripts/same_model_pairs.py`, nine pairs). Absent from
    /// files written before it existed.
    #[serde(default)]
    pub loss: Option<loss::Loss>,
}

/// A named warning in the report (never a silent fallback).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Warning {
    /// Stable name, e.g. `too_few_steps`.
    pub name: String,
    /// What and where.
    pub message: String,
}

/// Everything [`super::compare`] found (`comparison.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComparisonReport {
    /// The real run.
    pub real: RunInfo,
    /// Options used.
    pub options: CompareOptions,
    /// One entry per simulated log.
    pub sims: Vec<SimComparison>,
    /// Named warnings.
    pub warnings: Vec<Warning>,
}
