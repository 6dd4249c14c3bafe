//! The recorded steps a model is scored on: a log cut into steps, the measured state each
//! replayed step starts from, and the planar pose arithmetic both the estimators and the
//! replay use. Below [`super::metrics`] and [`super::replay`], which both read it.

use crate::error::{Error, Result};
use drive_sim_analysis::segment::{usable_steps, Exclusion, SegmentRules};
use drive_sim_log::{DriveLog, Pose, Sample};
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
    /// Body velocity at the first sample: the source's reference estimate when it has one,
    /// else the pose difference over the first 0.25 s of the step, in the body frame.
    pub velocity: BodyVelocity,
    /// Encoder wheel speeds of the first sample.
    pub wheels: WheelSpeeds,
    /// The previous step's command (its last sample's), or the wheels at the start when
    /// the previous step is not in the log.
    pub previous_cmd: WheelSpeeds,
    /// The commands of the log's steps before this one through the filters of a plant's
    /// [`StepContext`] (each step for its recorded duration; zero before the first).
    pub filtered_cmd: [WheelSpeeds; 3],
}

impl StepStart {
    /// What a plant replaying step `step` from here is told at its start.
    pub fn context(&self, step: u32) -> StepContext {
        StepContext {
            step,
            previous_cmd: self.previous_cmd,
            filtered_cmd: self.filtered_cmd,
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
    })
}

/// The start of `step` with the previous step's command taken from `all` (the log's steps in
/// order) when the previous step index is there.
///
/// Without a reference velocity, and when the previous step ran right before this one (the
/// next sample period, the pose continuing) and `may_measure` allows its step index, the start
/// velocity is the previous step's end velocity: a backward difference over its steady last
/// samples. The forward difference over this step's first 0.25 s averages the start of the
/// transient into it: with a body lagging its wheels by 0.3 s, that starts the replay a third
/// of the step's change away from where the robot was.
///
/// `may_measure` keeps a calibration's sets apart: a training step after a test step must not
/// start from the test step's poses, or the test steps would move the fit (they did, by 1e-7 in
/// a score, once the simulated protocol interrupted less and more steps followed each other
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
        if let Some(last) = earlier.samples.last() {
            ctx = ctx.next(last.m.cmd, duration_s(earlier.samples));
        }
    }
    start.filtered_cmd = ctx.filtered_cmd;
    let Some(prev) = step
        .step
        .checked_sub(1)
        .and_then(|prev| all.iter().find(|s| s.step == prev))
    else {
        return Ok(start);
    };
    let Some(last) = prev.samples.last() else {
        return Ok(start);
    };
    start.previous_cmd = last.m.cmd;
    let first = &step.samples[0];
    if may_measure(prev.step) && !first.m.reference.is_some_and(|v| v.is_finite()) {
        if let Some(v) = end_velocity(prev.samples) {
            if continues(prev.samples, first, v) {
                start.velocity = v;
            }
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

/// Body velocity at a step's first sample from its poses: the slope at that sample of a
/// least-squares parabola through the first half second of the first window (up to 10
/// samples; poses restart at each window in measured logs). A forward difference over the same
/// samples would be the mean velocity over them, which is late by half the window in a
/// transient; the parabola's slope at the start is not, at a similar noise for 10 samples.
fn start_velocity(samples: &[Sample]) -> BodyVelocity {
    let first = &samples[0];
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
    BodyVelocity::new(slope(&xyz[0]), slope(&xyz[1]), slope(&xyz[2]))
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

/// Body velocity at the end of a step: the backward difference over its last samples inside
/// one window (up to 5 sample periods).
fn end_velocity(samples: &[Sample]) -> Option<BodyVelocity> {
    let last = samples.last()?;
    let first = samples
        .iter()
        .rev()
        .take(6)
        .take_while(|s| s.window == last.window)
        .last()?;
    let dt = last.t_in_step_s - first.t_in_step_s;
    (dt > 0.0).then(|| {
        let v = body_rate(&first.m.pose, &last.m.pose, dt);
        BodyVelocity::new(v[0], v[1], v[2])
    })
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
                        ..Measurement::default()
                    },
                }
            })
            .collect()
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
        let all = [
            StepSlice {
                step: 4,
                samples: &prev,
            },
            StepSlice {
                step: 5,
                samples: &next,
            },
        ];
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
}
