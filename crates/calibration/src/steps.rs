//! The recorded steps a model is scored on: a log cut into steps, the measured state each
//! replayed step starts from, and the planar pose arithmetic both the estimators and the
//! replay use. Below [`super::metrics`] and [`super::replay`], which both read it.

use crate::error::{Error, Result};
use drive_sim_analysis::segment::{usable_steps, Exclusion, SegmentRules};
use drive_sim_analysis::stats::interquartile_mean;
use drive_sim_log::{held_command, DriveLog, Pose, Sample};
use drive_sim_model::effects::term::{PastStep, HISTORY_STEPS};
use drive_sim_model::effects::StepContext;
use drive_sim_model::geometry::wrap_angle;
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};

/// The samples of one completed step, in time order.
#[derive(Debug, Clone, Copy)]
pub struct StepSlice<'a> {
    /// Step index.
    pub step: u32,
    /// Its samples.
    pub samples: &'a [Sample],
}

/// Splits a log's samples into steps (they are stored ordered by step).
pub fn step_slices(log: &DriveLog) -> Vec<StepSlice<'_>> {
    log.samples
        .chunk_by(|a, b| a.step == b.step)
        .map(|s| StepSlice {
            step: s[0].step,
            samples: s,
        })
        .collect()
}

/// The steps a model is scored on: [`step_slices`] without the steps the analysis excludes
/// (incomplete, with a gap, a pose jump or a pose against its encoders:
/// [`drive_sim_analysis::segment::usable_steps`] with the default rules), and those with why.
/// A calibration must not fit what the analysis would not trust.
pub fn usable_step_slices(log: &DriveLog) -> (Vec<StepSlice<'_>>, Vec<Exclusion>) {
    let rules = SegmentRules::for_samples_per_window(log.meta.samples_per_window);
    let (keep, excluded) = usable_steps(log, &rules);
    let slices = step_slices(log)
        .into_iter()
        .filter(|s| keep.contains(&s.step))
        .collect();
    (slices, excluded)
}

/// Body-frame velocity between two poses `dt_s` apart: the displacement is rotated into the
/// frame at the mean heading, which makes a constant-(vx, wz) arc give vy = 0 exactly.
pub fn body_rate(p: &Pose, q: &Pose, dt_s: f64) -> [f64; 3] {
    let (dx, dy) = (q.x_m - p.x_m, q.y_m - p.y_m);
    let dyaw = wrap_angle(q.yaw_rad - p.yaw_rad);
    let (s, c) = (p.yaw_rad + dyaw / 2.0).sin_cos();
    [(c * dx + s * dy) / dt_s, (-s * dx + c * dy) / dt_s, dyaw / dt_s]
}

/// The measured state a replayed step starts from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepStart {
    /// Pose of the first sample.
    pub pose: Pose,
    /// Body velocity at the first sample: the source's reference estimate when it has one;
    /// else the previous step's steady end when this step follows it ([`step_start_in`]); else
    /// at rest when the wheels stand still, or the poses' slope at the start with the gyro's
    /// yaw rate ([`step_start`]). In the body frame.
    pub velocity: BodyVelocity,
    /// Encoder wheel speeds at the first sample: the previous step's steady end when this
    /// step follows it (see [`step_start_in`]), else the first sample's reading.
    pub wheels: WheelSpeeds,
    /// The previous step's held command ([`held_command`]), or the wheels at the start when
    /// the previous step is not in the log.
    pub previous_cmd: WheelSpeeds,
    /// The commands of the log's steps before this one through the filters of a plant's
    /// [`StepContext`] (each step for its recorded duration; zero before the first).
    pub filtered_cmd: [WheelSpeeds; 3],
    /// The log's steps before this one, as a plant's [`StepContext::history`] holds them.
    pub history: [PastStep; HISTORY_STEPS],
}

impl StepStart {
    /// What a plant replaying step `step` from here is told at its start.
    pub fn context(&self, step: u32) -> StepContext {
        StepContext {
            step,
            previous_cmd: self.previous_cmd,
            filtered_cmd: self.filtered_cmd,
            history: self.history,
        }
    }
}

