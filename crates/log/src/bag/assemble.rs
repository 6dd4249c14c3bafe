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

use super::roles::{Assigned, Role, RoleMap};
use crate::cdr::CdrError;
use crate::ros_msgs::{
    Float64, Imu, Int32, JointState, Odometry, RosMessage, StringMsg, Twist, TwistStamped,
};
use crate::{DriveLog, ImuReading, Interruption, LogMeta, Measurement, Pose, Sample};
use drive_sim_model::error::{Error, Result};
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};
use std::collections::BTreeMap;
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
    /// IMU.
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

/// Linear interpolation of `xs` (sorted by time) at `t`; `None` outside the span.
fn interp<T: Copy>(xs: &[(u64, T)], t: f64, lerp: impl Fn(T, T, f64) -> T) -> Option<T> {
    let i = xs.partition_point(|x| (x.0 as f64) <= t);
    if i == 0 {
        return None;
    }
    let (t0, a) = xs[i - 1];
    if (t0 as f64) == t || i == xs.len() {
        return ((t0 as f64) == t).then_some(a);
    }
    let (t1, b) = xs[i];
    let u = (t - t0 as f64) / (t1 as f64 - t0 as f64);
    Some(lerp(a, b, u))
}

fn lerp(a: f64, b: f64, u: f64) -> f64 {
    a + (b - a) * u
}

