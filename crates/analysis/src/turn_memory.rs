//! Turn memory: how far a loaded wheel falls short of its command, by what the previous DRIVE
//! step asked of it.
//!
//! **Why.** A skid-steered robot's turn loads its wheels: the outer side pushes, the inner side
//! brakes, and the sign of that torque flips with the turn's direction. A speed loop with only
//! a proportional part gives way by the same amount whatever came before (one shortfall per
//! command, the simulator's `speed_droop`). A loop with an integral wins the shortfall back over
//! seconds and keeps what it learnt into the next step: a turn after a turn the same way starts
//! with its torque already learnt and tracks well; a turn after a turn the other way starts from
//! the opposite torque, falls further short and is still gaining speed in the steady windows.
//! On the measured Warthog asphalt run the difference is three-fold (6 % against 20 % in the
//! first steady window); the tuned twins without an integral show less. This module measures it
//! so that a simulated and a measured run can be compared on it (`droop_recovery` is the effect
//! that gives it).
//!
//! **Definitions.** A step is a *turn* when its commanded wheel speeds differ by at least
//! [`TURN_MIN_RAD_S`]. Its *previous turn* is the difference of the measured wheel speeds at
//! its first sample, what the robot was doing when the step began (the previous step's end, or
//! the operator's manoeuvre between steps): *same* way (differences of one sign, the previous at
//! least [`PREVIOUS_TURN_MIN_RAD_S`]), *reversed*, or *from straight* (a smaller difference).
//! Measured, not read from the previous step's command, so that a half of a run (`--real-steps
//! odd`), which holds no step's predecessor, has a memory too.
//! Every wheel of a turn commanded at least [`WHEEL_MIN_RAD_S`] contributes its *shortfall* in
//! the first steady window, `1 − w₁/u` (0 on target, positive short of it), and its *gain* to
//! the second, `(w₂ − w₁)·sign(u)` in rad/s (a wheel still speeding up gains).
//!
//! **Statistic and interval.** The headline is the median shortfall after a reversed turn minus
//! the median after a same-way turn. Its interval is a bootstrap by step, two-sample: each
//! class's steps are resampled on their own (both wheels of a step together), the difference of
//! medians recomputed, the percentile interval taken ([`super::bootstrap`]). With fewer than
//! [`MIN_STEPS_PER_CLASS`] steps in either class there is no headline.

use super::bootstrap::{Bootstrap, Interval};
use super::scatter::StepWheels;
use super::stats::median;
use serde::{Deserialize, Serialize};

/// Smallest commanded wheel-speed difference of a turn, rad/s: the measured Warthog runs'
/// turns below it load the wheels too little for a shortfall to stand out of the window noise.
pub const TURN_MIN_RAD_S: f64 = 6.0;

/// Smallest wheel-speed difference of the previous step for it to count as a turn one way or
/// the other, rad/s; below it the previous step drove (nearly) straight.
pub const PREVIOUS_TURN_MIN_RAD_S: f64 = 2.0;

/// Smallest commanded speed of a wheel whose shortfall counts, rad/s: a fraction of a slower
/// command is mostly window noise.
pub const WHEEL_MIN_RAD_S: f64 = 3.0;

/// A wheel gaining more than this between its steady windows, rad/s, is counted as still
/// speeding up (twice the largest within-step scatter of the measured Warthog runs).
pub const GAINING_RAD_S: f64 = 0.5;

/// Fewer steps than this in the same-way or the reversed class and no headline is reported.
pub const MIN_STEPS_PER_CLASS: usize = 5;

/// Bootstrap streams of the two classes, apart from every other draw of the same seed.
const STREAM_SAME: u64 = 0x7E3A;
const STREAM_REVERSED: u64 = 0x7E3B;

/// The wheels of one class of turns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TurnClass {
    /// Turns in the class.
    pub steps: usize,
    /// Their wheels commanded at least [`WHEEL_MIN_RAD_S`].
    pub wheels: usize,
    /// Median shortfall in the first steady window, `1 − w₁/u` (fraction of the command).
    pub shortfall: Option<f64>,
    /// Median gain from the first steady window to the second, rad/s.
    pub gain_rad_s: Option<f64>,
    /// Wheels gaining more than [`GAINING_RAD_S`].
    pub wheels_gaining: usize,
}

/// How a run's loaded wheels track, by the previous step's turn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TurnMemory {
    /// Turns after a turn the same way.
    pub same: TurnClass,
    /// Turns after a turn the other way.
    pub reversed: TurnClass,
    /// Turns after a (nearly) straight step.
    pub from_straight: TurnClass,
    /// Median shortfall after a reversed turn minus after a same-way turn; `None` with fewer
    /// than [`MIN_STEPS_PER_CLASS`] steps in either.
    pub reversed_minus_same: Option<f64>,
    /// Two-sample bootstrap-by-step percentile interval of [`TurnMemory::reversed_minus_same`].
    pub ci95: Option<Interval>,
}

