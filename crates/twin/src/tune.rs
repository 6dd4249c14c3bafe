//! The chosen knobs tuned together in closed loop, then the choice checked on fresh seeds.
//!
//! The search is `tune`'s: a Halton design over the knobs' box and a Nelder–Mead simplex from
//! its best point, every point run on the same seeds ([`drive_sim_compare::tune::search`]). It
//! starts from each knob's best screening point. A robot knob is one coordinate shared by
//! every ground; a ground's knob is one coordinate per ground. The check runs the model the
//! search started from (the calibrated one, or in a pass's second round the twin the first
//! tuned) and the choice on seeds the search never used, paired by seed, and keeps the choice
//! only when its loss reduction exceeds twice its standard error
//! ([`drive_sim_compare::tune::check_rule`]); otherwise the twin stays the model it started
//! from.

use crate::closed::Closed;
use crate::event::TwinEvent;
use crate::knobs::Knob;
use crate::screen::{knob_values, Screening};
use drive_sim_calibration::params::ParamSpec;
use drive_sim_calibration::ModelParams;
use drive_sim_compare::tune::search::{self, SearchOptions, SearchSummary};
use drive_sim_compare::tune::{check_rule, SeedCheck};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;

/// One tuned value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TunedValue {
    /// The parameter's key (`speed_droop_rad_s_per_knm`, `terrain.friction.peak_lateral`).
    pub name: String,
    /// Its knob.
    pub knob: String,
    /// The ground it is tuned for (`None`: the robot's, shared by every ground).
    pub ground: Option<String>,
    /// Unit.
    pub unit: String,
    /// The search box.
    pub lower: f64,
    /// The search box.
    pub upper: f64,
    /// The calibrated model's value (infinity for a limit that is off).
    pub calibrated: f64,
    /// The chosen value (the twin's when the check accepted the choice).
    pub chosen: f64,
    /// The choice lies on its box's edge: a stand-in for something else, or a box too small.
    pub at_bound: bool,
    /// The range of this value over the search's points whose loss lies within twice the
    /// check's standard error of the best: how far the value can move for a loss the check
    /// cannot tell from the best's (a set of the search's own points, not a confidence
    /// interval; `None` without a standard error).
    pub near_best: Option<[f64; 2]>,
    /// The values whose loss, on a quadratic fitted to the search's points nearest the best,
    /// lies within twice the check's standard error of the surface's minimum: the profile
    /// interval of the full quadratic (the other tuned values minimised over), or, where that
    /// one has no minimum, the interval of the quadratic without cross terms
    /// ([`drive_sim_calibration::surface`]; which one: `interval_fit`); clamped to the box.
    /// `None`: the surface has no minimum along this value (the closed loop does not pin it),
    /// too few points, or no standard error.
    #[serde(default)]
    pub interval: Option<[f64; 2]>,
    /// Which quadratic `interval` was read from (`None` when no surface could be fitted).
    #[serde(default)]
    pub interval_fit: Option<drive_sim_calibration::surface::SurfaceFit>,
}

/// One point the search evaluated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluated {
    /// Every coordinate's value, in its unit.
    pub values: Vec<f64>,
    /// Mean loss over the search's seeds (`None`: a run failed).
    pub loss: Option<f64>,
}

/// What the tuning did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tuning {
    /// The search's seeds.
    pub seeds: Vec<u64>,
    /// The tuned values.
    pub values: Vec<TunedValue>,
    /// The start model's loss on the search's seeds (the calibrated model's in a first round).
    pub start_loss: Option<f64>,
    /// The best point's.
    pub chosen_loss: f64,
    /// Where the search stopped.
    pub search: SearchSummary,
    /// The check on fresh seeds.
    pub check: SeedCheck,
    /// The check accepted the choice: the twin has the tuned values.
    pub accepted: bool,
    /// Every point, in order.
    pub evaluated: Vec<Evaluated>,
}

/// One coordinate of the search.
struct Coordinate {
    spec: ParamSpec,
    knob: String,
    /// `None`: every ground.
    ground: Option<usize>,
}

/// The search's coordinates: a robot knob once, a ground's knob once per ground.
struct Space {
    coords: Vec<Coordinate>,
}

