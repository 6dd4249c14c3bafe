//! The one mapping between the domain types and the ROS messages of a DRIVE log, both ways.

use super::*;
use crate::ros_msgs::{
    DriveMarker, JointState, Odometry, Point, Pose as RosPose, Quaternion, Twist, Vector3,
};
use crate::{Frame, Phase, Pose};
use drive_sim_model::error::Error;
use drive_sim_model::error::Result;
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};

/// Log time of a frame stamp, ns, with the fixed epoch offset.
pub(crate) fn stamp_to_ns(stamp_s: f64) -> std::result::Result<u64, String> {
    // Upper bound keeps the header's int32 seconds valid.
    if !(stamp_s.is_finite() && (0.0..2.0e9).contains(&stamp_s)) {
        return Err(format!("stamp {stamp_s} s is not in [0, 2e9) s"));
    }
    Ok((stamp_s * 1e9).round() as u64 + EPOCH_OFFSET_NS)
}

/// Refuses frames that the reader would refuse: non-finite values, NaN in optional parts.
pub(crate) fn check_frame(f: &Frame) -> std::result::Result<(), String> {
    let m = &f.m;
    let mut bad = Vec::new();
    if !m.cmd.is_finite() {
        bad.push("cmd");
    }
    if !m.enc.is_finite() {
        bad.push("enc");
    }
    if !m.pose.is_finite() {
        bad.push("pose");
    }
    let i = m.imu;
    if ![i.wz_rad_s, i.ax_m_s2, i.ay_m_s2, i.az_m_s2]
        .iter()
        .all(|v| v.is_finite())
    {
        bad.push("imu");
    }
    if m.reference.is_some_and(|r| !r.is_finite()) {
        bad.push("reference");
    }
    if let Some(t) = m.truth {
        if !(t.pose.is_finite() && t.velocity.is_finite() && t.wheels.is_finite()) {
            bad.push("truth");
        }
    }
    if let Phase::Step { t_in_step_s, .. } = f.phase {
        if !t_in_step_s.is_finite() {
            bad.push("phase.t_in_step_s");
        }
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(format!("non-finite values in {}", bad.join(", ")))
    }
}

/// Sets `m` to frame `f`'s protocol phase (all but its header), reusing its phase string.
pub(crate) fn set_marker(m: &mut DriveMarker, f: &Frame) {
    let header = std::mem::take(&mut m.header);
    let mut phase = std::mem::take(&mut m.phase);
    phase.clear();
    *m = DriveMarker {
        header,
        stamp: f.stamp_s,
        ..Default::default()
    };
    match f.phase {
        Phase::Step {
            step,
            attempt,
            window,
            k,
            t_in_step_s,
        } => {
            phase.push_str("step");
            m.step = step;
            m.attempt = attempt;
            m.window = window;
            m.k = k;
            m.t_in_step = t_in_step_s;
        }
        Phase::Reorient { step } => {
            phase.push_str("reorient");
            m.step = step;
        }
        Phase::Idle => phase.push_str("idle"),
    }
    m.phase = phase;
}

pub(crate) fn body_twist(v: BodyVelocity) -> Twist {
    Twist {
        linear: Vector3 {
            x: v.vx_m_s,
            y: v.vy_m_s,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: v.wz_rad_s,
        },
    }
}

/// Sets the wheel speeds of a `JointState` built with the two wheel joints' names.
pub(crate) fn set_wheels(m: &mut JointState, w: WheelSpeeds) {
    m.velocity.clear();
    m.velocity.extend([w.left_rad_s, w.right_rad_s]);
}

pub(crate) fn ros_pose(p: Pose) -> RosPose {
    // ZYX (yaw, then pitch, then roll): nalgebra's from_euler_angles(roll, pitch, yaw).
    let q = nalgebra::UnitQuaternion::from_euler_angles(p.roll_rad, p.pitch_rad, p.yaw_rad);
    RosPose {
        position: Point {
            x: p.x_m,
            y: p.y_m,
            z: p.z_m,
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

pub(crate) fn msg_loc(topic: &str, idx: u64, log_time_ns: u64) -> String {
    format!(
        "topic {topic} message {idx} (log time {:.3} s)",
        log_time_ns as f64 * 1e-9
    )
}

pub(crate) fn phase_of(mk: &DriveMarker, t: u64) -> std::result::Result<(Phase, f64), String> {
    let stamp_s = mk.stamp;
    match stamp_to_ns(stamp_s) {
        Ok(ns) if ns == t => {}
        _ => {
            return Err(format!(
                "stamp {stamp_s} s does not match the log time {:.9} s - 1 s",
                t as f64 * 1e-9
            ))
        }
    }
    let phase = match mk.phase.as_str() {
        "step" => {
            if !mk.t_in_step.is_finite() {
                return Err(format!("t_in_step {} is not finite", mk.t_in_step));
            }
            Phase::Step {
                step: mk.step,
                attempt: mk.attempt,
                window: mk.window,
                k: mk.k,
                t_in_step_s: mk.t_in_step,
            }
        }
        "reorient" => Phase::Reorient { step: mk.step },
        "idle" => Phase::Idle,
        p => return Err(format!("phase `{p}`, expected step, reorient or idle")),
    };
    Ok((phase, stamp_s))
}

pub(crate) fn wheels_of(j: &JointState, file: &Path, topic: &str, idx: u64, t: u64) -> Result<WheelSpeeds> {
    let err = |m: String| Error::log(file, msg_loc(topic, idx, t), m);
    if j.velocity.len() != j.name.len() {
        return Err(err(format!(
            "{} names but {} velocities",
            j.name.len(),
            j.velocity.len()
        )));
    }
    let get = |joint: &str| {
        let i = j
            .name
            .iter()
            .position(|n| n == joint)
            .ok_or_else(|| err(format!("no joint `{joint}` in {:?}", j.name)))?;
        let v = j.velocity[i];
        if v.is_finite() {
            Ok(v)
        } else {
            Err(err(format!("velocity of `{joint}` is {v}")))
        }
    };
    Ok(WheelSpeeds::new(get(JOINT_LEFT)?, get(JOINT_RIGHT)?))
}

pub(crate) fn velocity_of(tw: &Twist, file: &Path, topic: &str, idx: u64, t: u64) -> Result<BodyVelocity> {
    let v = BodyVelocity::new(tw.linear.x, tw.linear.y, tw.angular.z);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::log(
            file,
            msg_loc(topic, idx, t),
            format!("non-finite twist {v:?}"),
        ))
    }
}

pub(crate) fn pose_of(o: &Odometry, file: &Path, topic: &str, idx: u64, t: u64) -> Result<Pose> {
    let err = |m: String| Error::log(file, msg_loc(topic, idx, t), m);
    let (p, q) = (o.pose.pose.position, o.pose.pose.orientation);
    let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    if !(norm.is_finite() && (norm - 1.0).abs() < 1e-6) {
        return Err(err(format!("orientation {q:?} is not a unit quaternion")));
    }
    let uq = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
    let (roll_rad, pitch_rad, yaw_rad) = uq.euler_angles();
    let pose = Pose {
        x_m: p.x,
        y_m: p.y,
        z_m: p.z,
        roll_rad,
        pitch_rad,
        yaw_rad,
    };
    if pose.is_finite() {
        Ok(pose)
    } else {
        Err(err(format!("non-finite position {p:?}")))
    }
}