/// Estimates the state at the start of a step (see [`StepStart`]).
pub fn step_start(samples: &[Sample]) -> Result<StepStart> {
    let first = samples.first().ok_or(Error::EmptyStep)?;
    let velocity = match first.m.reference {
        Some(v) if v.is_finite() => v,
        _ => start_velocity(samples),
    };
    Ok(StepStart {
        pose: first.m.pose,
        velocity,
        wheels: first.m.enc,
        previous_cmd: first.m.enc,
        filtered_cmd: [WheelSpeeds::default(); 3],
        history: [PastStep::default(); HISTORY_STEPS],
    })
}

/// The start of `step` with the previous step's command taken from `all` (the log's steps in
/// order) when the previous step index is there.
///
/// When the previous step ran right before this one (the next sample period, the pose
/// continuing) and `may_measure` allows its step index, the start is read from the previous
/// step's steady last second: the velocity (without a reference velocity) as the mean of the
/// body rates between poses half a second apart, each exact on a constant arc; the wheels as
/// each encoder's interquartile mean, which ignores a dropped or miscounted reading. This
/// step's own first samples would carry the start of its transient: with a body lagging its
/// wheels by 0.3 s, their slope starts the replay a third of the step's change away from
/// where the robot was.
///
/// `may_measure` says which steps' measurements may start this one: a calibration's training
/// set reads only its own steps, the validation set also the training steps, the test set
/// every step ([`crate::data::StepSet::after`]). A training step after a test step must not
/// start from the test step's poses, or the test steps would move the fit (they did, by 1e-7
/// in a score, once the simulated protocol interrupted less and more steps followed each other
/// without a break). The previous command is the protocol's input, not a measurement: it is
/// taken whatever set its step is in.
pub fn step_start_in(
    all: &[StepSlice<'_>],
    step: StepSlice<'_>,
    may_measure: impl Fn(u32) -> bool,
) -> Result<StepStart> {
    let mut start = step_start(step.samples)?;
    // The filters run over every earlier step of the log, whatever set it is in: commands
    // are the protocol's input, not a measurement.
    let mut ctx = StepContext::default();
    for earlier in all.iter().filter(|s| s.step < step.step) {
        if let Some(held) = held_command(earlier.samples) {
            ctx = ctx.next(held.cmd, duration_s(earlier.samples));
        }
    }
    start.filtered_cmd = ctx.filtered_cmd;
    start.history = ctx.history;
    let Some(prev) = step
        .step
        .checked_sub(1)
        .and_then(|prev| all.iter().find(|s| s.step == prev))
    else {
        return Ok(start);
    };
    let Some(held) = held_command(prev.samples) else {
        return Ok(start);
    };
    start.previous_cmd = held.cmd;
    let first = &step.samples[0];
    if !may_measure(prev.step) {
        return Ok(start);
    }
    let Some(v) = end_velocity(prev.samples) else {
        return Ok(start);
    };
    if continues(prev.samples, first, v) {
        if !first.m.reference.is_some_and(|v| v.is_finite()) {
            start.velocity = v;
        }
        if let Some(w) = end_wheels(prev.samples) {
            start.wheels = w;
        }
    }
    Ok(start)
}

/// How long a recorded step lasted: from its first sample to one sample period after its last.
fn duration_s(samples: &[Sample]) -> f64 {
    match (samples.first(), samples.last()) {
        (Some(a), Some(b)) if samples.len() > 1 => {
            let span = b.t_in_step_s - a.t_in_step_s;
            span * samples.len() as f64 / (samples.len() - 1) as f64
        }
        _ => 0.0,
    }
}

/// Below this encoder speed on both sides at a step's first sample, the wheels stand still
/// and the step starts from rest, rad/s (0.15 m/s on a 0.3 m wheel: about the encoders'
/// noise on the measured runs). A step after the operator stopped the robot starts so.
const STILL_WHEEL_RAD_S: f64 = 0.5;

/// Body velocity at a step's first sample without a reference. At rest when its wheels stand
/// still ([`STILL_WHEEL_RAD_S`]). Else vx and vy from its poses: the slope at that sample of a
/// least-squares parabola through the first half second of the first window (up to 10
/// samples; poses restart at each window in measured logs; a forward difference over the same
/// samples would be the mean velocity over them, late by half the window in a transient), and
/// wz from the gyro at that sample where the log has one (as the measured runs' reference
/// takes it). The poses' curve bends with the response to the new command, and more so when
/// the poses are late: the parabola puts a robot at rest at a speed below zero (tested), and
/// its yaw-rate slope biased a fitted pose latency low.
fn start_velocity(samples: &[Sample]) -> BodyVelocity {
    let first = &samples[0];
    if first.m.enc.left_rad_s.abs() < STILL_WHEEL_RAD_S && first.m.enc.right_rad_s.abs() < STILL_WHEEL_RAD_S {
        return BodyVelocity::default();
    }
    let window: Vec<&Sample> = samples
        .iter()
        .take(10)
        .take_while(|s| s.window == first.window)
        .collect();
    let p0 = first.m.pose;
    let (s0, c0) = p0.yaw_rad.sin_cos();
    // Positions in the first sample's frame, heading unwrapped from it.
    let mut t = Vec::with_capacity(window.len());
    let mut xyz: [Vec<f64>; 3] = Default::default();
    let mut yaw = 0.0;
    let mut last_yaw = p0.yaw_rad;
    for s in &window {
        let (dx, dy) = (s.m.pose.x_m - p0.x_m, s.m.pose.y_m - p0.y_m);
        yaw += wrap_angle(s.m.pose.yaw_rad - last_yaw);
        last_yaw = s.m.pose.yaw_rad;
        t.push(s.t_in_step_s - first.t_in_step_s);
        xyz[0].push(c0 * dx + s0 * dy);
        xyz[1].push(-s0 * dx + c0 * dy);
        xyz[2].push(yaw);
    }
    let slope = |y: &[f64]| -> f64 {
        if t.len() >= 4 {
            if let Some(b) = parabola_slope_at_zero(&t, y) {
                return b;
            }
        }
        let n = y.len();
        if n >= 2 && t[n - 1] > 0.0 {
            (y[n - 1] - y[0]) / t[n - 1]
        } else {
            0.0
        }
    };
    // The yaw rate is the gyro's at the first sample where there is one, as the measured
    // runs' reference takes it: a late pose bends the poses' curve, the gyro is not late.
    let wz = match first.m.imu.wz_rad_s {
        w if w.is_finite() => w,
        _ => slope(&xyz[2]),
    };
    BodyVelocity::new(slope(&xyz[0]), slope(&xyz[1]), wz)
}

/// The slope at t = 0 of the least-squares parabola y ≈ a + b t + c t² (None if singular).
fn parabola_slope_at_zero(t: &[f64], y: &[f64]) -> Option<f64> {
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut aty = nalgebra::Vector3::<f64>::zeros();
    for (&ti, &yi) in t.iter().zip(y) {
        let row = nalgebra::Vector3::new(1.0, ti, ti * ti);
        ata += row * row.transpose();
        aty += row * yi;
    }
    ata.cholesky().map(|c| c.solve(&aty)[1])
}

/// Samples of a step's steady end the next step's start is read from: up to 1 s at 20 Hz.
const END_SAMPLES: usize = 20;

/// The last samples of a step inside its last window (up to [`END_SAMPLES`]), in time order.
fn end_samples(samples: &[Sample]) -> &[Sample] {
    let Some(last) = samples.last() else {
        return samples;
    };
    let n = samples
        .iter()
        .rev()
        .take(END_SAMPLES)
        .take_while(|s| s.window == last.window)
        .count();
    &samples[samples.len() - n..]
}

/// Body velocity at the end of a step, from its steady last second: the mean of the
/// [`body_rate`]s between each sample of its first half and the sample half its length later.
/// Each sample enters once, so the noise falls as a least-squares slope's would (about 7×
/// below a difference over 0.25 s, for a second of poses), and each rate is exact on a
/// constant arc, where a straight-line fit of positions is not.
fn end_velocity(samples: &[Sample]) -> Option<BodyVelocity> {
    let end = end_samples(samples);
    let half = end.len() / 2;
    if half == 0 {
        return None;
    }
    let mut sum = [0.0; 3];
    let mut n = 0.0;
    for (a, b) in end[..half].iter().zip(&end[half..]) {
        let dt = b.t_in_step_s - a.t_in_step_s;
        if dt > 0.0 {
            let v = body_rate(&a.m.pose, &b.m.pose, dt);
            for (s, x) in sum.iter_mut().zip(v) {
                *s += x;
            }
            n += 1.0;
        }
    }
    (n > 0.0).then(|| BodyVelocity::new(sum[0] / n, sum[1] / n, sum[2] / n))
}

/// Encoder wheel speeds at the end of a step: the interquartile mean of each side over the
/// same steady last second as [`end_velocity`]. One sample's reading carries the encoder's
/// noise, its counts' quantisation and, now and then, a dropout to zero; a replay started
/// from it starts the wheels that far off.
fn end_wheels(samples: &[Sample]) -> Option<WheelSpeeds> {
    let end = end_samples(samples);
    if end.len() < 4 {
        return None;
    }
    let side = |f: fn(&Sample) -> f64| interquartile_mean(&end.iter().map(f).collect::<Vec<_>>());
    Some(WheelSpeeds::new(
        side(|s| s.m.enc.left_rad_s),
        side(|s| s.m.enc.right_rad_s),
    ))
}

/// Whether `next` follows the step `before` without a break: one sample period after its
/// last sample (within half a period) and the pose where the velocity `v` takes it (within
/// 5 cm and 0.05 rad beyond the motion itself).
fn continues(before: &[Sample], next: &Sample, v: BodyVelocity) -> bool {
    let [.., a, last] = before else {
        return false;
    };
    let period = last.stamp_s - a.stamp_s;
    let dt = next.stamp_s - last.stamp_s;
    let moved = (next.m.pose.x_m - last.m.pose.x_m).hypot(next.m.pose.y_m - last.m.pose.y_m);
    let speed = v.vx_m_s.hypot(v.vy_m_s);
    period > 0.0
        && dt > 0.0
        && dt <= 1.5 * period
        && moved <= speed * dt + 0.05
        && wrap_angle(next.m.pose.yaw_rad - last.m.pose.yaw_rad).abs() <= v.wz_rad_s.abs() * dt + 0.05
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_log::Measurement;

    /// A step of `n` samples at 20 Hz starting at `stamp0_s`, whose pose follows `pose(t)`.
    fn step(index: u32, stamp0_s: f64, n: u32, pose: impl Fn(f64) -> Pose) -> Vec<Sample> {
        (0..n)
            .map(|i| {
                let t = f64::from(i) * 0.05;
                Sample {
                    step: index,
                    window: i / 40,
                    k: i % 40,
                    t_in_step_s: t,
                    stamp_s: stamp0_s + t,
                    m: Measurement {
                        pose: pose(t),
                        // Turning wheels: the poses, not a stop, say how the step starts.
                        enc: WheelSpeeds::new(4.0, 4.0),
                        ..Measurement::default()
                    },
                }
            })
            .collect()
    }

    /// Steps 4 and 5 of a log, in order.
    fn steps_4_and_5<'a>(prev: &'a [Sample], next: &'a [Sample]) -> [StepSlice<'a>; 2] {
        [
            StepSlice {
                step: 4,
                samples: prev,
            },
            StepSlice {
                step: 5,
                samples: next,
            },
        ]
    }

    /// A straight line along heading `yaw` from rest at `v0`, accelerating at `a`.
    fn accelerating(v0: f64, a: f64, yaw: f64) -> impl Fn(f64) -> Pose {
        move |t| {
            let s = v0 * t + 0.5 * a * t * t;
            Pose {
                x_m: 2.0 + s * yaw.cos(),
                y_m: -1.0 + s * yaw.sin(),
                yaw_rad: yaw,
                ..Pose::default()
            }
        }
    }

    #[test]
    fn the_start_velocity_is_the_slope_at_the_start_not_the_mean_over_the_window() {
        let samples = step(0, 0.0, 80, accelerating(0.5, 2.0, 2.5));
        let v = step_start(&samples).unwrap().velocity;
        assert!((v.vx_m_s - 0.5).abs() < 1e-9, "{v:?}");
        assert!(v.vy_m_s.abs() < 1e-9 && v.wz_rad_s.abs() < 1e-9, "{v:?}");
    }

    #[test]
    fn a_step_right_after_a_steady_one_starts_at_its_end_velocity() {
        // Steady 1.2 m/s on a straight line, then a step that brakes hard from the next sample.
        let steady = |t: f64| Pose {
            x_m: 1.2 * t,
            ..Pose::default()
        };
        let prev = step(4, 0.0, 120, steady);
        let x0 = 1.2 * 6.0;
        let next = step(5, 6.0, 80, move |t| Pose {
            x_m: x0 + 1.2 * t - 0.5 * 3.0 * t * t.min(0.4),
            ..Pose::default()
        });
        let all = steps_4_and_5(&prev, &next);
        let start = step_start_in(&all, all[1], |_| true).unwrap();
        assert!((start.velocity.vx_m_s - 1.2).abs() < 1e-9, "{start:?}");
        // The previous step in another set (a test step before a training one): its poses are
        // not used, its command is.
        let own = step_start_in(&all, all[1], |k| k != 4).unwrap();
        assert!(
            (own.velocity.vx_m_s - start.velocity.vx_m_s).abs() > 1e-3,
            "{own:?}"
        );
        assert_eq!(own.velocity, step_start(&next).unwrap().velocity);
        assert_eq!(own.previous_cmd, start.previous_cmd);
        // After a break (re-orientation: 30 s later, elsewhere), the step's own poses decide.
        let later = step(5, 36.0, 80, move |t| Pose {
            x_m: 50.0 + 0.3 * t,
            ..Pose::default()
        });
        let all = [
            all[0],
            StepSlice {
                step: 5,
                samples: &later,
            },
        ];
        let start = step_start_in(&all, all[1], |_| true).unwrap();
        assert!((start.velocity.vx_m_s - 0.3).abs() < 1e-9, "{start:?}");
    }

    #[test]
    fn a_step_after_a_steady_one_starts_its_wheels_at_the_end_ignoring_dropouts_and_counts() {
        let steady = |t: f64| Pose {
            x_m: 1.2 * t,
            ..Pose::default()
        };
        let mut prev = step(4, 0.0, 120, steady);
        // Counts of ±0.5 rad/s about 4 and, twice in the last second, an encoder that reads 0.
        for (i, s) in prev.iter_mut().enumerate() {
            let count = if i % 2 == 0 { 0.5 } else { -0.5 };
            s.m.enc = WheelSpeeds::new(4.0 + count, 4.0 - count);
        }
        prev[110].m.enc.left_rad_s = 0.0;
        prev[116].m.enc.right_rad_s = 0.0;
        let next = step(5, 6.0, 80, move |t| Pose {
            x_m: 7.2 + 1.2 * t,
            ..Pose::default()
        });
        let all = steps_4_and_5(&prev, &next);
        // Within 0.05 rad/s of 4 (a plain mean of the last second is 0.2 below it, and the
        // last sample alone 0.5 off).
        let start = step_start_in(&all, all[1], |_| true).unwrap();
        assert!((start.wheels.left_rad_s - 4.0).abs() < 0.05, "{start:?}");
        assert!((start.wheels.right_rad_s - 4.0).abs() < 0.05, "{start:?}");
        // Without the previous step's measurements, the first sample's own reading.
        let own = step_start_in(&all, all[1], |k| k != 4).unwrap();
        assert_eq!(own.wheels, next[0].m.enc);
    }

    #[test]
    fn a_step_whose_wheels_stand_still_starts_at_rest_whatever_its_poses_bend_to() {
        // Poses that stand for 0.15 s (a late pose) and then accelerate: a parabola through
        // them would give a start velocity below zero.
        let mut samples = step(0, 0.0, 80, |t| Pose {
            x_m: 2.0 * (t - 0.15).max(0.0).powi(2),
            ..Pose::default()
        });
        samples[0].m.enc = WheelSpeeds::new(0.1, -0.2);
        let v = step_start(&samples).unwrap().velocity;
        assert_eq!(v, BodyVelocity::default());
        samples[0].m.enc = WheelSpeeds::new(3.0, 3.0);
        assert!(step_start(&samples).unwrap().velocity.vx_m_s < -0.05);
    }
}
