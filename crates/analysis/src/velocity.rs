//! Realized velocities from the pose stream, the IMU and the encoders.
//!
//! Poses are only comparable inside one window (a measured log gives each window in the frame
//! of its first sample), so every derivative here is taken inside one window.
//!
//! Derivative estimator: at each sample, the slope of a least-squares straight line through the
//! samples within `half_width` on either side (clipped at the window's ends). Inside the window
//! this is the Savitzky–Golay first-derivative filter (orders 1 and 2 give the same centred
//! derivative). Why: ICP positions carry centimetre noise; a two-point difference at 20 Hz turns
//! 1 cm into 0.2 m/s, while the 7-point fit (half width 3, 0.3 s) divides white-noise variance
//! by Σk² = 28 and keeps the lag at zero. Its cost is a bias on curvature (acceleration) that is
//! negligible in the steady windows the slip uses. Times come from `t_in_step_s`, so a missing
//! sample does not distort the slope.

use drive_sim_log::Sample;
use drive_sim_model::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};

/// Slope of the least-squares line through `(t[j], y[j])` for `j` within `half_width` of each `i`.
/// Returns NaN where fewer than two distinct times are available.
pub fn local_slope(t: &[f64], y: &[f64], half_width: usize) -> Vec<f64> {
    let n = t.len().min(y.len());
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half_width);
            let hi = (i + half_width + 1).min(n);
            let m = (hi - lo) as f64;
            let mt = t[lo..hi].iter().sum::<f64>() / m;
            let my = y[lo..hi].iter().sum::<f64>() / m;
            let (mut stt, mut sty) = (0.0, 0.0);
            for j in lo..hi {
                stt += (t[j] - mt) * (t[j] - mt);
                sty += (t[j] - mt) * (y[j] - my);
            }
            if stt > 0.0 {
                sty / stt
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// Mean of `y[j]` for `j` within `half_width` of each `i` (same clipping as [`local_slope`]):
/// the time and heading at which the local line's slope is an unbiased velocity.
pub fn local_mean(y: &[f64], half_width: usize) -> Vec<f64> {
    let n = y.len();
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half_width);
            let hi = (i + half_width + 1).min(n);
            y[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect()
}

/// Removes 2π jumps from a sequence of angles (rad), so that differences are continuous.
pub fn unwrap_angles(a: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(a.len());
    let mut offset = 0.0;
    for (i, &x) in a.iter().enumerate() {
        if i > 0 {
            let d = x - a[i - 1];
            offset -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
        }
        out.push(x + offset);
    }
    out
}

/// Mean body velocity over one window from the pose: least-squares slopes over the whole window
/// of the body-frame path (vx, vy) and of the unwrapped yaw (wz).
///
/// The body-frame path accumulates each pose increment rotated by the mean heading of its two
/// end samples, so it is a straight line `v t` for any motion at constant body velocity (a
/// circle included). Why a whole-window fit: the measured ICP positions arrive with
/// sample-and-hold jitter (at 3.2 m/s, 3-sample increments alternate between about 0.3 and
/// 0.6 m), and the mean of per-sample derivatives telescopes to an end-point difference that
/// carries the jitter of the two ends (up to 0.1 m/s on warthog_asphalt step 39); the line fit
/// uses every sample. For a window whose speed drifts, it is a parabola-weighted mean
/// (weights largest mid-window).
pub fn window_mean_body_velocity(samples: &[Sample]) -> BodyVelocity {
    let n = samples.len();
    if n < 2 {
        return BodyVelocity::new(f64::NAN, f64::NAN, f64::NAN);
    }
    let t: Vec<f64> = samples.iter().map(|s| s.t_in_step_s).collect();
    let yaw = unwrap_angles(&samples.iter().map(|s| s.m.pose.yaw_rad).collect::<Vec<_>>());
    let mut sx = vec![0.0; n];
    let mut sy = vec![0.0; n];
    for i in 1..n {
        let (dx, dy) = (
            samples[i].m.pose.x_m - samples[i - 1].m.pose.x_m,
            samples[i].m.pose.y_m - samples[i - 1].m.pose.y_m,
        );
        let (s, c) = (0.5 * (yaw[i] + yaw[i - 1])).sin_cos();
        sx[i] = sx[i - 1] + c * dx + s * dy;
        sy[i] = sy[i - 1] - s * dx + c * dy;
    }
    let slope = |y: &[f64]| local_slope(&t, y, n)[0];
    BodyVelocity::new(slope(&sx), slope(&sy), slope(&yaw))
}

/// Mean body acceleration over the middle of a (transient) window, from the pose and from the
/// IMU, as `[imu_ax, imu_ay, pose_ax, pose_ay]` (m/s²).
///
/// The pose side differences the whole-half line-fit velocities of the two halves of the
/// window (robust to the ICP jitter that ruins a second derivative per sample) and adds the
/// rotating-frame terms: `ax = Δvx/Δt − wz vy`, `ay = Δvy/Δt + wz vx`. The IMU side is the mean
/// specific force between the two half-centres. `None` with fewer than 8 samples.
pub fn half_window_acceleration(samples: &[Sample]) -> Option<[f64; 4]> {
    let n = samples.len();
    if n < 8 {
        return None;
    }
    let (a, b) = samples.split_at(n / 2);
    let (va, vb) = (window_mean_body_velocity(a), window_mean_body_velocity(b));
    let mean_t = |s: &[Sample]| s.iter().map(|x| x.t_in_step_s).sum::<f64>() / s.len() as f64;
    let (ta, tb) = (mean_t(a), mean_t(b));
    let dt = tb - ta;
    if dt <= 0.0 {
        return None;
    }
    let wz = 0.5 * (va.wz_rad_s + vb.wz_rad_s);
    let vx = 0.5 * (va.vx_m_s + vb.vx_m_s);
    let vy = 0.5 * (va.vy_m_s + vb.vy_m_s);
    let mid: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.t_in_step_s >= ta && s.t_in_step_s <= tb)
        .collect();
    let m = mid.len().max(1) as f64;
    Some([
        mid.iter().map(|s| s.m.imu.ax_m_s2).sum::<f64>() / m,
        mid.iter().map(|s| s.m.imu.ay_m_s2).sum::<f64>() / m,
        (vb.vx_m_s - va.vx_m_s) / dt - wz * vy,
        (vb.vy_m_s - va.vy_m_s) / dt + wz * vx,
    ])
}

