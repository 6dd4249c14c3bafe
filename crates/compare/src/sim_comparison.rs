//! One simulated run against the prepared real side ([`compare_one`]): the steps it is compared
//! on (paired or not), the metrics' bootstrap differences with Holm, the maps against their
//! yardstick with the permutation test, the time, the verdict and the loss.

use crate::curvature::{self, CurvatureBreakdown};
use crate::metrics::{resampled, statistic, two_sample_diffs, StepRow, METRICS};
use crate::prepared::too_few;
use crate::{
    loss, records_time, run_info, scatter, tf, turn_memory, CompareOptions, MetricDiff, Pairing,
    PreparedReal, PreparedSim, SimComparison, TfDiff, TimeDiff, Verdict, Warning,
};
use drive_sim_analysis::bootstrap::{holm, two_sided_p};
use drive_sim_log::{DriveLog, Origin};
use drive_sim_model::kinematics::CommandSpace;

/// Compares one simulated run with the real side; its warnings (too few steps, no common map
/// point) are added to `warnings`.
pub(crate) fn compare_one(
    prepared: &PreparedReal,
    sim: &PreparedSim,
    warnings: &mut Vec<Warning>,
) -> SimComparison {
    let (real, s) = (prepared.input, sim.input);
    let opts = &prepared.opts;
    too_few(&s.log.meta.name, sim.rows.len(), warnings);
    let steps = ComparedSteps::of(prepared, sim);
    let Resampled {
        pairing,
        steps_used,
        per_metric,
        curvature,
    } = resample(prepared, sim, &steps);
    let metrics = metric_diffs(&per_metric, &steps, &prepared.space, opts);
    let (transfer, maps) = transfer_diffs(prepared, sim, &steps);
    if transfer.iter().all(|t| t.points == 0) {
        warnings.push(Warning {
            name: "tf_no_overlap".into(),
            message: format!(
                "`{}` and `{}` share no grid point with enough steps near it: transfer functions not compared",
                real.log.meta.name, s.log.meta.name
            ),
        });
    }
    let verdict = verdict(&metrics, &transfer, opts.alpha);
    let (real_a, sim_a) = (&prepared.analysis, &sim.analysis);
    let mut c = SimComparison {
        sim: run_info(s.log, sim_a, s.file.map(|f| f.to_path_buf())),
        pairing,
        steps_used,
        metrics,
        transfer,
        maps,
        time: time_diff(real.log, s.log, prepared.rows.len(), sim.rows.len()),
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
    c
}

/// The steps of one comparison: every analysed step of each run, and, when the simulated run
/// replays the real one's commands, the steps both analysed, paired in the real log's order.
struct ComparedSteps<'r> {
    real: Vec<&'r StepRow>,
    sim: Vec<&'r StepRow>,
    common: Option<(Vec<StepRow>, Vec<StepRow>)>,
}

impl<'r> ComparedSteps<'r> {
    fn of(prepared: &'r PreparedReal, sim: &'r PreparedSim) -> Self {
        let (real_rows, sim_rows) = (&prepared.rows, &sim.rows);
        let paired = matches!(
            &sim.input.log.meta.origin,
            Origin::Replayed { of, .. } if *of == prepared.input.log.meta.name
        );
        let common = paired.then(|| {
            real_rows
                .iter()
                .filter_map(|r| sim_rows.iter().find(|q| q.step == r.step).map(|q| (*r, *q)))
                .unzip()
        });
        Self {
            real: real_rows.iter().collect(),
            sim: sim_rows.iter().collect(),
            common,
        }
    }
}

/// Each metric's resampled real and simulated values with their differences (sim − real), and
/// the breakdown by curvature, as the pairing allows.
struct Resampled {
    pairing: Pairing,
    steps_used: (usize, usize),
    /// Per metric of [`METRICS`]: (real, sim, sim − real) resamples.
    per_metric: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
    curvature: CurvatureBreakdown,
}

/// Paired runs are resampled by the same draws of their common steps; other runs independently,
/// the real side's resamples being those prepared once.
fn resample(prepared: &PreparedReal, sim: &PreparedSim, steps: &ComparedSteps) -> Resampled {
    let b = &prepared.opts.bootstrap;
    let space = &prepared.space;
    let nominal = &prepared.input.log.meta.nominal;
    let geometry = curvature::WheelGeometry {
        radius_m: nominal.wheel_radius_m,
        baseline_m: nominal.baseline_m,
    };
    if let Some((rr, ss)) = &steps.common {
        let curvature = curvature::breakdown(
            &rr.iter().collect::<Vec<_>>(),
            &ss.iter().collect::<Vec<_>>(),
            Pairing::Paired,
            geometry,
            b,
        );
        let draws = b.draws(rr.len(), 3);
        let rs = resampled(rr, &draws, space);
        let sm = resampled(ss, &draws, space);
        let per_metric = rs
            .into_iter()
            .zip(sm)
            .map(|(r, q)| {
                let d = q.iter().zip(&r).map(|(a, b)| a - b).collect();
                (r, q, d)
            })
            .collect();
        Resampled {
            pairing: Pairing::Paired,
            steps_used: (rr.len(), ss.len()),
            per_metric,
            curvature,
        }
    } else {
        let draws = b.draws(sim.rows.len(), 2);
        let sm = resampled(&sim.rows, &draws, space);
        let per_metric = prepared
            .stats
            .iter()
            .zip(sm)
            .map(|(r, q)| {
                let d = two_sample_diffs(r, &q, b.resamples);
                (r.clone(), q, d)
            })
            .collect();
        let curvature = curvature::breakdown(&steps.real, &steps.sim, Pairing::TwoSample, geometry, b);
        Resampled {
            pairing: Pairing::TwoSample,
            steps_used: (prepared.rows.len(), sim.rows.len()),
            per_metric,
            curvature,
        }
    }
}

