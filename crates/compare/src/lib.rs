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

pub mod curvature;
pub mod judge;
pub mod loss;
mod options;
mod real_steps;
mod report;
pub mod scatter;
pub mod tf;
pub mod tune;
pub mod turn_memory;
pub mod write;

use options::check_options;
pub use options::{CompareOptions, TfSmoother, DEFAULT_YARDSTICK_SPLITS};
pub use report::{
    ComparisonReport, MetricDiff, Pairing, RunInfo, SimComparison, TfDiff, TimeDiff, Verdict, Warning,
};

use drive_sim_analysis::bootstrap::{holm, two_sided_p, MIN_STEPS_FOR_INTERVAL};
use drive_sim_analysis::smoother::Smoothed;
use drive_sim_analysis::{analyze, spaces, stats, Analysis, AnalysisParams, SmootherParams};
use drive_sim_log::{DriveLog, Origin};
use drive_sim_model::error::{Error, Result};
use drive_sim_model::kinematics::CommandSpace;
use std::path::PathBuf;

/// What one step contributes to the metrics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StepRow {
    pub step: u32,
    /// ρ, slips vx, vy, wz, left, right.
    pub values: [f64; 6],
    pub cmd_body: (f64, f64),
    pub cmd_wheels: (f64, f64),
    pub t_body: (f64, f64),
    pub t_wheels: (f64, f64),
    pub vy: f64,
}

fn rows(a: &Analysis) -> Vec<StepRow> {
    a.steps
        .iter()
        .map(|s| {
            let r = &s.steady;
            StepRow {
                step: s.step,
                values: [
                    s.steady_rho.rho,
                    r.slip_body.vx_m_s,
                    r.slip_body.vy_m_s,
                    r.slip_body.wz_rad_s,
                    r.slip_wheels.left_rad_s,
                    r.slip_wheels.right_rad_s,
                ],
                cmd_body: (r.cmd_body.vx_m_s, r.cmd_body.wz_rad_s),
                cmd_wheels: (r.cmd_wheels.left_rad_s, r.cmd_wheels.right_rad_s),
                t_body: (r.realized_body.vx_m_s, r.realized_body.wz_rad_s),
                t_wheels: (r.realized_wheels.left_rad_s, r.realized_wheels.right_rad_s),
                vy: r.realized_body.vy_m_s,
            }
        })
        .collect()
}

/// The metrics compared, with their units and tolerance.
const METRICS: &[(&str, &str, Option<f64>)] = &[
    ("median_rho", "-", None),
    ("median_slip_vx", "m/s", None),
    ("median_slip_vy", "m/s", None),
    ("median_slip_wz", "rad/s", None),
    ("median_slip_left", "rad/s", None),
    ("median_slip_right", "rad/s", None),
    ("t_area_pct_body", "%", Some(0.0)),
    ("t_area_pct_wheels", "%", Some(0.0)),
];

/// Metric `k` of [`METRICS`] on a set of steps.
fn statistic(k: usize, rows: &[&StepRow], space: &CommandSpace) -> f64 {
    if k < 6 {
        return stats::median(&rows.iter().map(|r| r.values[k]).collect::<Vec<_>>());
    }
    let col = |f: fn(&StepRow) -> (f64, f64)| rows.iter().map(|r| f(r)).collect::<Vec<_>>();
    let s = spaces::spaces(
        space,
        col(|r| r.cmd_body),
        col(|r| r.cmd_wheels),
        col(|r| r.t_body),
        col(|r| r.t_wheels),
        &rows.iter().map(|r| r.vy).collect::<Vec<_>>(),
    );
    if k == 6 {
        s.t_area_pct_body
    } else {
        s.t_area_pct_wheels
    }
}

fn pick<'a>(rows: &'a [StepRow], idx: &[usize]) -> Vec<&'a StepRow> {
    idx.iter().map(|&i| &rows[i]).collect()
}

/// Resampled values of every metric on `rows` for each draw.
fn resampled(rows: &[StepRow], draws: &[Vec<usize>], space: &CommandSpace) -> Vec<Vec<f64>> {
    (0..METRICS.len())
        .map(|k| {
            draws
                .iter()
                .map(|d| statistic(k, &pick(rows, d), space))
                .collect()
        })
        .collect()
}

