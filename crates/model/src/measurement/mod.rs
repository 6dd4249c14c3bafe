//! The data model of a DRIVE run: what the simulator measures, where the protocol is at each
//! tick, and the log of completed steps that every reader produces.
//!
//! It sits below the simulator, the protocol and the log readers/writers so that all of them
//! (and the analysis above) share one definition without importing each other: the simulator
//! produces [`Measurement`]s, the protocol wraps them into [`Frame`]s and hands them to a
//! [`FrameSink`] (the MCAP writer, a `Vec`), and every reader (CSV, MCAP, rosbag2) builds a
//! [`DriveLog`].

mod drive_log;

pub use drive_log::{DriveLog, Interruption, LogMeta, Nominal, Origin, UseSteps};

use crate::kinematics::{BodyVelocity, WheelSpeeds};
use serde::{Deserialize, Serialize};

/// 6-DoF pose: position in m, attitude as roll, pitch, yaw in rad (ZYX convention).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// x position, m.
    pub x_m: f64,
    /// y position, m.
    pub y_m: f64,
    /// z position, m.
    pub z_m: f64,
    /// Roll, rad.
    pub roll_rad: f64,
    /// Pitch, rad.
    pub pitch_rad: f64,
    /// Yaw, rad (counter-clockwise positive).
    pub yaw_rad: f64,
}

impl Pose {
    /// True if every component is finite.
    pub fn is_finite(&self) -> bool {
        [
            self.x_m,
            self.y_m,
            self.z_m,
            self.roll_rad,
            self.pitch_rad,
            self.yaw_rad,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}

/// IMU reading in the body frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ImuReading {
    /// Yaw rate, rad/s.
    pub wz_rad_s: f64,
    /// Specific force along x, m/s² (includes gravity, as a real accelerometer).
    pub ax_m_s2: f64,
    /// Specific force along y, m/s².
    pub ay_m_s2: f64,
    /// Specific force along z, m/s² (about +9.81 at rest).
    pub az_m_s2: f64,
}

/// What only a simulator knows: the true state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct GroundTruth {
    /// True pose in the world (odom) frame.
    pub pose: Pose,
    /// True planar velocity in the body frame.
    pub velocity: BodyVelocity,
    /// True wheel speeds (mean of each side's wheels), rad/s.
    pub wheels: WheelSpeeds,
}

/// The measurements of one tick.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Measurement {
    /// Commanded wheel speeds (the protocol's target), rad/s.
    pub cmd: WheelSpeeds,
    /// Encoder wheel speeds, rad/s.
    pub enc: WheelSpeeds,
    /// Lidar/ICP pose. Only differences inside one window are meaningful: a measured log gives it
    /// in the frame of the window's first sample, a simulated one in the odom frame.
    pub pose: Pose,
    /// IMU reading.
    pub imu: ImuReading,
    /// The data source's own body-velocity estimate, when it has one.
    pub reference: Option<BodyVelocity>,
    /// Ground truth (simulated logs only).
    pub truth: Option<GroundTruth>,
}

/// Where the protocol is at one tick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Phase {
    /// Executing step `step` (attempt `attempt`, counting interrupted ones from 0).
    Step {
        /// Step index, from 0.
        step: u32,
        /// Attempt index of this step, from 0; an interruption starts a new attempt.
        attempt: u32,
        /// Window index: 0 transient, 1.. steady.
        window: u32,
        /// Sample index inside the window.
        k: u32,
        /// Time since the start of this attempt, s.
        t_in_step_s: f64,
    },
    /// Re-orienting towards the centre of the safe area after an interruption.
    Reorient {
        /// The step that was interrupted.
        step: u32,
    },
    /// Standing still before the first step or after the last.
    Idle,
}

/// One tick of a log: a timestamp, the protocol phase, and the measurements.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Time since the start of the log, s.
    pub stamp_s: f64,
    /// Protocol phase.
    pub phase: Phase,
    /// Measurements.
    pub m: Measurement,
}

/// One sample of a completed step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Step index.
    pub step: u32,
    /// Window index: 0 transient, 1.. steady.
    pub window: u32,
    /// Sample index inside the window.
    pub k: u32,
    /// Time since the start of the (completed attempt of the) step, s.
    pub t_in_step_s: f64,
    /// Time since the start of the log, s (not continuous across steps in measured logs).
    pub stamp_s: f64,
    /// Measurements.
    pub m: Measurement,
}

impl Sample {
    /// The frame of this sample, as the completed (final) attempt of its step: what a log of
    /// completed steps (a replay, a measured run) writes to MCAP.
    pub fn to_frame(&self) -> Frame {
        Frame {
            stamp_s: self.stamp_s,
            phase: Phase::Step {
                step: self.step,
                attempt: 0,
                window: self.window,
                k: self.k,
                t_in_step_s: self.t_in_step_s,
            },
            m: self.m,
        }
    }
}