/// The metrics' differences with their intervals, the medians tested with Holm's method.
fn metric_diffs(
    per_metric: &[(Vec<f64>, Vec<f64>, Vec<f64>)],
    steps: &ComparedSteps,
    space: &CommandSpace,
    opts: &CompareOptions,
) -> Vec<MetricDiff> {
    let b = &opts.bootstrap;
    let mut metrics: Vec<MetricDiff> = METRICS
        .iter()
        .zip(per_metric)
        .enumerate()
        .map(|(k, ((name, unit, tol), (r, q, d)))| {
            let real_v = statistic(k, &steps.real, space);
            let sim_v = statistic(k, &steps.sim, space);
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
    metrics
}

/// The maps' differences against the yardstick, with the permutation test's p-values
/// (Holm-adjusted over the channels).
fn transfer_diffs(
    prepared: &PreparedReal,
    sim: &PreparedSim,
    steps: &ComparedSteps,
) -> (Vec<TfDiff>, tf::DiffMaps) {
    let (opts, tf_grid, halves) = (&prepared.opts, &prepared.tf_grid, &prepared.halves);
    let sim_fields = tf_grid.fields(&steps.sim);
    let (mut transfer, maps) = tf_grid.compare(
        &prepared.fields,
        &sim_fields,
        halves,
        &prepared.splits,
        prepared.rows.len(),
        sim.rows.len(),
    );
    let seed = opts.bootstrap.seed ^ 0x7e57;
    let p_perm = match &steps.common {
        Some((rr, ss)) => tf_grid.permutation_p(
            &rr.iter().collect::<Vec<_>>(),
            &ss.iter().collect::<Vec<_>>(),
            true,
            &sim_fields,
            halves,
            &transfer,
            opts.tf_permutations,
            seed,
        ),
        None => tf_grid.permutation_p(
            &steps.real,
            &steps.sim,
            false,
            &sim_fields,
            halves,
            &transfer,
            opts.tf_permutations,
            seed,
        ),
    };
    let adjusted = holm(&p_perm.iter().map(|p| p.unwrap_or(f64::NAN)).collect::<Vec<_>>());
    for ((t, p), a) in transfer.iter_mut().zip(&p_perm).zip(adjusted) {
        t.p_permutation = *p;
        t.p_permutation_holm = p.map(|_| a);
    }
    (transfer, maps)
}

/// Interruptions per step and time efficiency of both runs, when both logs record them.
fn time_diff(real: &DriveLog, sim: &DriveLog, real_steps: usize, sim_steps: usize) -> Option<TimeDiff> {
    if !(records_time(real) && records_time(sim)) {
        return None;
    }
    let per = |l: &DriveLog, n: usize| l.interruptions.len() as f64 / n.max(1) as f64;
    Some(TimeDiff {
        real_interruptions_per_step: per(real, real_steps),
        sim_interruptions_per_step: per(sim, sim_steps),
        real_time_efficiency: real.time_efficiency(),
        sim_time_efficiency: sim.time_efficiency(),
    })
}

/// The verdict: the run reproduces the real one when no median differs significantly, every
/// area is within its tolerance and every map within its yardstick (the maps' permutation test
/// is listed beside it, not part of it).
fn verdict(metrics: &[MetricDiff], transfer: &[TfDiff], alpha: f64) -> Verdict {
    let significant: Vec<String> = metrics
        .iter()
        .filter(|m| m.significant)
        .map(|m| m.metric.clone())
        .collect();
    let areas_beyond_tolerance: Vec<String> = metrics
        .iter()
        .filter(|m| m.within_tolerance == Some(false))
        .map(|m| m.metric.clone())
        .collect();
    let tf_beyond_yardstick: Vec<String> = transfer
        .iter()
        .filter(|t| t.points > 0 && !t.within)
        .map(|t| t.channel.clone())
        .collect();
    let tf_significant = transfer
        .iter()
        .filter(|t| t.p_permutation_holm.is_some_and(|p| p < alpha))
        .map(|t| t.channel.clone())
        .collect();
    Verdict {
        reproduces: significant.is_empty()
            && areas_beyond_tolerance.is_empty()
            && tf_beyond_yardstick.is_empty(),
        significant,
        areas_beyond_tolerance,
        tf_beyond_yardstick,
        tf_significant,
    }
}
