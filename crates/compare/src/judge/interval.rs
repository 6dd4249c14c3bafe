//! Intervals for a twin's parameters by inverting the judge: the values of one parameter at
//! which `compare` cannot tell the real run from the twin's own runs.
//!
//! A closed-loop search (`drive-sim tune`) gives a value and no interval: its loss is a sum
//! of scaled differences, not a likelihood, and a Jacobian of a simulated DRIVE run is noise.
//! The judge, though, is a test with a known size: under "the real robot is this model", its
//! Monte Carlo p-value is uniform on `{1, ..., M + 1} / (M + 1)`. Inverting it (Neyman) gives
//! a confidence set: the parameter values θ with `p(θ) > alpha` form a set that covers the
//! true value with probability at least `1 - alpha`, whatever the loss's distribution.
//!
//! What it is and is not:
//! - **A slice.** One parameter moves; the others stay at the twin's values. Where two
//!   parameters trade off (a stiffer motor against a larger droop), the joint set is wider
//!   than this slice, and the slice says only how far this one can move alone.
//! - **Found by a walk.** From the twin's value the walk steps outwards by `box / 8`, doubling
//!   the step, until a value is rejected or the box's end is accepted; then `refine`
//!   bisections of the last gap. The bounds reported are the outermost accepted values, with
//!   the bracket to the first rejected one. A set with holes (the p-value is a Monte Carlo
//!   estimate) is reported by its outer bounds along the walk.
//! - **Common random numbers.** Every value is judged with the same seeds (runs and
//!   references), so `p(θ)` changes with θ and not with the draw.
//!
//! A twin whose own value is rejected (`p ≤ alpha`) has an empty set: nothing is walked.

use super::{judge, JudgeOutcome, JudgeRequest};
use crate::error::{Error, Result};
use crate::tune::{apply_boxes, tuned_specs, BoxOverride};
use drive_sim_calibration::params::ParamSpec;
use drive_sim_calibration::ModelParams;
use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use serde::{Deserialize, Serialize};

/// Options of [`intervals`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IntervalOptions {
    /// Bisections of the gap between the last accepted and the first rejected value.
    pub refine: u32,
    /// Largest number of judgements per side of one parameter (steps and bisections).
    pub max_per_side: u32,
}

impl Default for IntervalOptions {
    fn default() -> Self {
        Self {
            refine: 3,
            max_per_side: 8,
        }
    }
}

impl IntervalOptions {
    /// Checks the numbers before any run.
    pub fn validate(&self) -> Result<()> {
        if self.refine > 10 {
            return Err(Error::config(
                "<command line>",
                "--interval-refine",
                format!("must be in 0..=10, got {}", self.refine),
            ));
        }
        if !(2..=30).contains(&self.max_per_side) {
            return Err(Error::config(
                "<command line>",
                "--interval-max-per-side",
                format!("must be in 2..=30, got {}", self.max_per_side),
            ));
        }
        Ok(())
    }
}

/// One judged value of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// The parameter's value.
    pub value: f64,
    /// The loss's Monte Carlo p-value there.
    pub p: f64,
    /// Mean loss of the runs against the real run there.
    pub real_loss: f64,
    /// `p > alpha`: in the set.
    pub accepted: bool,
}

/// One end of a set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bound {
    /// The outermost accepted value on this side.
    pub value: f64,
    /// The first rejected value beyond it (`None`: the box's end was accepted).
    pub rejected_at: Option<f64>,
}

impl Bound {
    /// The set reaches the end of the box on this side: the data do not bound it there.
    pub fn at_box(&self) -> bool {
        self.rejected_at.is_none()
    }
}

/// The set of one parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamInterval {
    /// The parameter's key (`speed_droop_rad_s_per_knm`) or base name.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// The twin's value.
    pub value: f64,
    /// The box walked (the registry's search box for this log).
    pub box_lower: f64,
    /// Upper end of the box.
    pub box_upper: f64,
    /// Confidence level, `1 - alpha`.
    pub level: f64,
    /// Lower end (`None`: the twin's own value is rejected, the set is empty).
    pub lower: Option<Bound>,
    /// Upper end.
    pub upper: Option<Bound>,
    /// Every judged value, in the order judged.
    pub evaluations: Vec<Evaluation>,
    /// How the set was found, in words.
    pub method: String,
}

