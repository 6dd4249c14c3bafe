//! One number for "how far is this simulated run from the real one", in the verdict's own
//! terms: what a closed-loop search ([`crate::tune`]) minimises.
//!
//! Each term is scaled so that it is 1 at its verdict's threshold:
//! - a median (ρ, the five slips): the difference over the half-width of its 95 % interval (1
//!   where the interval starts to exclude zero);
//! - a T/U area: the difference over the area tolerance (5 percentage points), its verdict
//!   (its bootstrap interval is not a test, see [`super::compare`]);
//! - a transfer function: its RMS over the yardstick, divided by the tolerance (1.5×);
//! - the step scatter: the difference over the real interval's width, at least its tolerance
//!   (0.1 rad/s per wheel): 1 where two runs as uncertain as the real one would stop
//!   overlapping ([`crate::scatter::ScatterDiff::scaled_difference`]). Why in the loss though not
//!   in the verdict: a search that does not see the scatter sets a knob that makes it (the
//!   step offset `wheel_speed_scatter`) for what it does to the other terms, and a twin then
//!   scatters far more than its robot, or keeps none where the robot has it.
//!
//! The loss is the sum of the squared terms: a run meeting every criterion of the verdict has
//! every term at most about 1, a run failing one has at least one term above 1. A metric
//! without an interval (too few steps) or a transfer function without a common grid point
//! contributes nothing, and says so (`terms[i].value` is `None`).

use super::{CompareOptions, SimComparison};
use serde::{Deserialize, Serialize};

/// One term of the loss.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LossTerm {
    /// What it measures: a metric key (`median_rho`), `<area>/tolerance`, or a transfer
    /// channel (`slip_vx_m_s`).
    pub name: String,
    /// The scaled difference (1 at the verdict's threshold); `None` when it cannot be formed.
    pub value: Option<f64>,
}

/// The loss of one simulated run against the real one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Loss {
    /// Sum of the squared terms.
    pub total: f64,
    /// Every term.
    pub terms: Vec<LossTerm>,
}

impl Loss {
    /// The term named `name`, when it could be formed.
    pub fn term(&self, name: &str) -> Option<f64> {
        self.terms.iter().find(|t| t.name == name).and_then(|t| t.value)
    }
}