/// The command a step holds, and how firmly the log records it ([`held_command`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeldCommand {
    /// The command, rad/s.
    pub cmd: WheelSpeeds,
    /// Samples of the steady windows that record it.
    pub samples: usize,
    /// Samples of the steady windows (0: the step has none, and `cmd` is its last sample's).
    pub steady_samples: usize,
}

impl HeldCommand {
    /// The steady windows record another command beside the held one.
    pub fn changes_in_steady(&self) -> bool {
        self.samples < self.steady_samples
    }
}

/// The command a step holds: among the samples of its steady windows (window 1 and later), the
/// command recorded for the most of them (a tie goes to the one recorded last); the last
/// sample's when the step has no steady sample. `None` for no sample.
///
/// Not simply the last sample's: the transient window starts with the previous step's command
/// for a few samples, and some real logs record the next step's command in the last samples of
/// a step (`warthog_asphalt_b`, steps 88 to 99; `husky_2023`, 89 and 194 to 199), where the
/// encoders still answer the command held for the other 77 to 79 of the 80 steady samples.
/// Taking the last sample's paired those steps' steady state with the next step's command.
pub fn held_command<'a>(samples: impl IntoIterator<Item = &'a Sample>) -> Option<HeldCommand> {
    // (command, samples recording it, index of its last sample); a step holds one or two.
    let mut seen: Vec<(WheelSpeeds, usize, usize)> = Vec::with_capacity(2);
    let mut last = None;
    let mut steady = 0;
    for (i, s) in samples.into_iter().enumerate() {
        last = Some(s.m.cmd);
        if s.window == 0 {
            continue;
        }
        steady += 1;
        let same = |c: &WheelSpeeds| {
            c.left_rad_s.to_bits() == s.m.cmd.left_rad_s.to_bits()
                && c.right_rad_s.to_bits() == s.m.cmd.right_rad_s.to_bits()
        };
        match seen.iter_mut().find(|(c, _, _)| same(c)) {
            Some(e) => {
                e.1 += 1;
                e.2 = i;
            }
            None => seen.push((s.m.cmd, 1, i)),
        }
    }
    let Some(&(cmd, n, _)) = seen.iter().max_by_key(|(_, n, at)| (*n, *at)) else {
        return last.map(|cmd| HeldCommand {
            cmd,
            samples: 0,
            steady_samples: 0,
        });
    };
    Some(HeldCommand {
        cmd,
        samples: n,
        steady_samples: steady,
    })
}

/// Receives each frame as it is produced (e.g. an MCAP writer), and progress notifications.
///
/// Defined here, below the protocol that calls it and the log writers that implement it.
pub trait FrameSink {
    /// Takes one frame.
    fn frame(&mut self, frame: &Frame) -> crate::Result<()>;
    /// Called when a step completes.
    fn step_done(&mut self, _completed: u32) {}
}

impl FrameSink for Vec<Frame> {
    fn frame(&mut self, frame: &Frame) -> crate::Result<()> {
        self.push(*frame);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step of three 4-sample windows whose commands are given per window.
    fn step(cmds: [&[(f64, f64)]; 3]) -> Vec<Sample> {
        let mut out = Vec::new();
        for (w, window) in cmds.iter().enumerate() {
            for (k, &(l, r)) in window.iter().enumerate() {
                out.push(Sample {
                    step: 7,
                    window: w as u32,
                    k: k as u32,
                    t_in_step_s: 0.0,
                    stamp_s: 0.0,
                    m: Measurement {
                        cmd: WheelSpeeds::new(l, r),
                        ..Measurement::default()
                    },
                });
            }
        }
        out
    }

    #[test]
    fn the_held_command_is_the_steady_windows_most_recorded_not_the_last_samples() {
        let (prev, held, next) = ((1.0, 2.0), (-3.9, 6.0), (4.9, 13.9));
        // The transient starts with the previous command; the last two samples record the
        // next step's (a log recording it early).
        let s = step([
            &[prev, prev, held, held],
            &[held, held, held, held],
            &[held, held, next, next],
        ]);
        let h = held_command(&s).unwrap();
        assert_eq!(h.cmd, WheelSpeeds::new(-3.9, 6.0));
        assert_eq!((h.samples, h.steady_samples), (6, 8));
        assert!(h.changes_in_steady());
        // One command over the steady windows: held firmly.
        let s = step([&[prev, held], &[held, held], &[held, held]]);
        let h = held_command(&s).unwrap();
        assert_eq!(h.cmd, WheelSpeeds::new(-3.9, 6.0));
        assert!(!h.changes_in_steady());
        // A tie goes to the command recorded last.
        let s = step([&[prev], &[held, held], &[next, next]]);
        assert_eq!(held_command(&s).unwrap().cmd, WheelSpeeds::new(4.9, 13.9));
        // No steady sample: the last sample's; no sample: none.
        let s = step([&[prev, held], &[], &[]]);
        let h = held_command(&s).unwrap();
        assert_eq!((h.cmd, h.steady_samples), (WheelSpeeds::new(-3.9, 6.0), 0));
        assert!(held_command(&[]).is_none());
    }
}