/// Differences `sim − real` of two independent sets of resampled statistics: every pair when
/// there are few enough (both exhaustive), else draw i with draw i.
fn two_sample_diffs(real: &[f64], sim: &[f64], budget: usize) -> Vec<f64> {
    if real.is_empty() || sim.is_empty() {
        return Vec::new();
    }
    if real.len() * sim.len() <= budget {
        return sim.iter().flat_map(|s| real.iter().map(move |r| s - r)).collect();
    }
    let n = real.len().max(sim.len());
    (0..n)
        .map(|i| sim[i % sim.len()] - real[i % real.len()])
        .collect()
}

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
    analyze(log, &params)
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

fn run_info(log: &DriveLog, a: &Analysis, file: Option<PathBuf>) -> RunInfo {
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

/// The real side of a comparison, computed once: its analysis, its steps' bootstrap
/// statistics, its transfer-function maps and its halves' (the yardstick). A closed-loop
/// search (`tune`) compares hundreds of simulated runs with one real log; preparing it once
/// cut the asphalt tune of the README from 27.4-27.7 s to 25.2-25.6 s.
pub struct PreparedReal<'a> {
    input: Input<'a>,
    opts: CompareOptions,
    analysis: Analysis,
    rows: Vec<StepRow>,
    space: CommandSpace,
    stats: Vec<Vec<f64>>,
    tf_grid: tf::TfSetup,
    fields: Smoothed,
    halves: (Smoothed, Smoothed),
    splits: tf::SplitHalves,
    warnings: Vec<Warning>,
}

impl<'a> PreparedReal<'a> {
    /// Analyses `real` for comparisons with `opts` (bad options are refused here).
    pub fn new(real: Input<'a>, opts: &CompareOptions) -> Result<Self> {
        check_options(opts)?;
        let analysis = analysis_of(real.log)?;
        let rows = rows(&analysis);
        let space = real.log.meta.nominal.command_space();
        let mut warnings = Vec::new();
        too_few(&real.log.meta.name, rows.len(), &mut warnings);
        if !records_time(real.log) {
            warnings.push(Warning {
                name: "time_not_recorded".into(),
                message: format!(
                    "`{}` does not record interruptions or protocol time (a CSV export): time efficiency is not compared",
                    real.log.meta.name
                ),
            });
        }
        let stats = resampled(&rows, &opts.bootstrap.draws(rows.len(), 1), &space);
        let tf_grid = tf::TfSetup::new(real.log, opts);
        let all: Vec<&StepRow> = rows.iter().collect();
        let fields = tf_grid.fields(&all);
        // Halves by alternating position (not step number: a log may already hold only the
        // odd or the even steps, `--real-steps`).
        let odd: Vec<&StepRow> = rows.iter().skip(1).step_by(2).collect();
        let even: Vec<&StepRow> = rows.iter().step_by(2).collect();
        let halves = (tf_grid.fields(&odd), tf_grid.fields(&even));
        let splits = tf::SplitHalves::new(
            &tf_grid,
            &all,
            &halves,
            opts.tf_yardstick_splits,
            opts.bootstrap.seed ^ 0x5917,
        );
        Ok(Self {
            input: real,
            opts: *opts,
            analysis,
            rows,
            space,
            stats,
            tf_grid,
            fields,
            halves,
            splits,
            warnings,
        })
    }
}

/// A named warning when a run has too few analysed steps for its intervals.
fn too_few(name: &str, n: usize, warnings: &mut Vec<Warning>) {
    if n < MIN_STEPS_FOR_INTERVAL {
        warnings.push(Warning {
            name: "too_few_steps".into(),
            message: format!(
                "`{name}` has {n} analysed steps (fewer than {MIN_STEPS_FOR_INTERVAL}): its intervals are unreliable"
            ),
        });
    }
}

/// A simulated log analysed once, for comparisons with several real sides (`judge` compares
/// the same runs with the real log and with each of its reference runs).
pub struct PreparedSim<'a> {
    input: Input<'a>,
    analysis: Analysis,
    rows: Vec<StepRow>,
}

