//! Which knobs move the twin towards the robot: each knob of the pool moved a little either
//! side of its calibrated value, the rest of the model as calibrated, every point run in closed loop on the pass's
//! seeds and scored by compare's loss. What a knob changes in each of the loss's terms (ρ, the
//! slips, the T/U areas, the maps) is measured here, on this run, for this robot and ground:
//! no table says in advance which knob moves which statistic.

use crate::closed::{term, Closed, PointScore};
use crate::event::TwinEvent;
use crate::knobs::{Knob, KnobInfo};
use drive_sim_calibration::ModelParams;
use drive_sim_compare::tune::search::design;
use serde::{Deserialize, Serialize};

/// Points of a knob's box run by the screening: two on each side of the calibrated value, one
/// [`SCREEN_STEP`] of its box away and one [`FINE_SCREEN_STEP`].
pub const POINTS_PER_KNOB: usize = 4;

/// How far the outer screening points move a parameter from its calibrated value, as a
/// fraction of its box. The calibration by replay leaves most parameters near the robot's, and
/// what the closed loop adds is a correction: points far out (the box's quarters) measured the
/// knob where it is worst, and a knob whose good value lay close by looked harmful (the Husky's
/// ICR offset scored 15.2 and 27.2 at its quarters against 10.4 calibrated), or did not run at
/// all. The search that follows covers the whole box.
pub const SCREEN_STEP: f64 = 0.125;

/// How far the inner screening points move it: a quarter of [`SCREEN_STEP`]. Why a second,
/// finer pair: a multiplier whose box spans a wide ratio moves the robot a lot in an eighth of
/// it. The lateral friction's multiplier (`turning_resistance_scale`, box [0.2, 5]) moves 0.6
/// in an eighth; from a tuned Warthog twin of asphalt, 0.4 and 1.6 both raise the loss, while
/// 0.85 brings its yaw rate in pivots and turns in place, 25 % short of the robot's, part of
/// the way back and lowers it. The second round of the measured Warthog runs' twins takes it
/// at that point (`docs/results/twins.md`, "The rule").
pub const FINE_SCREEN_STEP: f64 = SCREEN_STEP / 4.0;

/// One point of a knob's screening.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScreenPoint {
    /// The knob's parameters there, in their units.
    pub values: Vec<f64>,
    /// Mean loss over the seeds (`None`: a run failed, or the values make no valid model).
    pub loss: Option<f64>,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// What moving one knob does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KnobScreen {
    /// The knob.
    pub knob: KnobInfo,
    /// Its points.
    pub points: Vec<ScreenPoint>,
    /// Its best point (lowest loss), if any ran.
    pub best: Option<usize>,
    /// The calibrated model's loss minus the best point's (positive: the knob helps).
    pub gain: f64,
    /// At the best point, each loss term's change from the calibrated model (sim − real
    /// differences in threshold units: a term moving towards 0 is a statistic moving towards
    /// the robot's).
    pub term_change: Vec<(String, f64)>,
}

/// The screening of a pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Screening {
    /// Seeds every point ran with.
    pub seeds: Vec<u64>,
    /// The calibrated model on those seeds.
    pub start: PointScore,
    /// Every knob, in the pool's order.
    pub knobs: Vec<KnobScreen>,
    /// DRIVE runs in all.
    pub runs: usize,
}

/// What [`screen`] works on.
pub(crate) struct ScreenInput<'a> {
    pub(crate) closed: &'a Closed<'a>,
    /// The calibrated model of each ground.
    pub(crate) starts: &'a [ModelParams],
    pub(crate) knobs: &'a [Knob],
    pub(crate) seeds: &'a [u64],
    /// The grounds' names (the loss terms' prefixes when several).
    pub(crate) names: &'a [String],
}

/// The models of every ground with `knob` at `values` (an invalid combination: the error).
pub(crate) fn with_knob(
    starts: &[ModelParams],
    knob: &Knob,
    values: &[f64],
) -> Result<Vec<ModelParams>, String> {
    starts
        .iter()
        .map(|m| m.with_values(&knob.specs, values).map_err(|e| e.to_string()))
        .collect()
}

/// A point of the unit box in the knob's units.
pub(crate) fn knob_values(knob: &Knob, z: &[f64]) -> Vec<f64> {
    knob.specs
        .iter()
        .zip(z)
        .map(|(s, z)| s.lower + z * (s.upper - s.lower))
        .collect()
}