/// Every velocity estimate of one sample of one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleKinematics {
    /// Window index (0 transient).
    pub window: u32,
    /// Time in the step, s.
    pub t_s: f64,
    /// Body velocity from the pose (vx, vy from positions rotated into the body frame, wz from yaw).
    pub pose: BodyVelocity,
    /// Body-frame acceleration from the pose velocity: `ax = dvx/dt - wz vy`, `ay = dvy/dt + wz vx`.
    pub pose_acc_m_s2: (f64, f64),
    /// IMU yaw rate, rad/s.
    pub imu_wz_rad_s: f64,
    /// IMU specific force (x, y), m/s².
    pub imu_acc_m_s2: (f64, f64),
    /// Encoder wheel speeds, rad/s.
    pub enc: WheelSpeeds,
    /// Body velocity the nominal IDD gives for the encoder speeds.
    pub enc_body: BodyVelocity,
    /// Commanded wheel speeds, rad/s.
    pub cmd: WheelSpeeds,
    /// True when the derivative neighbourhood is symmetric (not clipped by the window's ends):
    /// only such samples carry undistorted timing for the latency estimate.
    pub centered: bool,
}

/// The body velocity from the pose of each sample of one window (in time order), and the time
/// each one belongs to.
pub struct PoseVelocities {
    /// Mean time of each sample's derivative neighbourhood, s: where its slope is unbiased.
    pub t_mid_s: Vec<f64>,
    /// vx, vy (positions rotated into the body frame) and wz (yaw) of each sample.
    pub v: Vec<BodyVelocity>,
}

/// The pose velocities of one window's samples (in time order): what [`window_kinematics`]
/// builds on, and all that calibration's replays need (it skips the accelerations, a third of
/// the cost, on every model evaluation).
pub fn window_pose_velocities(samples: &[Sample], half_width: usize) -> PoseVelocities {
    let t: Vec<f64> = samples.iter().map(|s| s.t_in_step_s).collect();
    let x: Vec<f64> = samples.iter().map(|s| s.m.pose.x_m).collect();
    let y: Vec<f64> = samples.iter().map(|s| s.m.pose.y_m).collect();
    let yaw = unwrap_angles(&samples.iter().map(|s| s.m.pose.yaw_rad).collect::<Vec<_>>());
    let dx = local_slope(&t, &x, half_width);
    let dy = local_slope(&t, &y, half_width);
    let dyaw = local_slope(&t, &yaw, half_width);
    // The slope of a line fitted over a (possibly one-sided, at the window's ends) neighbourhood
    // is the velocity at the neighbourhood's mean time; rotate it with the mean heading over the
    // same samples, not the heading of sample i, or the ends get a spurious lateral speed
    // (v sin(wz dt): 0.12 m/s at 2 m/s, 0.8 rad/s).
    let t_mid_s = local_mean(&t, half_width);
    let yaw_mid = local_mean(&yaw, half_width);
    let v = (0..t.len())
        .map(|i| {
            let (s, c) = yaw_mid[i].sin_cos();
            // World (window-frame) velocity rotated into the body frame by -yaw.
            BodyVelocity::new(c * dx[i] + s * dy[i], -s * dx[i] + c * dy[i], dyaw[i])
        })
        .collect();
    PoseVelocities { t_mid_s, v }
}

