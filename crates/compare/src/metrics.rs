//! The scalar metrics `compare` puts side by side (median ρ and slips, T/U areas), computed from
//! the analysed steps of a run, and their bootstrap resamples.

use drive_sim_analysis::bootstrap::ResampledMedian;
use drive_sim_analysis::{spaces, stats, Analysis};
use drive_sim_model::kinematics::CommandSpace;

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

/// The rows of an analysis's steps, in its order.
pub(crate) fn rows(a: &Analysis) -> Vec<StepRow> {
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
pub(crate) const METRICS: &[(&str, &str, Option<f64>)] = &[
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
pub(crate) fn statistic(k: usize, rows: &[&StepRow], space: &CommandSpace) -> f64 {
    if k < 6 {
        return stats::median(&rows.iter().map(|r| r.values[k]).collect::<Vec<_>>());
    }
    let (body, wheels) = t_areas(rows, space);
    if k == 6 {
        body
    } else {
        wheels
    }
}

/// The T/U areas (body, wheels; % of U) of a set of steps.
fn t_areas(rows: &[&StepRow], space: &CommandSpace) -> (f64, f64) {
    let col = |f: fn(&StepRow) -> (f64, f64)| rows.iter().map(|r| f(r)).collect::<Vec<_>>();
    let s = spaces::spaces(
        space,
        col(|r| r.cmd_body),
        col(|r| r.cmd_wheels),
        col(|r| r.t_body),
        col(|r| r.t_wheels),
        &rows.iter().map(|r| r.vy).collect::<Vec<_>>(),
    );
    (s.t_area_pct_body, s.t_area_pct_wheels)
}

/// Resampled values of every metric on `rows` for each draw: the medians from the counts of
/// each step drawn ([`ResampledMedian`]), both areas from one computation of the spaces.
pub(crate) fn resampled(rows: &[StepRow], draws: &[Vec<usize>], space: &CommandSpace) -> Vec<Vec<f64>> {
    let mut medians: Vec<ResampledMedian> = (0..6)
        .map(|k| ResampledMedian::new(&rows.iter().map(|r| r.values[k]).collect::<Vec<_>>()))
        .collect();
    let mut out = vec![Vec::with_capacity(draws.len()); METRICS.len()];
    for d in draws {
        for (k, median) in medians.iter_mut().enumerate() {
            out[k].push(median.of(d));
        }
        let (body, wheels) = t_areas(&pick(rows, d), space);
        out[6].push(body);
        out[7].push(wheels);
    }
    out
}

fn pick<'a>(rows: &'a [StepRow], idx: &[usize]) -> Vec<&'a StepRow> {
    idx.iter().map(|&i| &rows[i]).collect()
}

/// Differences `sim − real` of two independent sets of resampled statistics: every pair when
/// there are few enough (both exhaustive), else draw i with draw i.
pub(crate) fn two_sample_diffs(real: &[f64], sim: &[f64], budget: usize) -> Vec<f64> {
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
