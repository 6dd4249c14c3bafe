//! Attempts and steps from the signals: from the protocol's step index and state when the bag
//! has them, else from runs of constant command (see the parent module).

use super::{t_s, Signals, StepClock};
use crate::Interruption;
use std::collections::BTreeMap;

/// One attempt of a step: a run of the step's command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attempt {
    /// Step index.
    pub step: u32,
    /// Attempt index, from 0.
    pub attempt: u32,
    /// First tick, ns.
    pub start_ns: u64,
    /// Last tick, ns.
    pub end_ns: u64,
    /// Last message of the step's command, ns: the command is held no later than this.
    pub cmd_until_ns: u64,
}

/// How steps were found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segmentation {
    /// From the step index (and state) topics.
    StepTopic,
    /// From runs of constant command.
    CommandConstancy,
}

/// Attempts from the step index, active while the state (if recorded) is `calib`.
fn attempts_from_step_topic(s: &Signals) -> Vec<Attempt> {
    let mut out: Vec<Attempt> = Vec::new();
    let mut state_i = 0usize;
    let mut cur: Option<(i32, u64, u64)> = None;
    let mut attempts_of: BTreeMap<i32, u32> = BTreeMap::new();
    let mut close = |cur: &mut Option<(i32, u64, u64)>, out: &mut Vec<Attempt>| {
        if let Some((step, a, b)) = cur.take() {
            if step >= 0 {
                let n = attempts_of.entry(step).or_insert(0);
                out.push(Attempt {
                    step: step as u32,
                    attempt: *n,
                    start_ns: a,
                    end_ns: b,
                    cmd_until_ns: b,
                });
                *n += 1;
            }
        }
    };
    for &(t, step) in &s.step {
        while state_i + 1 < s.state.len() && s.state[state_i + 1].0 <= t {
            state_i += 1;
        }
        let active = s.state.is_empty() || (s.state[state_i].0 <= t && s.state[state_i].1 == "calib");
        match (&mut cur, active) {
            (Some((st, _, b)), true) if *st == step => *b = t,
            (_, true) => {
                close(&mut cur, &mut out);
                cur = Some((step, t, t));
            }
            (_, false) => close(&mut cur, &mut out),
        }
    }
    close(&mut cur, &mut out);
    out
}

/// Attempts from runs of constant command, for a step of `step_ns` at ticks of `tick_ns`.
///
/// A run of one non-zero command lasting k step lengths is k steps (the protocol may draw the
/// same command twice in a row); a shorter one is an attempt, interrupted, and the same command
/// again after a stop is the next attempt of that step. A zero command is a stop, except a
/// zero run between two steps that lasts a whole number of step lengths to the tick: the
/// protocol drew a zero command (an operator's stop is not timed to the tick).
fn attempts_from_command(s: &Signals, step_ns: f64, tick_ns: f64) -> Vec<Attempt> {
    const TOL: f64 = 1e-9;
    let same = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() <= TOL && (a[1] - b[1]).abs() <= TOL;
    // (command, first tick, last tick)
    let mut runs: Vec<([f64; 2], u64, u64)> = Vec::new();
    for &(t, c) in &s.cmd {
        match runs.last_mut() {
            Some((rc, _, b)) if same(*rc, c) => *b = t,
            _ => runs.push((c, t, t)),
        }
    }
    let is_zero = |c: [f64; 2]| c[0].abs() <= TOL && c[1].abs() <= TOL;
    let mut out: Vec<Attempt> = Vec::new();
    let mut step: i64 = -1;
    // Command of the last attempt, and whether it was interrupted (so the next equal run is its
    // next attempt).
    let mut last: Option<([f64; 2], bool)> = None;
    let mut attempt = 0u32;
    for (i, &(c, a, b)) in runs.iter().enumerate() {
        let d = (b - a) as f64 + tick_ns;
        // A tick short still counts: a log may carry the previous command on a step's first tick.
        let n = ((d + 1.5 * tick_ns) / step_ns).floor() as u64;
        if is_zero(c) {
            let inner = i > 0 && i + 1 < runs.len();
            let whole = n >= 1 && (d - n as f64 * step_ns).abs() <= 1.5 * tick_ns;
            if !(inner && whole) {
                continue;
            }
        }
        let ticks = (step_ns / tick_ns).round() as u64;
        let chunk = |k: u64| {
            let start = a + (k as f64 * step_ns).round() as u64;
            (start, start + ((ticks - 1) as f64 * tick_ns).round() as u64)
        };
        if n == 0 {
            if last.is_some_and(|(l, interrupted)| interrupted && same(l, c)) {
                attempt += 1;
            } else {
                step += 1;
                attempt = 0;
            }
            out.push(Attempt {
                step: step as u32,
                attempt,
                start_ns: a,
                end_ns: b,
                cmd_until_ns: b,
            });
            last = Some((c, true));
            continue;
        }
        for k in 0..n {
            let continues = k == 0 && last.is_some_and(|(l, interrupted)| interrupted && same(l, c));
            if continues {
                attempt += 1;
            } else {
                step += 1;
                attempt = 0;
            }
            let (start_ns, end_ns) = chunk(k);
            out.push(Attempt {
                step: step as u32,
                attempt,
                start_ns,
                end_ns,
                cmd_until_ns: end_ns.min(b),
            });
        }
        last = Some((c, false));
    }
    out
}

/// The attempts of the signals, and how they were found: from the step topic when the bag
/// has one, else from runs of constant command.
pub(super) fn find_attempts(s: &Signals, clock: &StepClock) -> (Vec<Attempt>, Segmentation) {
    if !s.step.is_empty() {
        (attempts_from_step_topic(s), Segmentation::StepTopic)
    } else {
        (
            attempts_from_command(s, clock.step_ns, clock.tick_ns),
            Segmentation::CommandConstancy,
        )
    }
}

/// The attempts of each step, in step order.
pub(super) fn attempts_by_step(attempts: &[Attempt]) -> BTreeMap<u32, Vec<Attempt>> {
    let mut by_step: BTreeMap<u32, Vec<Attempt>> = BTreeMap::new();
    for a in attempts {
        by_step.entry(a.step).or_default().push(*a);
    }
    by_step
}

/// The interruptions of `step`: its attempts before the completed one (`done`), each lasting
/// until the next attempt starts.
pub(super) fn interruptions_before(step: u32, atts: &[Attempt], done: u32, t0: u64) -> Vec<Interruption> {
    atts.iter()
        .filter(|a| a.attempt < done)
        .map(|a| {
            let next = atts
                .iter()
                .find(|b| b.attempt == a.attempt + 1)
                .map_or(a.end_ns, |b| b.start_ns);
            Interruption {
                step,
                attempt: a.attempt,
                t_in_step_s: t_s(a.end_ns, a.start_ns),
                stamp_s: t_s(a.end_ns, t0),
                time_lost_s: t_s(next, a.start_ns),
            }
        })
        .collect()
}