impl Space {
    fn new(knobs: &[&Knob], grounds: usize) -> Self {
        let mut coords = Vec::new();
        for k in knobs {
            for s in &k.specs {
                if k.terrain_side && grounds > 1 {
                    coords.extend((0..grounds).map(|g| Coordinate {
                        spec: *s,
                        knob: k.name.clone(),
                        ground: Some(g),
                    }));
                } else {
                    coords.push(Coordinate {
                        spec: *s,
                        knob: k.name.clone(),
                        ground: None,
                    });
                }
            }
        }
        Self { coords }
    }

    fn to_x(&self, z: &[f64]) -> Vec<f64> {
        self.coords
            .iter()
            .zip(z)
            .map(|(c, z)| c.spec.lower + z * (c.spec.upper - c.spec.lower))
            .collect()
    }

    /// Every ground's model with the coordinates at `x`.
    fn models_at(&self, starts: &[ModelParams], x: &[f64]) -> Result<Vec<ModelParams>, String> {
        starts
            .iter()
            .enumerate()
            .map(|(g, m)| {
                let (specs, values): (Vec<ParamSpec>, Vec<f64>) = self
                    .coords
                    .iter()
                    .zip(x)
                    .filter(|(c, _)| c.ground.is_none_or(|h| h == g))
                    .map(|(c, v)| (c.spec, *v))
                    .unzip();
                m.with_values(&specs, &values).map_err(|e| e.to_string())
            })
            .collect()
    }
}

/// What [`tune`] works on.
pub(crate) struct TuneInput<'a> {
    pub(crate) closed: &'a Closed<'a>,
    /// The model of each ground the search starts from (calibrated, or the first round's twin).
    pub(crate) starts: &'a [ModelParams],
    /// The knobs the rule chose, from the pool.
    pub(crate) knobs: Vec<&'a Knob>,
    pub(crate) screening: &'a Screening,
    /// Grounds' names.
    pub(crate) names: &'a [String],
    pub(crate) seeds: &'a [u64],
    pub(crate) check_seeds: &'a [u64],
    pub(crate) max_evaluations: usize,
}

/// Tunes the chosen knobs (see the module doc); returns the tuning and the twin's models (the
/// choice when the check accepted it, else the calibrated models).
pub(crate) fn tune(input: &TuneInput, progress: &(dyn Fn(&TwinEvent) + Sync)) -> (Tuning, Vec<ModelParams>) {
    let space = Space::new(&input.knobs, input.starts.len());
    let z0 = start_point(input, &space);
    let start = input
        .closed
        .score(&[input.starts.to_vec()], input.seeds, input.names);
    let evaluated: RefCell<Vec<Evaluated>> = RefCell::new(Vec::new());
    let cost_many = |zs: &[Vec<f64>]| -> Vec<Option<f64>> {
        let xs: Vec<Vec<f64>> = zs.iter().map(|z| space.to_x(z)).collect();
        let models: Vec<Result<Vec<ModelParams>, String>> =
            xs.iter().map(|x| space.models_at(input.starts, x)).collect();
        let runnable: Vec<Vec<ModelParams>> =
            models.iter().filter_map(|m| m.as_ref().ok().cloned()).collect();
        let mut scores = input
            .closed
            .score(&runnable, input.seeds, input.names)
            .into_iter();
        let mut out = Vec::new();
        let mut ev = evaluated.borrow_mut();
        for (x, m) in xs.into_iter().zip(&models) {
            let loss = m.as_ref().ok().and_then(|_| scores.next().and_then(|s| s.loss));
            ev.push(Evaluated { values: x, loss });
            let best = ev.iter().filter_map(|e| e.loss).fold(f64::INFINITY, f64::min);
            progress(&TwinEvent::Point {
                index: ev.len(),
                loss,
                best,
            });
            out.push(loss);
        }
        out
    };
    let opts = SearchOptions {
        max_evaluations: input.max_evaluations,
        ..SearchOptions::default()
    };
    let (z_best, chosen_loss, summary) = search::minimise(&z0, &opts, &cost_many);
    let x_best = space.to_x(&z_best);
    let chosen = space
        .models_at(input.starts, &x_best)
        .unwrap_or_else(|_| input.starts.to_vec());
    let same = chosen.as_slice() == input.starts;
    let checked = input.closed.score(
        &[input.starts.to_vec(), chosen.clone()],
        input.check_seeds,
        input.names,
    );
    let check = check_rule(
        input.check_seeds.to_vec(),
        checked[0].seed_losses.clone(),
        checked[1].seed_losses.clone(),
        same,
    );
    progress(&TwinEvent::Checked { check: &check });
    let evaluated = evaluated.into_inner();
    let values = tuned_values(&space, input, &x_best, &evaluated, chosen_loss, check.se);
    let accepted = check.accepted;
    let twin = if accepted { chosen } else { input.starts.to_vec() };
    (
        Tuning {
            seeds: input.seeds.to_vec(),
            values,
            start_loss: start[0].loss,
            chosen_loss,
            search: summary,
            check,
            accepted,
            evaluated,
        },
        twin,
    )
}

