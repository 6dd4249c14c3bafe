//! Where the body and its wheels part: the steady-state motion of both runs split by the
//! commanded path's curvature.
//!
//! Why: the transfer-function maps say *where* in the command space a simulated run differs
//! from the real one, not *what* differs. A skid-steering robot's body and wheels part in a
//! way that depends on how hard it is asked to turn: driving straight the body moves at its
//! wheels' speed; in a curve the inner side brakes and the outer side drives, and which of
//! the two slips more decides whether the body goes faster or slower than its wheels imply
//! and how tightly it turns. Measured per class of curvature, the ratio of the body's forward
//! speed and yaw rate to the ones its *measured* wheel speeds imply separates the ground (how
//! wheel spin becomes motion) from the wheel loop (how commands become wheel spin), which the
//! slips mix.
//!
//! The class is the commanded wheel differential `d = |ω_R − ω_L| / |ω_R + ω_L|` (0 straight,
//! 1 one side stopped, above 1 the sides counter-rotate, infinite in place): a property of the
//! command, so a replay of the real commands puts each step in the same class in both runs and
//! the difference is paired by step, as [`super::compare`]'s metrics are. A diagnostic, not a
//! verdict: its differences are not in the Holm family of the `reproduces` verdict.

use super::{two_sample_diffs, Pairing, StepRow};
use drive_sim_analysis::bootstrap::{two_sided_p, Bootstrap, Interval, ResampledMedian};
use drive_sim_analysis::stats;
use serde::{Deserialize, Serialize};

/// Classes of commanded wheel differential `d`: name, lower bound (inclusive), upper bound.
pub const CLASSES: &[(&str, f64, f64)] = &[
    ("straight", 0.0, 0.1),
    ("curve", 0.1, 0.5),
    ("tight curve", 0.5, 1.0),
    ("pivot", 1.0, 3.0),
    ("turn in place", 3.0, f64::INFINITY),
];

/// The wheel-implied forward speed below which the forward ratio is not computed, m/s (a
/// ratio of two small noisy numbers says nothing).
pub const MIN_WHEEL_SPEED_M_S: f64 = 0.3;
/// The wheel-implied yaw rate below which the yaw ratio is not computed, rad/s.
pub const MIN_WHEEL_YAW_RATE_RAD_S: f64 = 0.2;

/// The robot geometry that turns wheel speeds into the body motion they imply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelGeometry {
    /// Wheel radius, m.
    pub radius_m: f64,
    /// Distance between the wheel sides, m.
    pub baseline_m: f64,
}

/// One statistic of one class in both runs, and its difference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClassStatistic {
    /// Median on the real run (NaN without a step).
    pub real: f64,
    /// Its 95 % interval (bootstrap by step).
    pub real_ci95: Option<Interval>,
    /// Median on the simulated run.
    pub sim: f64,
    /// Its interval.
    pub sim_ci95: Option<Interval>,
    /// `sim − real`.
    pub difference: f64,
    /// Interval of the difference (paired or two-sample, as the comparison).
    pub difference_ci95: Option<Interval>,
    /// Two-sided bootstrap p-value of a zero difference (not Holm-adjusted: a diagnostic).
    pub p: f64,
}

/// One class of curvature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CurvatureClass {
    /// Name, e.g. `tight curve`.
    pub class: String,
    /// Lower bound of the commanded wheel differential `d`.
    pub d_min: f64,
    /// Upper bound (`null` in JSON when unbounded).
    pub d_max: Option<f64>,
    /// Steps of the real and simulated runs in the class.
    pub steps: (usize, usize),
    /// Body forward speed over the one the measured wheel speeds imply, `vx / (r (ω_L + ω_R) / 2)`.
    pub forward_ratio: ClassStatistic,
    /// Body yaw rate over the one the measured wheel speeds imply, `wz / (r (ω_R − ω_L) / b)`.
    pub yaw_ratio: ClassStatistic,
    /// Median steady-state ρ.
    pub rho: ClassStatistic,
}

/// The classes of one simulated run against the real one.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CurvatureBreakdown {
    /// How `d` is computed and what the ratios are, for a reader of `comparison.json`.
    pub definition: String,
    /// One entry per class with a step in either run.
    pub classes: Vec<CurvatureClass>,
}

/// Commanded wheel differential of a step.
pub fn differential(cmd_wheels: (f64, f64)) -> f64 {
    let (l, r) = cmd_wheels;
    let sum = (l + r).abs();
    if sum < 1e-9 {
        return if (r - l).abs() < 1e-9 { 0.0 } else { f64::INFINITY };
    }
    (r - l).abs() / sum
}