impl<'a> PreparedSim<'a> {
    /// Analyses `sim` as [`compare`] does.
    pub fn new(sim: Input<'a>) -> Result<Self> {
        let analysis = analysis_of(sim.log)?;
        let rows = rows(&analysis);
        Ok(Self {
            input: sim,
            analysis,
            rows,
        })
    }
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
    let opts = &prepared.opts;
    let real_a = &prepared.analysis;
    let real_rows = &prepared.rows;
    let space = prepared.space;
    let mut warnings = prepared.warnings.clone();
    let b = &opts.bootstrap;
    let real_stats = &prepared.stats;
    let tf_grid = &prepared.tf_grid;
    let real_fields = &prepared.fields;
    let halves = &prepared.halves;

    let mut out = Vec::new();
    for prepared_sim in sims {
        let s = prepared_sim.input;
        let (sim_a, sim_rows) = (&prepared_sim.analysis, &prepared_sim.rows);
        too_few(&s.log.meta.name, sim_rows.len(), &mut warnings);
        let paired = matches!(&s.log.meta.origin, Origin::Replayed { of, .. } if *of == real.log.meta.name);
        let all_real: Vec<&StepRow> = real_rows.iter().collect();
        let all_sim: Vec<&StepRow> = sim_rows.iter().collect();
        let geometry = curvature::WheelGeometry {
            radius_m: real.log.meta.nominal.wheel_radius_m,
            baseline_m: real.log.meta.nominal.baseline_m,
        };
        // Paired: the steps both logs analysed, in the real log's order.
        let common: Option<(Vec<StepRow>, Vec<StepRow>)> = paired.then(|| {
            real_rows
                .iter()
                .filter_map(|r| sim_rows.iter().find(|q| q.step == r.step).map(|q| (*r, *q)))
                .unzip()
        });
        let (pairing, steps_used, per_metric, curvature) = if let Some((rr, ss)) = &common {
            let curvature = curvature::breakdown(
                &rr.iter().collect::<Vec<_>>(),
                &ss.iter().collect::<Vec<_>>(),
                Pairing::Paired,
                geometry,
                b,
            );
            let draws = b.draws(rr.len(), 3);
            let rs = resampled(rr, &draws, &space);
            let sm = resampled(ss, &draws, &space);
            let per: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = rs
                .into_iter()
                .zip(sm)
                .map(|(r, q)| {
                    let d = q.iter().zip(&r).map(|(a, b)| a - b).collect();
                    (r, q, d)
                })
                .collect();
            (Pairing::Paired, (rr.len(), ss.len()), per, curvature)
        } else {
            let draws = b.draws(sim_rows.len(), 2);
            let sm = resampled(sim_rows, &draws, &space);
            let per = real_stats
                .iter()
                .zip(sm)
                .map(|(r, q)| {
                    let d = two_sample_diffs(r, &q, b.resamples);
                    (r.clone(), q, d)
                })
                .collect();
            let curvature = curvature::breakdown(&all_real, &all_sim, Pairing::TwoSample, geometry, b);
            (
                Pairing::TwoSample,
                (real_rows.len(), sim_rows.len()),
                per,
                curvature,
            )
        };
        let mut metrics: Vec<MetricDiff> = METRICS
            .iter()
            .zip(&per_metric)
            .enumerate()
            .map(|(k, ((name, unit, tol), (r, q, d)))| {
                let real_v = statistic(k, &all_real, &space);
                let sim_v = statistic(k, &all_sim, &space);
                let diff = sim_v - real_v;
                let tolerance = tol.map(|_| opts.area_tolerance_pp);
                MetricDiff {
                    metric: name.to_string(),
                    unit: unit.to_string(),
                    real: real_v,
                    real_ci95: b.interval(r),
                    sim: sim_v,
                    sim_ci95: b.interval(q),
                    difference: diff,
                    difference_ci95: b.interval(d),
                    p: two_sided_p(d),
                    p_holm: f64::NAN,
                    significant: false,
                    tolerance,
                    within_tolerance: tolerance.map(|t| diff.abs() <= t),
                }
            })
            .collect();
        // The tested metrics are the medians; a T/U area is judged by its tolerance alone
        // (within 5 percentage points), because its bootstrap is not a test: a resample's hull is
        // the hull of a subset of the steps, so its area is never above the run's, and the
        // resampled difference is shifted by how much each run's hull shrinks (the estimate
        // can lie outside its own percentile interval). The interval is still reported.
        let tested: Vec<f64> = metrics
            .iter()
            .map(|m| if m.tolerance.is_none() { m.p } else { f64::NAN })
            .collect();
        for (m, p) in metrics.iter_mut().zip(holm(&tested)) {
            m.p_holm = p;
            m.significant = p.is_finite() && p < opts.alpha;
        }
        let sim_fields = tf_grid.fields(&all_sim);
        let (mut transfer, maps) = tf_grid.compare(
            real_fields,
            &sim_fields,
            halves,
            &prepared.splits,
            real_rows.len(),
            sim_rows.len(),
        );
        let p_perm = match &common {
            Some((rr, ss)) => tf_grid.permutation_p(
                &rr.iter().collect::<Vec<_>>(),
                &ss.iter().collect::<Vec<_>>(),
                true,
                &sim_fields,
                halves,
                &transfer,
                opts.tf_permutations,
                b.seed ^ 0x7e57,
            ),
            None => tf_grid.permutation_p(
                &all_real,
                &all_sim,
                false,
                &sim_fields,
                halves,
                &transfer,
                opts.tf_permutations,
                b.seed ^ 0x7e57,
            ),
        };
        let adjusted = holm(&p_perm.iter().map(|p| p.unwrap_or(f64::NAN)).collect::<Vec<_>>());
        for ((t, p), a) in transfer.iter_mut().zip(&p_perm).zip(adjusted) {
            t.p_permutation = *p;
            t.p_permutation_holm = p.map(|_| a);
        }
        if transfer.iter().all(|t| t.points == 0) {
            warnings.push(Warning {
                name: "tf_no_overlap".into(),
                message: format!(
                    "`{}` and `{}` share no grid point with enough steps near it: transfer functions not compared",
                    real.log.meta.name, s.log.meta.name
                ),
            });
        }
        let sim_info = run_info(s.log, sim_a, s.file.map(|f| f.to_path_buf()));
        let time = if records_time(real.log) && records_time(s.log) {
            let per = |l: &DriveLog, n: usize| l.interruptions.len() as f64 / n.max(1) as f64;
            Some(TimeDiff {
                real_interruptions_per_step: per(real.log, real_rows.len()),
                sim_interruptions_per_step: per(s.log, sim_rows.len()),
                real_time_efficiency: real.log.time_efficiency(),
                sim_time_efficiency: s.log.time_efficiency(),
            })
        } else {
            None
        };
        let verdict = Verdict {
            significant: metrics
                .iter()
                .filter(|m| m.significant)
                .map(|m| m.metric.clone())
                .collect(),
            areas_beyond_tolerance: metrics
                .iter()
                .filter(|m| m.within_tolerance == Some(false))
                .map(|m| m.metric.clone())
                .collect(),
            tf_beyond_yardstick: transfer
                .iter()
                .filter(|t| t.points > 0 && !t.within)
                .map(|t| t.channel.clone())
                .collect(),
            tf_significant: transfer
                .iter()
                .filter(|t| t.p_permutation_holm.is_some_and(|p| p < opts.alpha))
                .map(|t| t.channel.clone())
                .collect(),
            reproduces: false,
        };
        let verdict = Verdict {
            reproduces: verdict.significant.is_empty()
                && verdict.areas_beyond_tolerance.is_empty()
                && verdict.tf_beyond_yardstick.is_empty(),
            ..verdict
        };
        let mut c = SimComparison {
            sim: sim_info,
            pairing,
            steps_used,
            metrics,
            transfer,
            maps,
            time,
            curvature,
            // As `analyze` prints them: a diagnostic beside the verdict.
            step_scatter: Some(scatter::ScatterDiff::new(real_a.step_scatter, sim_a.step_scatter)),
            turn_memory: Some(turn_memory::TurnMemoryDiff::new(
                real_a.turn_memory,
                sim_a.turn_memory,
            )),
            verdict,
            loss: None,
        };
        c.loss = Some(loss::loss(&c, opts));
        out.push(c);
    }
    Ok(ComparisonReport {
        real: run_info(real.log, real_a, real.file.map(|f| f.to_path_buf())),
        options: *opts,
        sims: out,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_sample_enumerates_every_pair_when_small() {
        let d = two_sample_diffs(&[1.0, 2.0], &[5.0, 7.0], 100);
        assert_eq!(d, vec![4.0, 3.0, 6.0, 5.0]);
        let d = two_sample_diffs(&[1.0, 2.0, 3.0], &[5.0, 7.0], 4);
        assert_eq!(d, vec![4.0, 5.0, 2.0]);
    }
}