impl ParamInterval {
    /// The comment a twin file carries for this value: the set and how it was found.
    pub fn comment(&self, dataset: &str, steps: &str) -> String {
        let level = (self.level * 100.0).round();
        match (&self.lower, &self.upper) {
            (Some(lo), Some(hi)) => {
                let end = |b: &Bound, box_end: f64| {
                    if b.at_box() {
                        format!("{} (box)", short(box_end))
                    } else {
                        short(b.value)
                    }
                };
                format!(
                    "{level:.0} % set [{}, {}] on `{dataset}` ({steps} steps): inverted judge, the others fixed",
                    end(lo, self.box_lower),
                    end(hi, self.box_upper)
                )
            }
            _ => format!(
                "no {level:.0} % set: `{dataset}` ({steps} steps) tells the twin at this value apart (p ≤ {:.2})",
                1.0 - self.level
            ),
        }
    }
}

/// A number in 4 significant digits.
pub fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// `tune`'s errors for its `--tune` and `--box` as this walk's `--interval` and
/// `--interval-box` (the parameters and boxes are resolved by the same code).
fn as_interval_option(e: Error) -> Error {
    match e {
        Error::Model(drive_sim_model::Error::Config { file, field, message }) => {
            let option = match file.to_str() {
                Some("--tune") => "--interval".into(),
                Some("--box") => "--interval-box".into(),
                _ => file,
            };
            Error::config(option, field, message.replace("tuned", "walked"))
        }
        other => other,
    }
}

/// The boxes of `--interval-box KEY=LOWER:UPPER` (parsed before any log is read).
pub fn parse_boxes(texts: &[String]) -> Result<Vec<BoxOverride>> {
    texts
        .iter()
        .map(|b| BoxOverride::parse(b).map_err(as_interval_option))
        .collect()
}

/// The parameters `names` names (effect names, effect parameter keys or simulator base
/// parameters, as `tune --tune` takes them), with the registry's boxes for the commands of
/// `real` and the `boxes` given: checked before any run (an unknown name, a box that does not
/// hold the twin's value: a configuration error naming `--interval` or `--interval-box`).
pub fn interval_specs(
    names: &[String],
    boxes: &[BoxOverride],
    model: &ModelParams,
    real: &DriveLog,
) -> Result<Vec<ParamSpec>> {
    let rename = as_interval_option;
    let reach = CommandReach::of_commands(real.samples.iter().map(|s| s.m.cmd), &model.robot.idd());
    let mut specs = tuned_specs(names, model, &reach).map_err(rename)?;
    apply_boxes(&mut specs, boxes).map_err(rename)?;
    for spec in &specs {
        let value = spec.param.get(model);
        if !(value.is_finite() && spec.lower <= value && value <= spec.upper) {
            return Err(Error::config(
                "--interval",
                spec.param.key(),
                format!(
                    "the twin's value {value} is not in the box [{}, {}] (a parameter the twin leaves off, or a box that misses it: `--interval-box KEY=LOWER:UPPER`)",
                    spec.lower, spec.upper
                ),
            ));
        }
    }
    Ok(specs)
}

/// What [`intervals`] walks.
#[derive(Debug, Clone, Copy)]
pub struct IntervalRequest<'a> {
    /// The real log, the twin and the judge's options, as for [`judge`].
    pub judge: JudgeRequest<'a>,
    /// The twin's own judgement (with the same options): the centre of every walk.
    pub centre: &'a JudgeOutcome,
    /// The parameters, with the boxes to walk in.
    pub specs: &'a [ParamSpec],
    /// The walk.
    pub opts: &'a IntervalOptions,
}

/// What [`intervals`] tells its caller as it goes. `Display` gives the line `drive-sim judge
/// --interval` prints (after its clock).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IntervalEvent<'a> {
    /// The walks start (each value is judged as the twin was).
    Walking {
        /// Parameters walked, one after the other.
        parameters: usize,
    },
    /// One value of a parameter judged.
    Judged {
        /// The parameter's key or base name.
        parameter: &'a str,
        /// The judgement at that value.
        evaluation: Evaluation,
    },
}

