//! From the role topics of a bag to the common [`DriveLog`]: decoding, step segmentation,
//! resampling onto the analysis clock, and the checks that exclude a step.
//!
//! Steps come from the protocol's step index and state when the bag has them: an *attempt* is
//! a run of messages with one step index while the state is `calib` (an interruption sends the
//! node back to `idle`, and the step restarts from zero elapsed time). Without them, an attempt
//! is a run of one constant non-zero command, a new command value starts a new step, and the
//! same command again after a stop is a new attempt of the same step. An attempt that lasts a
//! whole step is the step's completed one; earlier attempts are interruptions.
//!
//! Every signal is resampled onto the analysis clock, `rate_hz` ticks from the start of the
//! completed attempt: the command by zero-order hold, the others by linear interpolation
//! (angles along the shorter arc). A role topic silent for longer than its gap limit inside a
//! step excludes the step, with a warning naming the step, the topic and the time.

mod attempts;
mod resample;

use attempts::{attempts_by_step, find_attempts, interruptions_before};
pub use attempts::{Attempt, Segmentation};

use super::roles::{Assigned, Role, RoleMap};
use crate::cdr::CdrError;
use crate::ros_msgs::{
    Float64, Imu, Int32, JointState, Odometry, RosMessage, StringMsg, Twist, TwistStamped,
};
use crate::{DriveLog, ImuReading, LogMeta, Pose};
use drive_sim_model::error::{Error, Result};
use std::path::Path;

/// Decoded role signals, each sorted by receive time (ns).
#[derive(Debug, Default, Clone)]
pub struct Signals {
    /// Body command (vx m/s, wz rad/s).
    pub cmd: Vec<(u64, [f64; 2])>,
    /// Left wheel speed, rad/s.
    pub left: Vec<(u64, f64)>,
    /// Right wheel speed, rad/s.
    pub right: Vec<(u64, f64)>,
    /// Odometry pose and the source's own twist (vx, vy, wz; NaN when absent).
    pub odom: Vec<(u64, Pose, [f64; 3])>,
    /// IMU; empty without one (the samples' IMU readings are then NaN).
    pub imu: Vec<(u64, ImuReading)>,
    /// Step index.
    pub step: Vec<(u64, i32)>,
    /// State.
    pub state: Vec<(u64, String)>,
}

fn t_s(ns: u64, t0: u64) -> f64 {
    (ns as f64 - t0 as f64) * 1e-9
}

