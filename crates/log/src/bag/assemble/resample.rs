//! Resampling a completed attempt onto the analysis clock: the command by zero-order hold, the
//! other signals by linear interpolation (angles along the shorter arc).

use super::{Assembly, Attempt};
use crate::bag::roles::Role;
use crate::{ImuReading, Measurement, Pose, Sample};
use drive_sim_model::error::{Error, Result};
use drive_sim_model::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};

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

fn lerp_imu(a: ImuReading, b: ImuReading, u: f64) -> ImuReading {
    ImuReading {
        wz_rad_s: lerp(a.wz_rad_s, b.wz_rad_s, u),
        ax_m_s2: lerp(a.ax_m_s2, b.ax_m_s2, u),
        ay_m_s2: lerp(a.ay_m_s2, b.ay_m_s2, u),
        az_m_s2: lerp(a.az_m_s2, b.az_m_s2, u),
    }
}

/// Pose and the source's own twist at `t`, interpolated between the odometry messages around
/// it; `None` outside their span.
fn odom_at(odom: &[(u64, Pose, [f64; 3])], t: f64) -> Option<(Pose, [f64; 3])> {
    let oi = odom.partition_point(|x| (x.0 as f64) <= t);
    if oi > 0 && (odom[oi - 1].0 as f64 == t || oi == odom.len()) {
        let (_, p, w) = odom[oi - 1];
        if odom[oi - 1].0 as f64 != t {
            return None;
        }
        Some((p, w))
    } else if oi > 0 {
        let (ta, pa, wa) = odom[oi - 1];
        let (tb, pb, wb) = odom[oi];
        let u = (t - ta as f64) / (tb as f64 - ta as f64);
        Some((
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
        ))
    } else {
        None
    }
}

impl Assembly<'_> {
    /// The samples of `step`, whose completed attempt is `done`, one per tick.
    pub(super) fn resample_step(&self, step: u32, done: &Attempt) -> Result<Vec<Sample>> {
        let idd = self.meta.nominal.idd();
        let start = done.start_ns as f64;
        (0..self.clock.n_ticks)
            .map(|k| self.sample_at(step, done, &idd, start + k as f64 * self.clock.tick_ns, k))
            .collect()
    }

    /// The sample of tick `k` of `step`, at `t` (ns).
    fn sample_at(&self, step: u32, done: &Attempt, idd: &IdealDiffDrive, t: f64, k: u64) -> Result<Sample> {
        let s = self.s;
        let tick_ns = self.clock.tick_ns;
        // Command: zero-order hold, looking half a tick ahead (it is published with the tick),
        // never past the attempt (a run one tick short must not take the next command).
        let tq = (t + 0.5 * tick_ns).min(done.cmd_until_ns as f64);
        let ci = s.cmd.partition_point(|x| (x.0 as f64) <= tq);
        let c = s.cmd[ci.saturating_sub(1)].1;
        let cmd = idd.wheels_from_body(BodyVelocity::new(c[0], 0.0, c[1]));
        let miss = |role: Role| {
            Error::log(
                self.file,
                format!("step {step} tick {k} (t = {:.3} s)", (t - self.t0 as f64) * 1e-9),
                format!("no {} to interpolate from", self.topic(role)),
            )
        };
        let l = interp(&s.left, t, lerp).ok_or_else(|| miss(Role::WheelLeft))?;
        let r = interp(&s.right, t, lerp).ok_or_else(|| miss(Role::WheelRight))?;
        let (pose, tw) = odom_at(&s.odom, t).ok_or_else(|| miss(Role::Odom))?;
        // Without an IMU the reading is NaN, as in a CSV without one: the yaw rate then comes
        // from the pose.
        let imu = if s.imu.is_empty() {
            ImuReading {
                wz_rad_s: f64::NAN,
                ax_m_s2: f64::NAN,
                ay_m_s2: f64::NAN,
                az_m_s2: f64::NAN,
            }
        } else {
            interp(&s.imu, t, lerp_imu).ok_or_else(|| miss(Role::Imu))?
        };
        let reference = BodyVelocity::new(tw[0], tw[1], tw[2]);
        let spw = self.clock.samples_per_window;
        Ok(Sample {
            step,
            window: (k / spw) as u32,
            k: (k % spw) as u32,
            t_in_step_s: k as f64 / self.clock.rate_hz,
            stamp_s: (t - self.t0 as f64) * 1e-9,
            m: Measurement {
                cmd,
                enc: WheelSpeeds::new(l, r),
                pose,
                imu,
                reference: reference.is_finite().then_some(reference),
                truth: None,
            },
        })
    }
}