impl std::fmt::Display for IntervalEvent<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IntervalEvent::Walking { parameters } => write!(
                f,
                "interval: walking {parameters} parameter(s), each value judged as above"
            ),
            IntervalEvent::Judged {
                parameter,
                evaluation: e,
            } => write!(
                f,
                "interval {parameter}: {} -> p {:.3}, mean loss {:.2}: {}",
                short(e.value),
                e.p,
                e.real_loss,
                if e.accepted { "in the set" } else { "rejected" }
            ),
        }
    }
}

/// The set of each parameter of `req.specs` for the twin (see the module doc). `progress`
/// hears when the walks start and of each judged value.
pub fn intervals(
    req: &IntervalRequest,
    progress: &(dyn Fn(&IntervalEvent) + Sync),
) -> Result<Vec<ParamInterval>> {
    req.opts.validate()?;
    if !req.specs.is_empty() {
        progress(&IntervalEvent::Walking {
            parameters: req.specs.len(),
        });
    }
    req.specs
        .iter()
        .map(|spec| interval_of(req, spec, progress))
        .collect()
}

/// The set of one parameter: walks down and up from the twin's value when the twin itself is
/// accepted.
fn interval_of(
    req: &IntervalRequest,
    spec: &ParamSpec,
    progress: &(dyn Fn(&IntervalEvent) + Sync),
) -> Result<ParamInterval> {
    let (iopts, opts, model, real) = (req.opts, req.judge.opts, req.judge.model, req.judge.real);
    let name = spec.param.key();
    let value = spec.param.get(model);
    // The twin's own value: its judgement is the centre's.
    let centre = Evaluation {
        value,
        p: req.centre.loss.p,
        real_loss: req.centre.loss.real,
        accepted: req.centre.indistinguishable,
    };
    let mut evaluations: Vec<Evaluation> = vec![centre];
    let mut eval = |v: f64| -> Result<Evaluation> {
        let m = model.with_values(std::slice::from_ref(spec), &[v])?;
        let o: JudgeOutcome = judge(
            &JudgeRequest {
                real,
                model: &m,
                opts,
            },
            &|_| {},
        )?;
        let e = Evaluation {
            value: v,
            p: o.loss.p,
            real_loss: o.loss.real,
            accepted: o.indistinguishable,
        };
        progress(&IntervalEvent::Judged {
            parameter: &name,
            evaluation: e,
        });
        evaluations.push(e);
        Ok(e)
    };
    let (lower, upper) = if centre.accepted {
        let step = (spec.upper - spec.lower) / 8.0;
        let lo = walk(value, spec.lower, -step, iopts, &mut eval)?;
        let hi = walk(value, spec.upper, step, iopts, &mut eval)?;
        (Some(lo), Some(hi))
    } else {
        (None, None)
    };
    Ok(ParamInterval {
        name,
        unit: spec.param.unit().to_string(),
        value,
        box_lower: spec.lower,
        box_upper: spec.upper,
        level: 1.0 - opts.alpha,
        lower,
        upper,
        evaluations,
        method: format!(
            "inverted Monte Carlo test (judge: {} runs, {} references, seeds from {}), the other parameters at the twin's values; walk by box/8 doubling, {} bisections",
            opts.sims, opts.references, opts.seed, iopts.refine
        ),
    })
}