/// Estimates every velocity of the samples of one window (in time order).
pub fn window_kinematics(
    samples: &[Sample],
    half_width: usize,
    idd: &IdealDiffDrive,
) -> Vec<SampleKinematics> {
    let PoseVelocities { t_mid_s, v } = window_pose_velocities(samples, half_width);
    let n = v.len();
    let vx: Vec<f64> = v.iter().map(|v| v.vx_m_s).collect();
    let vy: Vec<f64> = v.iter().map(|v| v.vy_m_s).collect();
    let dvx = local_slope(&t_mid_s, &vx, half_width);
    let dvy = local_slope(&t_mid_s, &vy, half_width);
    (0..n)
        .map(|i| {
            let m = &samples[i].m;
            let wz = v[i].wz_rad_s;
            SampleKinematics {
                window: samples[i].window,
                t_s: samples[i].t_in_step_s,
                pose: v[i],
                pose_acc_m_s2: (dvx[i] - wz * vy[i], dvy[i] + wz * vx[i]),
                imu_wz_rad_s: m.imu.wz_rad_s,
                imu_acc_m_s2: (m.imu.ax_m_s2, m.imu.ay_m_s2),
                enc: m.enc,
                enc_body: idd.body_from_wheels(m.enc),
                cmd: m.cmd,
                centered: i >= half_width && i + half_width < n,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_log::{Measurement, Pose};

    fn circle_samples(v: f64, w: f64, noise_m: f64) -> Vec<Sample> {
        // Robot on a circle of radius v / w starting at heading 2.5 rad in an arbitrary frame.
        let psi0 = 2.5; // crosses +pi during the window: exercises unwrapping
        (0..40)
            .map(|k| {
                let t = k as f64 / 20.0;
                let psi = psi0 + w * t;
                let r = v / w;
                // Deterministic pseudo-noise (alternating sign) to exercise the smoothing.
                let n = if k % 2 == 0 { noise_m } else { -noise_m };
                let pose = Pose {
                    x_m: r * (psi.sin() - psi0.sin()) + n,
                    y_m: -r * (psi.cos() - psi0.cos()) - n,
                    // Wrapped to (-pi, pi] as a real sensor reports it.
                    yaw_rad: (psi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI,
                    ..Default::default()
                };
                Sample {
                    step: 0,
                    window: 1,
                    k,
                    t_in_step_s: 2.0 + t,
                    stamp_s: 2.0 + t,
                    m: Measurement {
                        pose,
                        ..Default::default()
                    },
                }
            })
            .collect()
    }

    #[test]
    fn circle_gives_constant_body_velocity() {
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        let k = window_kinematics(&circle_samples(2.0, 0.8, 0.0), 3, &idd);
        for s in &k {
            // On a circle the body velocity is (v, 0, w) exactly, at the window's ends too; the
            // line fit of a sinusoid over 0.3 s is biased by about (w dt)^2 terms: a few 1e-3.
            assert!((s.pose.vx_m_s - 2.0).abs() < 5e-3, "{:?}", s.pose);
            assert!(s.pose.vy_m_s.abs() < 5e-3, "{:?}", s.pose);
            assert!((s.pose.wz_rad_s - 0.8).abs() < 1e-9);
        }
        for s in &k[3..37] {
            // Centripetal acceleration v w = 1.6 m/s² along +y (interior: the second
            // derivative at the ends uses one-sided fits twice).
            assert!((s.pose_acc_m_s2.1 - 1.6).abs() < 0.02, "{:?}", s.pose_acc_m_s2);
            assert!(s.pose_acc_m_s2.0.abs() < 0.02);
        }
        // With ±1 cm alternating noise the 7-point fit keeps vx within a few cm/s.
        let noisy = window_kinematics(&circle_samples(2.0, 0.8, 0.01), 3, &idd);
        let mean_vx = noisy.iter().map(|s| s.pose.vx_m_s).sum::<f64>() / 40.0;
        assert!((mean_vx - 2.0).abs() < 0.02, "{mean_vx}");
    }

    #[test]
    fn window_mean_on_a_circle_and_with_jitter() {
        // Exact on a circle: chords at mid-heading give v sinc(w dt / 2) = v (1 - 2.7e-4).
        let v = window_mean_body_velocity(&circle_samples(2.0, 0.8, 0.0));
        assert!(
            (v.vx_m_s - 2.0).abs() < 1e-3 && v.vy_m_s.abs() < 1e-9 && (v.wz_rad_s - 0.8).abs() < 1e-9,
            "{v:?}"
        );
        // Sample-and-hold jitter of the positions (every other sample repeats the previous
        // one) leaves the line fit within 2 % while an end-point difference can be off by a
        // whole sample when the last sample is a held one.
        let mut s = circle_samples(2.0, 0.0001, 0.0);
        for k in (1..40).step_by(2) {
            s[k].m.pose = s[k - 1].m.pose;
        }
        let v = window_mean_body_velocity(&s);
        assert!((v.vx_m_s - 2.0).abs() < 0.04, "{v:?}");
    }

    #[test]
    fn unwrap_removes_jumps() {
        let a = [3.0, 3.1, -3.1, -3.0];
        let u = unwrap_angles(&a);
        assert!((u[2] - (std::f64::consts::TAU - 3.1)).abs() < 1e-12);
        assert!((u[3] - u[2] - 0.1).abs() < 1e-12);
    }

    #[test]
    fn slope_of_a_line() {
        let t: Vec<f64> = (0..10).map(|i| i as f64 * 0.05).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * t - 1.0).collect();
        assert!(local_slope(&t, &y, 3).iter().all(|s| (s - 3.0).abs() < 1e-12));
    }
}