/// Which way the previous step turned, relative to this one.
#[derive(Clone, Copy, PartialEq)]
enum Previous {
    Same,
    Reversed,
    Straight,
}

/// One wheel's (shortfall, gain).
type Wheel = (f64, f64);

/// The wheels of each turn, by class: one entry per step (in step order, so that the
/// bootstrap's draws do not depend on the input's), its wheels together.
fn classify(steps: &[StepWheels]) -> [Vec<Vec<Wheel>>; 3] {
    let mut sorted: Vec<&StepWheels> = steps.iter().collect();
    sorted.sort_by_key(|s| s.step);
    let mut out: [Vec<Vec<Wheel>>; 3] = Default::default();
    for s in &sorted {
        let turn = s.cmd_rad_s[0] - s.cmd_rad_s[1];
        let before = s.start_rad_s[0] - s.start_rad_s[1];
        if !turn.is_finite() || turn.abs() < TURN_MIN_RAD_S || !before.is_finite() {
            continue;
        }
        let class = if before.abs() < PREVIOUS_TURN_MIN_RAD_S {
            Previous::Straight
        } else if before * turn > 0.0 {
            Previous::Same
        } else {
            Previous::Reversed
        };
        let (Some(w1), Some(w2)) = (s.window(1), s.window(2)) else {
            continue;
        };
        let wheels: Vec<Wheel> = (0..2)
            .filter(|&k| s.cmd_rad_s[k].abs() >= WHEEL_MIN_RAD_S)
            .map(|k| {
                let u = s.cmd_rad_s[k];
                (1.0 - w1[k] / u, (w2[k] - w1[k]) * u.signum())
            })
            .collect();
        if wheels.is_empty() {
            continue;
        }
        let i = match class {
            Previous::Same => 0,
            Previous::Reversed => 1,
            Previous::Straight => 2,
        };
        out[i].push(wheels);
    }
    out
}

fn class_of(steps: &[Vec<Wheel>]) -> TurnClass {
    let wheels: Vec<Wheel> = steps.iter().flatten().copied().collect();
    let of = |f: fn(&Wheel) -> f64| {
        (!wheels.is_empty()).then(|| median(&wheels.iter().map(f).collect::<Vec<_>>()))
    };
    TurnClass {
        steps: steps.len(),
        wheels: wheels.len(),
        shortfall: of(|w| w.0),
        gain_rad_s: of(|w| w.1),
        wheels_gaining: wheels.iter().filter(|w| w.1 > GAINING_RAD_S).count(),
    }
}

fn median_shortfall(steps: &[Vec<Wheel>], idx: &mut dyn Iterator<Item = usize>) -> f64 {
    let v: Vec<f64> = idx.flat_map(|i| steps[i].iter().map(|w| w.0)).collect();
    median(&v)
}

/// [`turn_memory_with`] with the project's bootstrap (2000 resamples, its seed).
pub fn turn_memory(steps: &[StepWheels]) -> TurnMemory {
    turn_memory_with(steps, &Bootstrap::default())
}

/// The turn memory of `steps` with its interval drawn by `boot`. Steps without a finite command
/// or without steady windows 1 and 2 take no part.
pub fn turn_memory_with(steps: &[StepWheels], boot: &Bootstrap) -> TurnMemory {
    let [same, reversed, straight] = classify(steps);
    let (reversed_minus_same, ci95) =
        if same.len() >= MIN_STEPS_PER_CLASS && reversed.len() >= MIN_STEPS_PER_CLASS {
            let estimate = median_shortfall(&reversed, &mut (0..reversed.len()))
                - median_shortfall(&same, &mut (0..same.len()));
            let ds = boot.draws(same.len(), STREAM_SAME);
            let dr = boot.draws(reversed.len(), STREAM_REVERSED);
            let stats: Vec<f64> = dr
                .iter()
                .zip(&ds)
                .map(|(r, s)| {
                    median_shortfall(&reversed, &mut r.iter().copied())
                        - median_shortfall(&same, &mut s.iter().copied())
                })
                .collect();
            (Some(estimate), boot.interval(&stats))
        } else {
            (None, None)
        };
    TurnMemory {
        same: class_of(&same),
        reversed: class_of(&reversed),
        from_straight: class_of(&straight),
        reversed_minus_same,
        ci95,
    }
}