/// Walks from the accepted `from` towards `end` (the box's end) by `step` (signed), doubling,
/// until a value is rejected or `end` is accepted; then bisects the gap.
fn walk(
    from: f64,
    end: f64,
    step: f64,
    iopts: &IntervalOptions,
    eval: &mut dyn FnMut(f64) -> Result<Evaluation>,
) -> Result<Bound> {
    let beyond = |v: f64| if step > 0.0 { v >= end } else { v <= end };
    let mut accepted = from;
    let mut h = step;
    let mut used = 0;
    let mut rejected = loop {
        if beyond(accepted) || used >= iopts.max_per_side {
            return Ok(Bound {
                value: accepted,
                rejected_at: None,
            });
        }
        let next = if beyond(accepted + h) { end } else { accepted + h };
        used += 1;
        if eval(next)?.accepted {
            accepted = next;
            h *= 2.0;
        } else {
            break next;
        }
    };
    for _ in 0..iopts.refine {
        if used >= iopts.max_per_side {
            break;
        }
        let mid = 0.5 * (accepted + rejected);
        used += 1;
        if eval(mid)?.accepted {
            accepted = mid;
        } else {
            rejected = mid;
        }
    }
    Ok(Bound {
        value: accepted,
        rejected_at: Some(rejected),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk on a known acceptance region [2, 5.3] from 3 in the box [0, 8]: steps of 1
    /// (box / 8) doubling, then bisections; the bounds bracket the region's ends.
    #[test]
    fn walk_brackets_the_region() {
        let opts = IntervalOptions {
            refine: 4,
            max_per_side: 12,
        };
        let mut seen = Vec::new();
        let mut eval = |v: f64| -> Result<Evaluation> {
            seen.push(v);
            Ok(Evaluation {
                value: v,
                p: 0.5,
                real_loss: 1.0,
                accepted: (2.0..=5.3).contains(&v),
            })
        };
        let hi = walk(3.0, 8.0, 1.0, &opts, &mut eval).unwrap();
        // 4 accepted, 6 rejected; bisections 5 (in), 5.5 (out), 5.25 (in), 5.375 (out).
        assert_eq!(hi.value, 5.25);
        assert_eq!(hi.rejected_at, Some(5.375));
        let lo = walk(3.0, 0.0, -1.0, &opts, &mut eval).unwrap();
        // 2 accepted, 0 rejected; bisections 1 (out), 1.5 (out), 1.75 (out), 1.875 (out).
        assert_eq!(lo.value, 2.0);
        assert_eq!(lo.rejected_at, Some(1.875));
    }

    /// A region that covers the box's end is reported as reaching it, with no rejection.
    #[test]
    fn walk_reaches_the_box() {
        let opts = IntervalOptions::default();
        let mut eval = |v: f64| -> Result<Evaluation> {
            Ok(Evaluation {
                value: v,
                p: 0.5,
                real_loss: 1.0,
                accepted: true,
            })
        };
        let hi = walk(3.0, 8.0, 1.0, &opts, &mut eval).unwrap();
        assert_eq!(hi.value, 8.0);
        assert!(hi.at_box());
    }

    /// The budget stops the walk: never more judgements per side than asked.
    #[test]
    fn walk_keeps_its_budget() {
        let opts = IntervalOptions {
            refine: 10,
            max_per_side: 3,
        };
        let mut n = 0;
        let mut eval = |v: f64| -> Result<Evaluation> {
            n += 1;
            Ok(Evaluation {
                value: v,
                p: 0.5,
                real_loss: 1.0,
                accepted: v < 3.5,
            })
        };
        walk(3.0, 8.0, 0.1, &opts, &mut eval).unwrap();
        assert!(n <= 3, "{n} judgements");
    }

    /// The lines are the ones `drive-sim judge --interval` has always printed.
    #[test]
    fn events_display_as_the_printed_lines() {
        assert_eq!(
            IntervalEvent::Walking { parameters: 1 }.to_string(),
            "interval: walking 1 parameter(s), each value judged as above"
        );
        let judged = IntervalEvent::Judged {
            parameter: "wheel_speed_saturation_rad_s",
            evaluation: Evaluation {
                value: 11.04468,
                p: 0.2,
                real_loss: 13.7512,
                accepted: true,
            },
        };
        assert_eq!(
            judged.to_string(),
            "interval wheel_speed_saturation_rad_s: 11.04 -> p 0.200, mean loss 13.75: in the set"
        );
    }

    #[test]
    fn comment_names_the_set_and_the_box() {
        let i = ParamInterval {
            name: "speed_droop_rad_s_per_knm".into(),
            unit: "rad/s per kN·m".into(),
            value: 1.0,
            box_lower: 0.0,
            box_upper: 6.0,
            level: 0.95,
            lower: Some(Bound {
                value: 0.0,
                rejected_at: None,
            }),
            upper: Some(Bound {
                value: 2.3456,
                rejected_at: Some(2.5),
            }),
            evaluations: Vec::new(),
            method: String::new(),
        };
        let c = i.comment("warthog_asphalt", "all");
        assert!(c.contains("95 % set [0 (box), 2.346]"), "{c}");
        let empty = ParamInterval {
            lower: None,
            upper: None,
            ..i
        };
        assert!(empty.comment("d", "odd").starts_with("no 95 % set"));
    }
}