/// The loss of `c` (see the module doc), with the tolerances of `opts`.
pub fn loss(c: &SimComparison, opts: &CompareOptions) -> Loss {
    let mut terms = Vec::new();
    for m in &c.metrics {
        if let Some(tol) = m.tolerance.filter(|t| *t > 0.0) {
            terms.push(LossTerm {
                name: format!("{}/tolerance", m.metric),
                value: m.difference.is_finite().then(|| m.difference / tol),
            });
            continue;
        }
        let z = m.difference_ci95.and_then(|ci| {
            let half = 0.5 * (ci.upper - ci.lower);
            (half > 0.0 && m.difference.is_finite()).then(|| m.difference / half)
        });
        terms.push(LossTerm {
            name: m.metric.clone(),
            value: z,
        });
    }
    for t in &c.transfer {
        terms.push(LossTerm {
            name: t.channel.clone(),
            value: (t.points > 0 && t.ratio.is_finite()).then(|| t.ratio / opts.tf_tolerance),
        });
    }
    if let Some(d) = &c.step_scatter {
        terms.push(LossTerm {
            name: crate::judge::STEP_SCATTER.into(),
            value: d.scaled_difference(),
        });
    }
    let total = terms.iter().filter_map(|t| t.value).map(|v| v * v).sum();
    Loss { total, terms }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MetricDiff, Pairing, RunInfo, TfDiff, Verdict};
    use drive_sim_analysis::bootstrap::Interval;

    fn metric(name: &str, diff: f64, half: f64, tol: Option<f64>) -> MetricDiff {
        MetricDiff {
            metric: name.into(),
            unit: "-".into(),
            real: 0.0,
            real_ci95: None,
            sim: diff,
            sim_ci95: None,
            difference: diff,
            difference_ci95: Some(Interval {
                lower: diff - half,
                upper: diff + half,
                level: 0.95,
            }),
            p: 1.0,
            p_holm: 1.0,
            significant: false,
            tolerance: tol,
            within_tolerance: None,
        }
    }

    fn tf(ratio: f64, points: usize) -> TfDiff {
        TfDiff {
            channel: "slip_vx_m_s".into(),
            unit: "m/s".into(),
            rms: ratio,
            split_half_rms: 1.0,
            split_half_rms_mean: Some(1.0),
            yardstick_splits: Some(1),
            yardstick: 1.0,
            ratio,
            within: ratio <= 1.5,
            points,
            p_permutation: None,
            p_permutation_holm: None,
        }
    }

    fn comparison(metrics: Vec<MetricDiff>, transfer: Vec<TfDiff>) -> SimComparison {
        let info = RunInfo {
            name: "s".into(),
            file: None,
            robot: "r".into(),
            terrain: "t".into(),
            steps: 20,
            interruptions: None,
            time_efficiency: None,
        };
        SimComparison {
            sim: info,
            pairing: Pairing::TwoSample,
            steps_used: (20, 20),
            metrics,
            transfer,
            maps: crate::tf::DiffMaps {
                vx_m_s: vec![],
                wz_rad_s: vec![],
                channels: vec![],
                values: vec![],
            },
            time: None,
            curvature: Default::default(),
            step_scatter: None,
            turn_memory: None,
            verdict: Verdict {
                reproduces: true,
                significant: vec![],
                areas_beyond_tolerance: vec![],
                tf_beyond_yardstick: vec![],
                tf_significant: vec![],
            },
            loss: None,
        }
    }

    #[test]
    fn each_term_is_one_at_its_threshold() {
        let opts = CompareOptions::default();
        // ρ at its interval's edge, an area at 5 pp (its interval, half-width 0.2, is no test
        // and costs nothing), a map at 1.5×.
        let c = comparison(
            vec![
                metric("median_rho", 0.1, 0.1, None),
                metric("t_area_pct_body", 5.0, 0.2, Some(5.0)),
            ],
            vec![tf(1.5, 12)],
        );
        let l = loss(&c, &opts);
        assert_eq!(l.term("median_rho"), Some(1.0));
        assert_eq!(l.term("t_area_pct_body"), None);
        assert_eq!(l.term("t_area_pct_body/tolerance"), Some(1.0));
        assert_eq!(l.term("slip_vx_m_s"), Some(1.0));
        assert_eq!(l.terms.len(), 3);
        assert!((l.total - 3.0).abs() < 1e-12, "{}", l.total);
    }

    fn scatter(v: f64, lower: f64, upper: f64) -> drive_sim_analysis::scatter::StepScatter {
        drive_sim_analysis::scatter::StepScatter {
            pairs: 20,
            wheel_rad_s: Some(v),
            ci95: Some(Interval {
                lower,
                upper,
                level: 0.95,
            }),
            ..Default::default()
        }
    }

    /// The step scatter's term is 1 where two runs as uncertain as the real one would stop
    /// overlapping (the real interval's width apart), at least the tolerance; beyond it the term
    /// grows, a scatter the twin lacks counts as one it has too much, and a twin's own wider
    /// interval buys it nothing.
    #[test]
    fn the_step_scatter_term_is_one_at_the_real_intervals_width() {
        let opts = CompareOptions::default();
        let with = |real, sim| {
            let mut c = comparison(vec![], vec![]);
            c.step_scatter = Some(crate::scatter::ScatterDiff::new(real, sim));
            loss(&c, &opts)
        };
        // Real 0.28 [0.26, 0.34]: width 0.08, below the tolerance 0.1; twin 0.42: 0.14 / 0.1.
        let l = with(scatter(0.28, 0.26, 0.34), scatter(0.42, 0.40, 0.50));
        assert!((l.term("step_scatter").unwrap() - 1.4).abs() < 1e-12);
        // A twin without scatter: 0.05 against 0.48 [0.31, 0.65], width 0.34.
        let l = with(scatter(0.48, 0.31, 0.65), scatter(0.05, 0.03, 0.09));
        assert!((l.term("step_scatter").unwrap() + 0.43 / 0.34).abs() < 1e-12);
        // A twin that scatters more, with the wider interval that comes with it, is held to the
        // robot's scale: 0.86 [0.69, 1.06] against 0.40 [0.31, 0.52] is (0.86 − 0.40) / 0.21,
        // where the intervals' own gap (0.12 + 0.17) would have made it 1.59.
        let d = crate::scatter::ScatterDiff::new(scatter(0.40, 0.31, 0.52), scatter(0.86, 0.69, 1.06));
        assert!((d.scaled_difference().unwrap() - 0.46 / 0.21).abs() < 1e-12);
        assert!(d.differs);
        // The twin's interval does not enter.
        let tight = crate::scatter::ScatterDiff::new(scatter(0.40, 0.31, 0.52), scatter(0.86, 0.85, 0.87));
        assert_eq!(tight.scaled_difference(), d.scaled_difference());
        // Without an estimate: named, nothing added.
        let mut none = scatter(0.3, 0.2, 0.4);
        none.wheel_rad_s = None;
        let l = with(none, scatter(0.3, 0.2, 0.4));
        assert_eq!(l.term("step_scatter"), None);
        assert_eq!(l.total, 0.0);
    }

    #[test]
    fn terms_that_cannot_be_formed_are_named_and_add_nothing() {
        let opts = CompareOptions::default();
        let mut m = metric("median_rho", 0.3, 0.1, None);
        m.difference_ci95 = None;
        let l = loss(&comparison(vec![m], vec![tf(2.0, 0)]), &opts);
        assert_eq!(l.terms.len(), 2);
        assert!(l.terms.iter().all(|t| t.value.is_none()));
        assert_eq!(l.total, 0.0);
    }
}
