//! The recorded steps a model is scored on: a log cut into steps, the measured state each
//! replayed step starts from, and the planar pose arithmetic both the estimators and the
//! replay use. Below [`super::metrics`] and [`super::replay`], which both read it.

use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, WheelSpeeds};
use crate::log::{DriveLog, Pose, Sample};
use crate::sim::plant::wrap_angle;

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
}

/// Estimates the state at the start of a step (see [`StepStart`]).
pub fn step_start(samples: &[Sample]) -> Result<StepStart> {
    let first = samples
        .first()
        .ok_or_else(|| Error::Analysis("empty step".into()))?;
    let velocity = match first.m.reference {
        Some(v) if v.is_finite() => v,
        _ => {
            // Forward difference inside the first window (poses restart at each window in
            // measured logs), over up to 5 samples.
            let end = samples
                .iter()
                .take(6)
                .take_while(|s| s.window == first.window)
                .last()
                .unwrap_or(first);
            let dt = end.t_in_step_s - first.t_in_step_s;
            if dt > 0.0 {
                let v = body_rate(&first.m.pose, &end.m.pose, dt);
                BodyVelocity::new(v[0], v[1], v[2])
            } else {
                BodyVelocity::default()
            }
        }
    };
    Ok(StepStart {
        pose: first.m.pose,
        velocity,
        wheels: first.m.enc,
        previous_cmd: first.m.enc,
    })
}

/// The start of `steps[i]` with the previous step's command taken from `all` (the log's
/// steps in order) when the previous step index is there.
pub fn step_start_in(all: &[StepSlice<'_>], step: StepSlice<'_>) -> Result<StepStart> {
    let mut start = step_start(step.samples)?;
    if let Some(prev) = step.step.checked_sub(1) {
        if let Some(p) = all.iter().find(|s| s.step == prev) {
            if let Some(last) = p.samples.last() {
                start.previous_cmd = last.m.cmd;
            }
        }
    }
    Ok(start)
}