/// Decodes the role topics of one bag.
pub fn decode(bag: &super::storage::Bag, roles: &RoleMap) -> Result<(Signals, u64)> {
    let order: Vec<(Role, &Assigned)> = roles.roles.iter().map(|(r, a)| (*r, a)).collect();
    let topics: Vec<&str> = order.iter().map(|(_, a)| a.topic.as_str()).collect();
    let mut s = Signals::default();
    let mut counts = vec![0u64; order.len()];
    let mut t0: Option<u64> = None;
    bag.read(&topics, &mut |i, t, data| {
        let (role, a) = order[i];
        let idx = counts[i];
        counts[i] += 1;
        let first = *t0.get_or_insert(t);
        let de = |e: CdrError| {
            Error::log(
                &bag.path,
                format!("topic {} message {idx} (t = {:.3} s)", a.topic, t_s(t, first)),
                format!("does not decode as {}: {e}", a.msg_type),
            )
        };
        match role {
            Role::Cmd => {
                let tw = if a.msg_type.ends_with("TwistStamped") {
                    TwistStamped::from_cdr(data).map_err(de)?.twist
                } else {
                    Twist::from_cdr(data).map_err(de)?
                };
                s.cmd.push((t, [tw.linear.x, tw.angular.z]));
            }
            Role::WheelLeft | Role::WheelRight => {
                let v = if a.msg_type.ends_with("JointState") {
                    let j = JointState::from_cdr(data).map_err(de)?;
                    joint_speed(&j, role, a.joint.as_deref())
                        .map_err(|m| Error::log(&bag.path, format!("topic {} message {idx}", a.topic), m))?
                } else {
                    Float64::from_cdr(data).map_err(de)?.data
                };
                if role == Role::WheelLeft {
                    s.left.push((t, v));
                } else {
                    s.right.push((t, v));
                }
            }
            Role::Odom => {
                let o = Odometry::from_cdr(data).map_err(de)?;
                let pose = crate::mcap::convert::pose_of(&o, &bag.path, &a.topic, idx, t)?;
                let tw = o.twist.twist;
                s.odom.push((t, pose, [tw.linear.x, tw.linear.y, tw.angular.z]));
            }
            Role::Imu => {
                let m = Imu::from_cdr(data).map_err(de)?;
                s.imu.push((
                    t,
                    ImuReading {
                        wz_rad_s: m.angular_velocity.z,
                        ax_m_s2: m.linear_acceleration.x,
                        ay_m_s2: m.linear_acceleration.y,
                        az_m_s2: m.linear_acceleration.z,
                    },
                ));
            }
            Role::Step => s.step.push((t, Int32::from_cdr(data).map_err(de)?.data)),
            Role::State => s.state.push((t, StringMsg::from_cdr(data).map_err(de)?.data)),
        }
        Ok(())
    })?;
    // Files are read in order and each in time order; a split bag may still interleave.
    s.cmd.sort_by_key(|x| x.0);
    s.left.sort_by_key(|x| x.0);
    s.right.sort_by_key(|x| x.0);
    s.odom.sort_by_key(|x| x.0);
    s.imu.sort_by_key(|x| x.0);
    s.step.sort_by_key(|x| x.0);
    s.state.sort_by_key(|x| x.0);
    for (i, (role, a)) in order.iter().enumerate() {
        if counts[i] == 0 && role.required() {
            return Err(Error::log(
                &bag.path,
                format!("topic {}", a.topic),
                format!("no message: role `{}` needs {}", role.key(), a.msg_type),
            ));
        }
    }
    let t0 = t0.ok_or_else(|| Error::log(&bag.path, "role topics", "no message on any role topic"))?;
    Ok((s, t0))
}

fn joint_speed(j: &JointState, role: Role, joint: Option<&str>) -> std::result::Result<f64, String> {
    if j.velocity.len() != j.name.len() {
        return Err(format!(
            "{} names but {} velocities",
            j.name.len(),
            j.velocity.len()
        ));
    }
    let side = if role == Role::WheelLeft { "left" } else { "right" };
    let picked: Vec<f64> = j
        .name
        .iter()
        .zip(&j.velocity)
        .filter(|(n, _)| match joint {
            Some(want) => n.as_str() == want,
            None => n.to_lowercase().contains(side),
        })
        .map(|(_, v)| *v)
        .collect();
    if picked.is_empty() {
        return Err(format!(
            "no joint {} in {:?}",
            joint.map_or(format!("named like `{side}`"), |w| format!("`{w}`")),
            j.name
        ));
    }
    // Several wheels per side (skid steer): their mean.
    Ok(picked.iter().sum::<f64>() / picked.len() as f64)
}