/// The knob's screening points, in its units.
///
/// A parameter whose calibrated value `c` lies in its box (a limit that is off, or values that
/// differ between grounds, do not) moves by `SCREEN_STEP` of its box to either side at the
/// first two points, `c + d` and `c − d`, and by `FINE_SCREEN_STEP` at the next two, the signs
/// alternating between a knob's parameters so that a pair does not move them all together; a
/// side beyond the box is replaced by a second step on the other side. Any other parameter
/// takes the Halton design's second to fifth points (the quarters of its box, then two of its
/// eighths; the first point, the middle, is often the calibrated value itself).
pub(crate) fn screen_points(knob: &Knob, starts: &[ModelParams]) -> [Vec<f64>; POINTS_PER_KNOB] {
    let far = design(knob.specs.len(), POINTS_PER_KNOB + 1);
    let mut points: [Vec<f64>; POINTS_PER_KNOB] = Default::default();
    for (j, spec) in knob.specs.iter().enumerate() {
        let of = |m: &ModelParams| {
            let v = spec.param.get(m);
            // An effect the model does not run sits at its neutral value.
            if v.is_nan() {
                spec.param.neutral().unwrap_or(f64::NAN)
            } else {
                v
            }
        };
        let c = starts.first().map_or(f64::NAN, of);
        let same = starts.iter().all(|m| of(m) == c);
        let (lo, hi) = (spec.lower, spec.upper);
        let beside = |step: f64| {
            let d = step * (hi - lo);
            let (a, b) = if c + d > hi {
                (c - d, c - 2.0 * d)
            } else if c - d < lo {
                (c + d, c + 2.0 * d)
            } else {
                (c + d, c - d)
            };
            if j % 2 == 0 {
                [a, b]
            } else {
                [b, a]
            }
        };
        let values: [f64; POINTS_PER_KNOB] = if same && c.is_finite() && (lo..=hi).contains(&c) {
            let [a, b] = beside(SCREEN_STEP);
            let [e, f] = beside(FINE_SCREEN_STEP);
            [a, b, e, f]
        } else {
            std::array::from_fn(|i| lo + far[i + 1][j] * (hi - lo))
        };
        for (p, v) in points.iter_mut().zip(values) {
            p.push(v);
        }
    }
    points
}

/// Runs the calibrated model and every knob's points (all in parallel), and measures each
/// knob's gain and the terms it moves.
pub(crate) fn screen(input: &ScreenInput, progress: &(dyn Fn(&TwinEvent) + Sync)) -> Screening {
    let ScreenInput {
        closed,
        starts,
        knobs,
        seeds,
        names,
    } = *input;
    // Every point's values and models; the calibrated model first.
    let mut values: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut points: Vec<Result<Vec<ModelParams>, String>> = vec![Ok(starts.to_vec())];
    for (k, knob) in knobs.iter().enumerate() {
        for v in screen_points(knob, starts) {
            points.push(with_knob(starts, knob, &v));
            values.push((k, v));
        }
    }
    let runnable: Vec<Vec<ModelParams>> = points.iter().filter_map(|p| p.as_ref().ok().cloned()).collect();
    progress(&TwinEvent::Screening {
        knobs: knobs.len(),
        runs: runnable.len() * seeds.len(),
    });
    let mut scored = closed.score(&runnable, seeds, names).into_iter();
    let scores: Vec<PointScore> = points
        .iter()
        .map(|p| match p {
            Ok(_) => scored.next().expect("one score per runnable point"),
            Err(e) => PointScore {
                loss: None,
                seed_losses: vec![None; seeds.len()],
                terms: Vec::new(),
                error: Some(e.clone()),
            },
        })
        .collect();
    let start = scores[0].clone();
    let screens: Vec<KnobScreen> = knobs
        .iter()
        .enumerate()
        .map(|(k, knob)| {
            let mine: Vec<(&Vec<f64>, &PointScore)> = values
                .iter()
                .zip(&scores[1..])
                .filter(|((kk, _), _)| *kk == k)
                .map(|((_, v), s)| (v, s))
                .collect();
            knob_screen(knob, &mine, &start)
        })
        .collect();
    for s in &screens {
        progress(&TwinEvent::KnobScreened { screen: s });
    }
    Screening {
        seeds: seeds.to_vec(),
        start,
        knobs: screens,
        runs: runnable.len() * seeds.len(),
    }
}