fn lerp_angle(a: f64, b: f64, u: f64) -> f64 {
    let d = (b - a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    drive_sim_model::geometry::wrap_angle(a + d * u)
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

/// Segments, resamples and checks; builds the log.
pub fn build_log(
    s: &Signals,
    t0: u64,
    meta: LogMeta,
    roles: &RoleMap,
    file: &Path,
) -> Result<(DriveLog, BuildReport)> {
    let mut report = BuildReport::default();
    let rate = meta.rate_hz;
    let spw = meta.samples_per_window as u64;
    let n_ticks = spw * meta.windows_per_step as u64;
    let tick_ns = 1e9 / rate;
    let step_ns = meta.step_s() * 1e9;
    let (attempts, seg) = if !s.step.is_empty() {
        (attempts_from_step_topic(s), Segmentation::StepTopic)
    } else {
        (
            attempts_from_command(s, step_ns, tick_ns),
            Segmentation::CommandConstancy,
        )
    };
    report.segmentation = Some(seg);
    // An attempt of n_ticks messages spans (n_ticks - 1) ticks; allow half a tick of jitter.
    let complete = |a: &Attempt| (a.end_ns - a.start_ns) as f64 >= step_ns - 1.5 * tick_ns;
    let topic = |r: Role| roles.roles.get(&r).map_or("?", |a| a.topic.as_str());
    type Times = Vec<u64>;
    let series: [(Role, Times); 5] = [
        (Role::Cmd, s.cmd.iter().map(|x| x.0).collect()),
        (Role::WheelLeft, s.left.iter().map(|x| x.0).collect()),
        (Role::WheelRight, s.right.iter().map(|x| x.0).collect()),
        (Role::Odom, s.odom.iter().map(|x| x.0).collect()),
        (Role::Imu, s.imu.iter().map(|x| x.0).collect()),
    ];
    let limits: Vec<f64> = series
        .iter()
        .map(|(_, ts)| gap_limit_s(median_period(ts)))
        .collect();

    let mut by_step: BTreeMap<u32, Vec<Attempt>> = BTreeMap::new();
    for a in &attempts {
        by_step.entry(a.step).or_default().push(*a);
    }
    let mut samples = Vec::new();
    let mut interruptions = Vec::new();
    for (step, atts) in &by_step {
        let Some(done) = atts.iter().rev().find(|a| complete(a)).copied() else {
            let longest = atts.iter().map(|a| t_s(a.end_ns, a.start_ns)).fold(0.0, f64::max);
            report.warnings.push(format!(
                "step {step}: excluded: not completed (longest of {} attempt(s) {longest:.2} s, a step is {:.2} s), \
                 from t = {:.2} s",
                atts.len(),
                meta.step_s(),
                t_s(atts[0].start_ns, t0)
            ));
            continue;
        };
        for a in atts.iter().filter(|a| a.attempt < done.attempt) {
            let next = atts
                .iter()
                .find(|b| b.attempt == a.attempt + 1)
                .map_or(a.end_ns, |b| b.start_ns);
            interruptions.push(Interruption {
                step: *step,
                attempt: a.attempt,
                t_in_step_s: t_s(a.end_ns, a.start_ns),
                stamp_s: t_s(a.end_ns, t0),
                time_lost_s: t_s(next, a.start_ns),
            });
        }
        let start = done.start_ns as f64;
        let end = start + (n_ticks - 1) as f64 * tick_ns;
        // Gaps: a role topic silent longer than its limit within [start, end].
        let mut excluded = None;
        for ((role, ts), limit) in series.iter().zip(&limits) {
            let lo = ts.partition_point(|&t| (t as f64) < start);
            let hi = ts.partition_point(|&t| (t as f64) <= end);
            // Messages bracketing the step count too: interpolation uses them.
            let from = lo.saturating_sub(1);
            let to = (hi + 1).min(ts.len());
            let mut prev = if from < lo { ts[from] as f64 } else { f64::NAN };
            let mut worst: Option<(f64, f64)> = None;
            let mut check = |a: f64, b: f64| {
                let g = (b - a) * 1e-9;
                if g > *limit && worst.is_none_or(|w| g > w.0) {
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
            if let Some((g, at)) = worst {
                excluded = Some(format!(
                    "step {step}: excluded: topic {} has no message for {g:.2} s from t = {:.2} s \
                     (expected one every {:.3} s; a gap of more than {limit:.2} s breaks a step)",
                    topic(*role),
                    (at - t0 as f64) * 1e-9,
                    median_period(ts)
                ));
                break;
            }
        }
        if let Some(w) = excluded {
            report.warnings.push(w);
            continue;
        }
        let idd = meta.nominal.idd();
        let mut step_samples = Vec::with_capacity(n_ticks as usize);
        for k in 0..n_ticks {
            let t = start + k as f64 * tick_ns;
            // Command: zero-order hold, looking half a tick ahead (it is published with the tick),
            // never past the attempt (a run one tick short must not take the next command).
            let tq = (t + 0.5 * tick_ns).min(done.cmd_until_ns as f64);
            let ci = s.cmd.partition_point(|x| (x.0 as f64) <= tq);
            let c = s.cmd[ci.saturating_sub(1)].1;
            let cmd = idd.wheels_from_body(BodyVelocity::new(c[0], 0.0, c[1]));
            let miss = |what: &str| {
                Error::log(
                    file,
                    format!("step {step} tick {k} (t = {:.3} s)", (t - t0 as f64) * 1e-9),
                    format!("no {what} to interpolate from"),
                )
            };
            let l = interp(&s.left, t, lerp).ok_or_else(|| miss(topic(Role::WheelLeft)))?;
            let r = interp(&s.right, t, lerp).ok_or_else(|| miss(topic(Role::WheelRight)))?;
            let oi = s.odom.partition_point(|x| (x.0 as f64) <= t);
            let (pose, tw) = if oi > 0 && (s.odom[oi - 1].0 as f64 == t || oi == s.odom.len()) {
                let (_, p, w) = s.odom[oi - 1];
                if s.odom[oi - 1].0 as f64 != t {
                    return Err(miss(topic(Role::Odom)));
                }
                (p, w)
            } else if oi > 0 {
                let (ta, pa, wa) = s.odom[oi - 1];
                let (tb, pb, wb) = s.odom[oi];
                let u = (t - ta as f64) / (tb as f64 - ta as f64);
                (
                    Pose {
                        x_m: lerp(pa.x_m, pb.x_m, u),
                        y_m: lerp(pa.y_m, pb.y_m, u),
                        z_m: lerp(pa.z_m, pb.z_m, u),
                        roll_rad: lerp_angle(pa.roll_rad, pb.roll_rad, u),
                        pitch_rad: lerp_angle(pa.pitch_rad, pb.pitch_rad, u),
                        yaw_rad: lerp_angle(pa.yaw_rad, pb.yaw_rad, u),
                    },
                    [
                        lerp(wa[0], wb[0], u),
                        lerp(wa[1], wb[1], u),
                        lerp(wa[2], wb[2], u),
                    ],
                )
            } else {
                return Err(miss(topic(Role::Odom)));
            };
            let imu = interp(&s.imu, t, |a: ImuReading, b: ImuReading, u| ImuReading {
                wz_rad_s: lerp(a.wz_rad_s, b.wz_rad_s, u),
                ax_m_s2: lerp(a.ax_m_s2, b.ax_m_s2, u),
                ay_m_s2: lerp(a.ay_m_s2, b.ay_m_s2, u),
                az_m_s2: lerp(a.az_m_s2, b.az_m_s2, u),
            })
            .ok_or_else(|| miss(topic(Role::Imu)))?;
            let reference = BodyVelocity::new(tw[0], tw[1], tw[2]);
            let m = Measurement {
                cmd,
                enc: WheelSpeeds::new(l, r),
                pose,
                imu,
                reference: reference.is_finite().then_some(reference),
                truth: None,
            };
            step_samples.push(Sample {
                step: *step,
                window: (k / spw) as u32,
                k: (k % spw) as u32,
                t_in_step_s: k as f64 / rate,
                stamp_s: (t - t0 as f64) * 1e-9,
                m,
            });
        }
        samples.extend(step_samples);
    }
    if samples.is_empty() {
        let why = if report.warnings.is_empty() {
            match seg {
                Segmentation::StepTopic => format!("no attempt found on {}", topic(Role::Step)),
                Segmentation::CommandConstancy => {
                    format!("no run of constant non-zero command on {}", topic(Role::Cmd))
                }
            }
        } else {
            format!("every step was excluded: {}", report.warnings.join("; "))
        };
        return Err(Error::log(file, "steps", format!("no complete step ({why})")));
    }
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
    let duration_s = t_s(last, first) + 1.0 / rate;
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