/// The search's start in the unit box: each knob at its best screening point (the middle of
/// the box when none of its points ran).
fn start_point(input: &TuneInput, space: &Space) -> Vec<f64> {
    space
        .coords
        .iter()
        .map(|c| {
            let screen = input.screening.knobs.iter().find(|k| k.knob.name == c.knob);
            let knob = input.knobs.iter().find(|k| k.name == c.knob);
            let j = knob.and_then(|k| k.specs.iter().position(|s| s.param == c.spec.param));
            let value = match (screen.and_then(|s| s.best.map(|b| &s.points[b])), j) {
                (Some(p), Some(j)) => p.values[j],
                _ => knob_values(knob.expect("a coordinate's knob"), &[0.5; 8])[j.unwrap_or(0)],
            };
            ((value - c.spec.lower) / (c.spec.upper - c.spec.lower)).clamp(0.0, 1.0)
        })
        .collect()
}

/// Each coordinate's calibrated and chosen value, and its near-best range.
fn tuned_values(
    space: &Space,
    input: &TuneInput,
    x_best: &[f64],
    evaluated: &[Evaluated],
    best: f64,
    se: f64,
) -> Vec<TunedValue> {
    let near: Vec<&Evaluated> = evaluated
        .iter()
        .filter(|e| se.is_finite() && e.loss.is_some_and(|l| l <= best + 2.0 * se))
        .collect();
    let to_z = |x: &[f64]| -> Vec<f64> {
        space
            .coords
            .iter()
            .zip(x)
            .map(|(c, v)| (v - c.spec.lower) / (c.spec.upper - c.spec.lower))
            .collect()
    };
    let points: Vec<(Vec<f64>, f64)> = evaluated
        .iter()
        .filter_map(|e| e.loss.map(|l| (to_z(&e.values), l)))
        .collect();
    let intervals = drive_sim_calibration::surface::profile_intervals(&points, &to_z(x_best), 2.0 * se);
    space
        .coords
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let g = c.ground.unwrap_or(0);
            let range = (!near.is_empty()).then(|| {
                let vs = near.iter().map(|e| e.values[i]);
                [
                    vs.clone().fold(f64::INFINITY, f64::min),
                    vs.fold(f64::NEG_INFINITY, f64::max),
                ]
            });
            TunedValue {
                name: c.spec.param.key(),
                knob: c.knob.clone(),
                ground: c.ground.map(|g| input.names[g].clone()),
                unit: c.spec.param.unit().to_string(),
                lower: c.spec.lower,
                upper: c.spec.upper,
                calibrated: c.spec.param.get(&input.starts[g]),
                chosen: x_best[i],
                at_bound: c.spec.at_bound(x_best[i]),
                near_best: range,
                interval: intervals.as_ref().and_then(|iv| iv.intervals[i]).map(|[a, b]| {
                    let (lo, width) = (c.spec.lower, c.spec.upper - c.spec.lower);
                    [lo + a * width, lo + b * width]
                }),
                interval_fit: intervals.as_ref().map(|iv| iv.fit),
            }
        })
        .collect()
}