/// One knob's points, its best, its gain and the terms it moves there.
fn knob_screen(knob: &Knob, mine: &[(&Vec<f64>, &PointScore)], start: &PointScore) -> KnobScreen {
    let best = mine
        .iter()
        .enumerate()
        .filter_map(|(i, (_, s))| s.loss.map(|l| (i, l)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let gain = match (best, start.loss) {
        (Some(i), Some(l0)) => l0 - mine[i].1.loss.unwrap_or(f64::INFINITY),
        _ => f64::NEG_INFINITY,
    };
    let term_change = best.map_or_else(Vec::new, |i| {
        start
            .terms
            .iter()
            .map(|(n, v)| (n.clone(), term(mine[i].1, n) - v))
            .collect()
    });
    KnobScreen {
        knob: knob.info(),
        points: mine
            .iter()
            .map(|(v, s)| ScreenPoint {
                values: v.to_vec(),
                loss: s.loss,
                error: s.error.clone(),
            })
            .collect(),
        best,
        gain,
        term_change,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_calibration::params::{Param, ParamSpec};
    use drive_sim_model::robot::Robot;
    use drive_sim_model::terrain::Terrain;

    fn start() -> ModelParams {
        let robot = Robot::resolve("warthog").unwrap().0;
        let terrain = Terrain::resolve("asphalt").unwrap().0;
        ModelParams::new(robot, terrain)
    }

    fn knob(specs: Vec<ParamSpec>) -> Knob {
        Knob {
            name: "k".into(),
            specs,
            terrain_side: false,
        }
    }

    #[test]
    fn points_sit_an_eighth_and_a_thirty_second_of_the_box_either_side_of_the_calibrated_value() {
        let m = start();
        let peak = m.terrain.friction.peak_longitudinal;
        let p = screen_points(
            &knob(vec![ParamSpec::new(
                Param::PeakLongitudinal,
                peak - 0.5,
                peak + 0.5,
            )]),
            std::slice::from_ref(&m),
        );
        assert!((p[0][0] - (peak + 0.125)).abs() < 1e-12, "{p:?}");
        assert!((p[1][0] - (peak - 0.125)).abs() < 1e-12, "{p:?}");
        // The inner pair: a thirty-second of the box either side.
        assert!((p[2][0] - (peak + 0.03125)).abs() < 1e-12, "{p:?}");
        assert!((p[3][0] - (peak - 0.03125)).abs() < 1e-12, "{p:?}");
        // At the lower bound both points step inwards.
        let p = screen_points(
            &knob(vec![ParamSpec::new(Param::PeakLongitudinal, peak, peak + 1.0)]),
            std::slice::from_ref(&m),
        );
        assert!(
            (p[0][0] - (peak + 0.125)).abs() < 1e-12 && (p[1][0] - (peak + 0.25)).abs() < 1e-12,
            "{p:?}"
        );
        assert!(
            (p[2][0] - (peak + 0.03125)).abs() < 1e-12 && (p[3][0] - (peak + 0.0625)).abs() < 1e-12,
            "{p:?}"
        );
        // An effect the model does not run starts from its neutral value (dead time 0), and a
        // second parameter moves the other way at each point.
        let dead = Param::effect_param("dead_time_s").unwrap();
        let p = screen_points(
            &knob(vec![
                ParamSpec::new(dead, 0.0, 0.8),
                ParamSpec::new(Param::PeakLongitudinal, peak - 0.5, peak + 0.5),
            ]),
            std::slice::from_ref(&m),
        );
        assert!(
            (p[0][0] - 0.1).abs() < 1e-12 && (p[1][0] - 0.2).abs() < 1e-12,
            "{p:?}"
        );
        assert!(
            (p[0][1] - (peak - 0.125)).abs() < 1e-12 && (p[1][1] - (peak + 0.125)).abs() < 1e-12,
            "{p:?}"
        );
    }

    #[test]
    fn a_value_outside_the_box_or_unlike_between_grounds_takes_the_quarters() {
        let m = start();
        let peak = m.terrain.friction.peak_longitudinal;
        let outside = knob(vec![ParamSpec::new(
            Param::PeakLongitudinal,
            peak + 1.0,
            peak + 2.0,
        )]);
        let p = screen_points(&outside, std::slice::from_ref(&m));
        assert!(
            (p[0][0] - (peak + 1.25)).abs() < 1e-12 && (p[1][0] - (peak + 1.75)).abs() < 1e-12,
            "{p:?}"
        );
        // Then two of the eighths.
        assert!(
            (p[2][0] - (peak + 1.125)).abs() < 1e-12 && (p[3][0] - (peak + 1.625)).abs() < 1e-12,
            "{p:?}"
        );
        let mut other = m.clone();
        other.terrain.friction.peak_longitudinal = peak + 0.1;
        let inside = knob(vec![ParamSpec::new(
            Param::PeakLongitudinal,
            peak - 1.0,
            peak + 1.0,
        )]);
        let p = screen_points(&inside, &[m, other]);
        assert!(
            (p[0][0] - (peak - 0.5)).abs() < 1e-12 && (p[1][0] - (peak + 0.5)).abs() < 1e-12,
            "{p:?}"
        );
    }
}