impl std::fmt::Display for TurnMemory {
    /// One line for a person: `turn memory: loaded wheels fall short by 20 % (gaining 0.87 rad/s,
    /// 20 wheels) after a turn the other way, 6 % (gaining 0.13 rad/s, 28 wheels) after one the
    /// same way; difference +0.14 (95 % [+0.09, +0.21], bootstrap by step)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let class = |c: &TurnClass| match (c.shortfall, c.gain_rad_s) {
            (Some(s), Some(g)) => format!("{:.0} % (gaining {g:.2} rad/s, {} wheels)", 100.0 * s, c.wheels),
            _ => format!("- ({} wheels)", c.wheels),
        };
        write!(
            f,
            "turn memory: loaded wheels fall short by {} after a turn the other way, {} after one the same way",
            class(&self.reversed),
            class(&self.same)
        )?;
        match (self.reversed_minus_same, self.ci95) {
            (Some(d), Some(i)) => write!(
                f,
                "; difference {d:+.2} ({:.0} % [{:+.2}, {:+.2}], bootstrap by step)",
                i.level * 100.0,
                i.lower,
                i.upper
            ),
            (Some(d), None) => write!(f, "; difference {d:+.2}"),
            _ => write!(
                f,
                "; no difference (fewer than {MIN_STEPS_PER_CLASS} turns in a class: {} same way, {} reversed)",
                self.same.steps, self.reversed.steps
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// A synthetic run independent of the simulator: commands uniform in [-15, 15]² rad/s, each
    /// wheel's steady windows at `u (1 − s)` plus noise N(0, 0.2²), where the shortfall `s` of a
    /// turn is `a` after a turn the same way and `b` after any other step, the second window
    /// recovering `g` of it. `a = b`, `g = 0` is a loop without memory.
    fn synthetic(n: u32, a: f64, b: f64, g: f64, seed: u64) -> Vec<StepWheels> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut prev = [0.0, 0.0];
        let mut end = [0.0, 0.0];
        (0..n)
            .map(|step| {
                let cmd: [f64; 2] = [rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0)];
                let (turn, before) = (cmd[0] - cmd[1], prev[0] - prev[1]);
                let s = if turn.abs() < TURN_MIN_RAD_S {
                    0.0
                } else if turn * before > 0.0 && f64::abs(before) >= PREVIOUS_TURN_MIN_RAD_S {
                    a
                } else {
                    b
                };
                prev = cmd;
                let mut noise = || 0.2 * rng.sample::<f64, _>(StandardNormal);
                let w1 = [0, 1].map(|k| cmd[k] * (1.0 - s) + noise());
                let w2 = [0, 1].map(|k| cmd[k] * (1.0 - s * (1.0 - g)) + noise());
                // The step begins where the previous one ended.
                let start_rad_s = std::mem::replace(&mut end, w2);
                StepWheels {
                    step,
                    cmd_rad_s: cmd,
                    steady_windows: vec![(1, w1), (2, w2)],
                    start_rad_s,
                }
            })
            .collect()
    }

    #[test]
    fn a_loop_with_memory_is_found_and_one_without_is_not() {
        let m = turn_memory(&synthetic(150, 0.05, 0.20, 0.5, 3));
        let d = m.reversed_minus_same.unwrap();
        let i = m.ci95.unwrap();
        assert!((d - 0.15).abs() < 0.03, "{m}");
        assert!(i.lower > 0.05 && i.contains(0.15), "{m}");
        assert!(
            m.reversed.gain_rad_s.unwrap() > 0.3 && m.same.gain_rad_s.unwrap() < 0.3,
            "{m}"
        );
        assert!(m.to_string().contains("bootstrap by step"), "{m}");
        // The null case: one shortfall whatever came before; the interval holds zero.
        let null = turn_memory(&synthetic(150, 0.12, 0.12, 0.0, 3));
        let i = null.ci95.unwrap();
        assert!(i.contains(0.0), "{null}");
        assert!(null.reversed_minus_same.unwrap().abs() < 0.03, "{null}");
        assert!(null.reversed.gain_rad_s.unwrap().abs() < 0.1, "{null}");
    }

    #[test]
    fn classes_follow_the_wheels_at_the_start_and_few_turns_give_no_headline() {
        // Each step starts with the wheel speeds `start` (its predecessor's end, whether or not
        // that step is among these).
        let w = |step, cmd: [f64; 2], start: [f64; 2]| StepWheels {
            step,
            cmd_rad_s: cmd,
            steady_windows: vec![
                (1, [cmd[0] * 0.9, cmd[1] * 0.9]),
                (2, [cmd[0] * 0.95, cmd[1] * 0.95]),
            ],
            start_rad_s: start,
        };
        let steps = vec![
            w(0, [5.0, -5.0], [0.0, 0.0]),   // from straight (rest)
            w(1, [6.0, -4.0], [4.8, -4.7]),  // same way
            w(2, [-5.0, 5.0], [5.7, -3.8]),  // reversed
            w(3, [8.0, 8.0], [-4.8, 4.7]),   // straight: not a turn
            w(5, [-4.0, 4.0], [-1.0, -9.0]), // reversed (step 4 is in the other half)
        ];
        let m = turn_memory(&steps);
        assert_eq!((m.same.steps, m.reversed.steps, m.from_straight.steps), (1, 2, 1));
        assert_eq!(m.same.wheels, 2);
        assert!((m.same.shortfall.unwrap() - 0.1).abs() < 1e-12);
        assert!((m.same.gain_rad_s.unwrap() - 0.25).abs() < 1e-12, "{m}");
        assert!(m.reversed_minus_same.is_none() && m.ci95.is_none());
        assert!(m.to_string().contains("fewer than 5 turns"), "{m}");
    }
}
