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