fn class_of(d: f64) -> usize {
    CLASSES
        .iter()
        .position(|&(_, lo, hi)| d >= lo && d < hi)
        .unwrap_or(CLASSES.len() - 1)
}

/// The three per-step values of the breakdown: forward ratio, yaw ratio, ρ (NaN where a ratio
/// is not defined).
fn values(row: &StepRow, g: WheelGeometry) -> [f64; 3] {
    let (l, r) = row.t_wheels;
    let vx_w = g.radius_m * (l + r) / 2.0;
    let wz_w = g.radius_m * (r - l) / g.baseline_m;
    let fwd = if vx_w.abs() >= MIN_WHEEL_SPEED_M_S {
        row.t_body.0 / vx_w
    } else {
        f64::NAN
    };
    let yaw = if wz_w.abs() >= MIN_WHEEL_YAW_RATE_RAD_S {
        row.t_body.1 / wz_w
    } else {
        f64::NAN
    };
    [fwd, yaw, row.values[0]]
}

fn resampled_medians(v: &[f64], draws: &[Vec<usize>]) -> Vec<f64> {
    let mut median = ResampledMedian::new(v);
    draws.iter().map(|d| median.of(d)).collect()
}

fn statistic(real: &[f64], sim: &[f64], pairing: Pairing, b: &Bootstrap, stream: u64) -> ClassStatistic {
    let (r_med, s_med) = (stats::median(real), stats::median(sim));
    let (r_stats, s_stats, diffs) = match pairing {
        Pairing::Paired => {
            let draws = b.draws(real.len(), stream);
            let r = resampled_medians(real, &draws);
            let s = resampled_medians(sim, &draws);
            let d = s.iter().zip(&r).map(|(a, c)| a - c).collect();
            (r, s, d)
        }
        Pairing::TwoSample => {
            let r = resampled_medians(real, &b.draws(real.len(), stream));
            let s = resampled_medians(sim, &b.draws(sim.len(), stream + 1));
            let d = two_sample_diffs(&r, &s, b.resamples);
            (r, s, d)
        }
    };
    ClassStatistic {
        real: r_med,
        real_ci95: b.interval(&r_stats),
        sim: s_med,
        sim_ci95: b.interval(&s_stats),
        difference: s_med - r_med,
        difference_ci95: b.interval(&diffs),
        p: two_sided_p(&diffs),
    }
}