/// Median interval between messages, s.
fn median_period(ts: &[u64]) -> f64 {
    let mut d: Vec<f64> = ts.windows(2).map(|w| (w[1] - w[0]) as f64 * 1e-9).collect();
    if d.is_empty() {
        return f64::INFINITY;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// What [`build_log`] produced besides the log.
#[derive(Debug, Clone, Default)]
pub struct BuildReport {
    /// Steps excluded, and why (step, topic, time).
    pub warnings: Vec<String>,
    /// How steps were found.
    pub segmentation: Option<Segmentation>,
}

/// Longest silence of a role topic inside a step before the step is excluded: five of its
/// median periods, and never less than 0.25 s (5 ticks at 20 Hz).
pub fn gap_limit_s(period_s: f64) -> f64 {
    (5.0 * period_s).max(0.25)
}

/// The analysis clock of a log: ticks per window and per step, and their lengths.
#[derive(Debug, Clone, Copy)]
struct StepClock {
    /// Ticks per second.
    rate_hz: f64,
    /// Ticks per window.
    samples_per_window: u64,
    /// Ticks per step.
    n_ticks: u64,
    /// Tick length, ns.
    tick_ns: f64,
    /// Step length, ns.
    step_ns: f64,
}

impl StepClock {
    fn of(meta: &LogMeta) -> Self {
        let rate_hz = meta.rate_hz;
        let samples_per_window = meta.samples_per_window as u64;
        Self {
            rate_hz,
            samples_per_window,
            n_ticks: samples_per_window * meta.windows_per_step as u64,
            tick_ns: 1e9 / rate_hz,
            step_ns: meta.step_s() * 1e9,
        }
    }

    /// Whether attempt `a` lasts a whole step.
    fn completes(&self, a: &Attempt) -> bool {
        // An attempt of n_ticks messages spans (n_ticks - 1) ticks; allow half a tick of jitter.
        (a.end_ns - a.start_ns) as f64 >= self.step_ns - 1.5 * self.tick_ns
    }

    /// Time of the last tick of a step whose first tick is at `start` (ns).
    fn step_end(&self, start: f64) -> f64 {
        start + (self.n_ticks - 1) as f64 * self.tick_ns
    }
}

/// The longest silence of a topic (message times `ts`, ns) over a step's ticks `start..=end`
/// that exceeds `limit` (s): its length (s) and start (ns).
fn worst_gap(ts: &[u64], start: f64, end: f64, limit: f64, tick_ns: f64) -> Option<(f64, f64)> {
    let lo = ts.partition_point(|&t| (t as f64) < start);
    let hi = ts.partition_point(|&t| (t as f64) <= end);
    // Messages bracketing the step count too: interpolation uses them.
    let from = lo.saturating_sub(1);
    let to = (hi + 1).min(ts.len());
    let mut prev = if from < lo { ts[from] as f64 } else { f64::NAN };
    let mut worst: Option<(f64, f64)> = None;
    let mut check = |a: f64, b: f64| {
        let g = (b - a) * 1e-9;
        if g > limit && worst.is_none_or(|w| g > w.0) {
            worst = Some((g, a));
        }
    };
    if prev.is_nan() {
        let first = ts.get(lo).map_or(f64::INFINITY, |&t| t as f64);
        check(start, first.min(end + tick_ns));
        prev = first;
    }
    for &t in &ts[lo..to] {
        if (t as f64) > prev {
            check(prev, t as f64);
        }
        prev = t as f64;
    }
    if prev < end {
        check(prev, end);
    }
    worst
}

/// Message times of the role topics every step needs, with each topic's gap limit.
struct RoleTimes {
    /// Receive times (ns) per role; a bag without IMU messages has no IMU series.
    series: Vec<(Role, Vec<u64>)>,
    /// [`gap_limit_s`] of each series, s.
    limits: Vec<f64>,
}

impl RoleTimes {
    fn of(s: &Signals) -> Self {
        let mut series: Vec<(Role, Vec<u64>)> = vec![
            (Role::Cmd, s.cmd.iter().map(|x| x.0).collect()),
            (Role::WheelLeft, s.left.iter().map(|x| x.0).collect()),
            (Role::WheelRight, s.right.iter().map(|x| x.0).collect()),
            (Role::Odom, s.odom.iter().map(|x| x.0).collect()),
        ];
        if !s.imu.is_empty() {
            series.push((Role::Imu, s.imu.iter().map(|x| x.0).collect()));
        }
        let limits = series
            .iter()
            .map(|(_, ts)| gap_limit_s(median_period(ts)))
            .collect();
        Self { series, limits }
    }
}

/// What every step of [`build_log`] shares: the signals, the log's clock and where it came
/// from (for messages).
struct Assembly<'a> {
    /// Decoded role signals.
    s: &'a Signals,
    /// First receive time, ns: t = 0 of the log.
    t0: u64,
    /// The log's metadata (step length, nominal model).
    meta: &'a LogMeta,
    /// Role topics, to name them in messages.
    roles: &'a RoleMap,
    /// The bag, for errors.
    file: &'a Path,
    /// The analysis clock.
    clock: StepClock,
    /// Message times and gap limits of the role topics.
    times: RoleTimes,
}

impl Assembly<'_> {
    /// The topic of role `r`, `?` when unassigned.
    fn topic(&self, r: Role) -> &str {
        self.roles.roles.get(&r).map_or("?", |a| a.topic.as_str())
    }

    /// Why `step` is excluded when none of its attempts `atts` lasts a whole step.
    fn not_completed(&self, step: u32, atts: &[Attempt]) -> String {
        let longest = atts.iter().map(|a| t_s(a.end_ns, a.start_ns)).fold(0.0, f64::max);
        format!(
            "step {step}: excluded: not completed (longest of {} attempt(s) {longest:.2} s, a step is {:.2} s), \
             from t = {:.2} s",
            atts.len(),
            self.meta.step_s(),
            t_s(atts[0].start_ns, self.t0)
        )
    }

    /// Why `step` (first tick at `start`, ns) is excluded when a role topic is silent longer
    /// than its limit within the step: the first such topic, at its longest silence.
    fn gap_exclusion(&self, step: u32, start: f64) -> Option<String> {
        let end = self.clock.step_end(start);
        self.times
            .series
            .iter()
            .zip(&self.times.limits)
            .find_map(|((role, ts), limit)| {
                let (g, at) = worst_gap(ts, start, end, *limit, self.clock.tick_ns)?;
                Some(format!(
                    "step {step}: excluded: topic {} has no message for {g:.2} s from t = {:.2} s \
                     (expected one every {:.3} s; a gap of more than {limit:.2} s breaks a step)",
                    self.topic(*role),
                    (at - self.t0 as f64) * 1e-9,
                    median_period(ts)
                ))
            })
    }

    /// The error when no step is left: why none was found, or why each was excluded.
    fn no_complete_step(&self, seg: Segmentation, warnings: &[String]) -> Error {
        let why = if warnings.is_empty() {
            match seg {
                Segmentation::StepTopic => format!("no attempt found on {}", self.topic(Role::Step)),
                Segmentation::CommandConstancy => {
                    format!("no run of constant non-zero command on {}", self.topic(Role::Cmd))
                }
            }
        } else {
            format!("every step was excluded: {}", warnings.join("; "))
        };
        Error::log(self.file, "steps", format!("no complete step ({why})"))
    }
}

/// Length of the log, s: from the first attempt to the last command, step or pose message,
/// plus one tick.
fn duration_s(s: &Signals, attempts: &[Attempt], t0: u64, rate_hz: f64) -> f64 {
    let last = [
        s.cmd.last().map(|x| x.0),
        s.step.last().map(|x| x.0),
        s.odom.last().map(|x| x.0),
    ]
    .into_iter()
    .flatten()
    .max()
    .unwrap_or(t0);
    let first = attempts.first().map_or(t0, |a| a.start_ns);
    t_s(last, first) + 1.0 / rate_hz
}

/// Segments, resamples and checks; builds the log.
pub fn build_log(
    s: &Signals,
    t0: u64,
    meta: LogMeta,
    roles: &RoleMap,
    file: &Path,
) -> Result<(DriveLog, BuildReport)> {
    let clock = StepClock::of(&meta);
    let (attempts, seg) = find_attempts(s, &clock);
    let mut report = BuildReport {
        segmentation: Some(seg),
        ..BuildReport::default()
    };
    let asm = Assembly {
        s,
        t0,
        meta: &meta,
        roles,
        file,
        clock,
        times: RoleTimes::of(s),
    };
    let mut samples = Vec::new();
    let mut interruptions = Vec::new();
    for (step, atts) in &attempts_by_step(&attempts) {
        let Some(done) = atts.iter().rev().find(|a| clock.completes(a)).copied() else {
            report.warnings.push(asm.not_completed(*step, atts));
            continue;
        };
        interruptions.extend(interruptions_before(*step, atts, done.attempt, t0));
        if let Some(w) = asm.gap_exclusion(*step, done.start_ns as f64) {
            report.warnings.push(w);
            continue;
        }
        samples.extend(asm.resample_step(*step, &done)?);
    }
    if samples.is_empty() {
        return Err(asm.no_complete_step(seg, &report.warnings));
    }
    let duration_s = duration_s(s, &attempts, t0, clock.rate_hz);
    Ok((
        DriveLog {
            meta,
            samples,
            interruptions,
            duration_s,
        },
        report,
    ))
}