/// The breakdown of `sim` against `real` (paired: `sim` holds the same steps as `real`, in
/// the same order, each classed by the real command).
pub(crate) fn breakdown(
    real: &[&StepRow],
    sim: &[&StepRow],
    pairing: Pairing,
    geometry: WheelGeometry,
    b: &Bootstrap,
) -> CurvatureBreakdown {
    let mut classes = Vec::new();
    for (k, &(name, lo, hi)) in CLASSES.iter().enumerate() {
        let in_class = |r: &&&StepRow| class_of(differential(r.cmd_wheels)) == k;
        let (rr, ss): (Vec<[f64; 3]>, Vec<[f64; 3]>) = match pairing {
            Pairing::Paired => real
                .iter()
                .zip(sim)
                .filter(|(r, _)| in_class(r))
                .map(|(r, s)| (values(r, geometry), values(s, geometry)))
                .unzip(),
            Pairing::TwoSample => (
                real.iter()
                    .filter(in_class)
                    .map(|r| values(r, geometry))
                    .collect(),
                sim.iter().filter(in_class).map(|r| values(r, geometry)).collect(),
            ),
        };
        if rr.is_empty() && ss.is_empty() {
            continue;
        }
        let col = |v: &[[f64; 3]], j: usize| v.iter().map(|x| x[j]).collect::<Vec<f64>>();
        // A stream per class and statistic: independent draws, reproducible.
        let stream = 100 + 10 * k as u64;
        classes.push(CurvatureClass {
            class: name.to_string(),
            d_min: lo,
            d_max: hi.is_finite().then_some(hi),
            steps: (rr.len(), ss.len()),
            forward_ratio: statistic(&col(&rr, 0), &col(&ss, 0), pairing, b, stream),
            yaw_ratio: statistic(&col(&rr, 1), &col(&ss, 1), pairing, b, stream + 3),
            rho: statistic(&col(&rr, 2), &col(&ss, 2), pairing, b, stream + 6),
        });
    }
    CurvatureBreakdown {
        definition: format!(
            "classes of the commanded wheel differential d = |w_R - w_L| / |w_R + w_L|; forward_ratio = body vx / (r (w_L + w_R) / 2) over steps whose measured wheels imply at least {MIN_WHEEL_SPEED_M_S} m/s; yaw_ratio = body wz / (r (w_R - w_L) / b) over steps whose wheels imply at least {MIN_WHEEL_YAW_RATE_RAD_S} rad/s; steady-state means per step, medians with bootstrap-by-step intervals; p not Holm-adjusted (a diagnostic)"
        ),
        classes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(step: u32, cmd: (f64, f64), wheels: (f64, f64), body: (f64, f64), rho: f64) -> StepRow {
        StepRow {
            step,
            values: [rho, 0.0, 0.0, 0.0, 0.0, 0.0],
            cmd_body: (0.0, 0.0),
            cmd_wheels: cmd,
            t_body: body,
            t_wheels: wheels,
            vy: 0.0,
        }
    }

    #[test]
    fn differential_classes_commands() {
        assert_eq!(class_of(differential((5.0, 5.0))), 0);
        assert_eq!(class_of(differential((4.0, 6.0))), 1); // d = 0.2
        assert_eq!(class_of(differential((0.0, 6.0))), 3); // one side stopped: d = 1
        assert_eq!(class_of(differential((-1.0, 6.0))), 3); // d = 1.4
        assert_eq!(class_of(differential((-5.0, 5.0))), 4); // in place
        assert_eq!(differential((0.0, 0.0)), 0.0);
    }

    #[test]
    fn ratios_are_body_over_what_the_wheels_imply() {
        let g = WheelGeometry {
            radius_m: 0.5,
            baseline_m: 1.0,
        };
        // Wheels 2 and 4 rad/s: they imply 1.5 m/s and 1 rad/s; the body does 1.2 and 0.5.
        let v = values(&row(0, (2.0, 4.0), (2.0, 4.0), (1.2, 0.5), 0.3), g);
        assert!((v[0] - 0.8).abs() < 1e-12 && (v[1] - 0.5).abs() < 1e-12 && v[2] == 0.3);
        // Too slow for a forward ratio, straight for a yaw ratio.
        let v = values(&row(0, (0.1, 0.1), (0.1, 0.1), (0.05, 0.0), 0.1), g);
        assert!(v[0].is_nan() && v[1].is_nan());
    }

    #[test]
    fn a_run_against_itself_differs_by_nothing_and_a_faster_body_is_found() {
        let g = WheelGeometry {
            radius_m: 0.3,
            baseline_m: 1.0,
        };
        let real: Vec<StepRow> = (0..30)
            .map(|i| {
                let l = 2.0 + 0.1 * i as f64;
                let r = l * 1.5; // d = 0.2: a curve
                row(
                    i,
                    (l, r),
                    (l, r),
                    (0.9 * 0.15 * (l + r), 0.5 * 0.3 * (r - l)),
                    0.2,
                )
            })
            .collect();
        let refs: Vec<&StepRow> = real.iter().collect();
        let b = Bootstrap::default();
        let same = breakdown(&refs, &refs, Pairing::Paired, g, &b);
        assert_eq!(same.classes.len(), 1);
        let c = &same.classes[0];
        assert_eq!(c.class, "curve");
        assert!((c.forward_ratio.real - 0.9).abs() < 1e-12);
        assert_eq!(c.forward_ratio.difference, 0.0);
        let ci = c.forward_ratio.difference_ci95.unwrap();
        assert!(ci.lower == 0.0 && ci.upper == 0.0);
        // A simulated body 10 % faster than its wheels where the real one is 10 % slower.
        let sim: Vec<StepRow> = real
            .iter()
            .map(|r| StepRow {
                t_body: (r.t_body.0 / 0.9 * 1.1, r.t_body.1),
                ..*r
            })
            .collect();
        let srefs: Vec<&StepRow> = sim.iter().collect();
        let d = breakdown(&refs, &srefs, Pairing::TwoSample, g, &b);
        let f = &d.classes[0].forward_ratio;
        assert!((f.difference - 0.2).abs() < 1e-9, "{f:?}");
        assert!(f.difference_ci95.unwrap().lower > 0.1 && f.p < 0.01);
        assert!(d.classes[0].yaw_ratio.difference.abs() < 1e-12);
    }
}
