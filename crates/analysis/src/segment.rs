//! Segmentation of a log into steps and windows, with explicit exclusions.
//!
//! A step is analysed only if every window `0..windows_per_step` is present, each with at least
//! `min_samples_per_window` samples, every measurement is finite, the recording has no gap, the
//! pose no jump, and the pose and the encoders agree on which way the robot goes in the steady
//! windows. Anything else is excluded with a reason that the result lists: nothing is dropped
//! silently. Calibration drops the same steps ([`usable_steps`]): one definition of a step the
//! data can be trusted on.

use drive_sim_log::{DriveLog, Sample};
use serde::{Deserialize, Serialize};

/// The samples of one complete step, split by window (index = window number).
#[derive(Debug, Clone)]
pub struct StepSegment<'a> {
    /// Step index.
    pub step: u32,
    /// Samples of each window, in time order.
    pub windows: Vec<&'a [Sample]>,
}

/// A step left out of the analysis, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Exclusion {
    /// Step index.
    pub step: u32,
    /// Human-readable reason.
    pub reason: String,
}

/// Whether the log has an IMU: a log read from a bag without one has NaN IMU readings
/// throughout.
pub fn has_imu(log: &DriveLog) -> bool {
    log.samples.iter().any(|s| {
        let i = &s.m.imu;
        [i.wz_rad_s, i.ax_m_s2, i.ay_m_s2, i.az_m_s2]
            .iter()
            .any(|v| !v.is_nan())
    })
}

/// Whether every measurement of `s` is finite; the IMU's only when the log has one.
fn sample_is_finite(s: &Sample, imu: bool) -> bool {
    let m = &s.m;
    let i = &m.imu;
    m.cmd.is_finite()
        && m.enc.is_finite()
        && m.pose.is_finite()
        && s.t_in_step_s.is_finite()
        && (!imu
            || [i.wz_rad_s, i.ax_m_s2, i.ay_m_s2, i.az_m_s2]
                .iter()
                .all(|v| v.is_finite()))
}

/// A gap in the samples of a step: two consecutive samples further apart in time than 2.5
/// sample periods (a dropped stretch of recording), or going back in time.
fn time_gap(block: &[Sample], meta: &drive_sim_log::LogMeta) -> Option<String> {
    let period = 1.0 / meta.rate_hz;
    block.windows(2).find_map(|p| {
        let dt = p[1].t_in_step_s - p[0].t_in_step_s;
        (!(dt > 0.0 && dt <= 2.5 * period)).then(|| {
            format!(
                "gap in the recording: {dt:.3} s between window {} sample {} and window {} sample {} \
                 (the sample period is {period:.3} s)",
                p[0].window, p[0].k, p[1].window, p[1].k
            )
        })
    })
}

/// A pose outlier (a localisation jump): a pose far from the midpoint of its two neighbours in
/// the same window. The second difference is small on any drivable path, also on measured logs
/// whose localisation holds a pose for a few samples and then catches up (up to 1.5 m on the
/// Warthog datasets); the threshold, 12 top-speed sample periods and at least 3 m, leaves those
/// alone and catches a jump of meters.
fn pose_jump(block: &[Sample], meta: &drive_sim_log::LogMeta) -> Option<String> {
    let period = 1.0 / meta.rate_hz;
    let limit_m = (12.0 * meta.nominal.max_lin_m_s * period).max(3.0);
    // The largest second difference names the sample: a spike of d also moves its two
    // neighbours' second differences by d/2.
    let (d, at) = block
        .windows(3)
        .filter(|t| t[0].window == t[1].window && t[1].window == t[2].window)
        .map(|t| {
            let (a, b, c) = (t[0].m.pose, t[1].m.pose, t[2].m.pose);
            let d = ((b.x_m - (a.x_m + c.x_m) / 2.0).powi(2)
                + (b.y_m - (a.y_m + c.y_m) / 2.0).powi(2)
                + (b.z_m - (a.z_m + c.z_m) / 2.0).powi(2))
            .sqrt();
            (d, &t[1])
        })
        .max_by(|x, y| x.0.total_cmp(&y.0))?;
    (d > limit_m).then(|| {
        format!(
            "pose outlier (localisation jump): the pose at window {} sample {} is {d:.2} m off \
             the path of its neighbours (more than {limit_m:.1} m)",
            at.window, at.k
        )
    })
}

/// What a step must satisfy to be analysed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentRules {
    /// Minimum samples per window.
    pub min_samples_per_window: usize,
    /// A steady window whose pose moves along the heading against the encoders' direction,
    /// both faster than this, excludes its step (m/s); `None` switches the check off.
    pub pose_contradiction_m_s: Option<f64>,
}

/// The speed above which a pose moving against its wheels may be a localisation fault, m/s.
///
/// Why a speed and more: a body can move against its wheels, for a while. DRIVE runs its steps
/// back to back, so a step that reverses the previous one starts with the body sliding the
/// other way, and on ice (peak friction 0.13) a 5 m/s slide lasts nearly 4 s, into the first
/// steady window (the simulated Warthog on ice does this); a robot spinning while it slides
/// sees its slide pass from ahead to behind. But such a body decelerates towards its wheels
/// (at least [`MIN_SLIDE_DECELERATION_M_S2`]), and no force turns it from going with its
/// wheels to going against them (see `pose_contradicts_encoders` for the two tests). The
/// measured asphalt run has two such windows (steps 71 and 90: the pose goes backwards at
/// 2.5-3.1 m/s right after going forwards at 3.4-3.6 m/s, the wheels driving forwards at
/// 3.4-3.5 m/s throughout, the heading turning by 0.6-0.7 rad, the source's own velocity
/// estimate agreeing with the pose): the position there is not in the frame the yaw is.
/// Steps of the same kind at large heading changes (asphalt 23, 93, 96, gravel 75) are left
/// in: rotation could explain them, so the check does not call them faults.
pub const POSE_CONTRADICTION_M_S: f64 = 1.0;

/// The least deceleration of a body sliding against its wheels, m/s²: friction 0.05 (below
/// the measured ice's 0.13, and any ground a wheeled robot drives on) times g.
pub const MIN_SLIDE_DECELERATION_M_S2: f64 = 0.05 * 9.81;

impl SegmentRules {
    /// The rules for a log with `samples_per_window` declared samples: at least 3/4 of them,
    /// and the pose check at [`POSE_CONTRADICTION_M_S`].
    pub fn for_samples_per_window(samples_per_window: u32) -> Self {
        Self {
            min_samples_per_window: (samples_per_window as usize * 3).div_ceil(4).max(2),
            pose_contradiction_m_s: Some(POSE_CONTRADICTION_M_S),
        }
    }
}

/// The most the heading may turn within a window for its deceleration to be judged, rad: a
/// turning robot's body-frame velocity turns with it (a slide seen from a spinning robot
/// passes from ahead to behind without any force), so "a slide slows towards the wheels" only
/// holds at a nearly fixed heading.
pub const MAX_HEADING_CHANGE_RAD: f64 = 0.5;

/// A steady window (any but the first, transient one) whose pose moves along the heading
/// against the direction the encoders drive, both faster than `min_m_s`, where either
/// - the heading turns less than [`MAX_HEADING_CHANGE_RAD`] and the body does not decelerate
///   towards the wheels as a sliding body must, or
/// - the window before went with the wheels, and turning the previous window's mean velocity
///   by the heading change between the two windows' middles cannot bring it this far against
///   them (friction only pulls a body towards what its wheels drive, so the velocity along
///   the wheels' direction can fall no lower than rotation takes it): the body cannot have
///   turned from its wheels' direction to the other while they kept driving.
///
/// The pose cannot be trusted there (see [`POSE_CONTRADICTION_M_S`]). Each window's heading
/// change is its own (measured logs restart the pose frame at every window).
fn pose_contradicts_encoders(windows: &[Option<&[Sample]>], radius_m: f64, min_m_s: f64) -> Option<String> {
    let velocity = super::velocity::window_mean_body_velocity;
    let enc = |w: &[Sample]| {
        radius_m
            * w.iter()
                .map(|s| s.m.enc.left_rad_s + s.m.enc.right_rad_s)
                .sum::<f64>()
            / (2.0 * w.len().max(1) as f64)
    };
    let turn = |w: &[Sample]| {
        let u = super::velocity::unwrap_angles(&w.iter().map(|s| s.m.pose.yaw_rad).collect::<Vec<_>>());
        let (lo, hi) = u.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &y| {
            (a.0.min(y), a.1.max(y))
        });
        hi - lo
    };
    let flat: Vec<&[Sample]> = windows.iter().flatten().copied().collect();
    flat.iter().enumerate().skip(1).find_map(|(i, w)| {
        let n = w.len();
        if n < 8 {
            return None;
        }
        // The encoders first: most windows end here without a pose derivative.
        let wheels = enc(w);
        if wheels.abs() <= min_m_s {
            return None;
        }
        let s = wheels.signum();
        let pose = velocity(w).vx_m_s;
        if !(pose * wheels < 0.0 && pose.abs() > min_m_s) {
            return None;
        }
        // Deceleration towards the wheels between the two halves' mean velocities.
        let (a, b) = w.split_at(n / 2);
        let centre = |p: &[Sample]| p.iter().map(|s| s.t_in_step_s).sum::<f64>() / p.len() as f64;
        let towards = s * (velocity(b).vx_m_s - velocity(a).vx_m_s) / (centre(b) - centre(a));
        let steady_against = turn(w) <= MAX_HEADING_CHANGE_RAD && towards < MIN_SLIDE_DECELERATION_M_S2;
        // The least velocity along the wheels' direction that rotation leaves of the window
        // before's.
        let before = velocity(flat[i - 1]);
        let theta = (0.5 * (turn(flat[i - 1]) + turn(w))).min(std::f64::consts::FRAC_PI_2);
        let least = s * before.vx_m_s * theta.cos() - before.vy_m_s.abs() * theta.sin();
        let reversed = s * before.vx_m_s > min_m_s && s * pose < least - min_m_s;
        (steady_against || reversed).then(|| {
            let why = if reversed {
                format!(
                    "after moving {:+.2} m/s with them in the window before, which turning by \
                     {theta:.2} rad leaves at {:+.2} m/s at the least",
                    before.vx_m_s,
                    s * least
                )
            } else {
                format!(
                    "at a heading turning less than {MAX_HEADING_CHANGE_RAD} rad, without slowing \
                     towards them ({towards:+.2} m/s², a slide would at least \
                     {MIN_SLIDE_DECELERATION_M_S2:.2})"
                )
            };
            format!(
                "pose contradicts the encoders (localisation fault): in window {} the pose moves \
                 {pose:+.2} m/s along the heading while the wheels drive {wheels:+.2} m/s, {why}",
                w[0].window
            )
        })
    })
}

/// The steps of `log` that `rules` keep, and the others with why: what calibration replays.
pub fn usable_steps(log: &DriveLog, rules: &SegmentRules) -> (Vec<u32>, Vec<Exclusion>) {
    let (steps, exclusions) = segment(log, rules);
    (steps.iter().map(|s| s.step).collect(), exclusions)
}

/// Splits `log.samples` into complete steps; the others become [`Exclusion`]s.
pub fn segment<'a>(log: &'a DriveLog, rules: &SegmentRules) -> (Vec<StepSegment<'a>>, Vec<Exclusion>) {
    let min_samples_per_window = rules.min_samples_per_window;
    let wps = log.meta.windows_per_step as usize;
    let mut steps = Vec::new();
    let mut exclusions = Vec::new();
    let samples = &log.samples;
    let imu = has_imu(log);
    let mut i = 0;
    while i < samples.len() {
        let step = samples[i].step;
        let mut j = i;
        while j < samples.len() && samples[j].step == step {
            j += 1;
        }
        let block = &samples[i..j];
        i = j;
        // Windows as contiguous runs; a window index seen twice or out of order is a defect.
        let mut windows: Vec<Option<&[Sample]>> = vec![None; wps];
        let mut problem: Option<String> = None;
        let mut a = 0;
        while a < block.len() {
            let w = block[a].window as usize;
            let mut b = a;
            while b < block.len() && block[b].window as usize == w {
                b += 1;
            }
            if w >= wps {
                problem = Some(format!("window {w} out of range 0..{wps}"));
                break;
            }
            if windows[w].is_some() {
                problem = Some(format!("window {w} appears twice or out of order"));
                break;
            }
            windows[w] = Some(&block[a..b]);
            a = b;
        }
        if problem.is_none() {
            let missing: Vec<String> = (0..wps)
                .filter(|&w| windows[w].is_none())
                .map(|w| w.to_string())
                .collect();
            if !missing.is_empty() {
                problem = Some(format!("missing window(s) {}", missing.join(", ")));
            }
        }
        if problem.is_none() {
            for (w, win) in windows.iter().enumerate() {
                let n = win.map_or(0, |s| s.len());
                if n < min_samples_per_window {
                    problem = Some(format!(
                        "window {w} has {n} samples, fewer than the {min_samples_per_window} required"
                    ));
                    break;
                }
            }
        }
        if problem.is_none() {
            if let Some(bad) = block.iter().find(|s| !sample_is_finite(s, imu)) {
                problem = Some(format!(
                    "non-finite measurement at window {}, sample {}",
                    bad.window, bad.k
                ));
            }
        }
        if problem.is_none() {
            problem = time_gap(block, &log.meta)
                .or_else(|| pose_jump(block, &log.meta))
                .or_else(|| {
                    rules
                        .pose_contradiction_m_s
                        .and_then(|v| pose_contradicts_encoders(&windows, log.meta.nominal.wheel_radius_m, v))
                });
        }
        match problem {
            Some(reason) => exclusions.push(Exclusion { step, reason }),
            None => steps.push(StepSegment {
                step,
                windows: windows.into_iter().flatten().collect(),
            }),
        }
    }
    (steps, exclusions)
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_log::{Measurement, Pose};
    use drive_sim_model::kinematics::WheelSpeeds;

    const R: f64 = 0.3;

    /// Three 2 s windows at 20 Hz of a robot on a straight line along x, heading `yaw_rad`
    /// (the pose moves along its heading at `v(t)`), the wheels at `wheel_rad_s`.
    fn step(v: impl Fn(f64) -> f64, wheel_rad_s: f64, yaw_rad: f64) -> Vec<Sample> {
        let mut s = 0.0;
        (0..120)
            .map(|i| {
                let t = i as f64 / 20.0;
                if i > 0 {
                    s += v(t - 0.025) / 20.0;
                }
                Sample {
                    step: 0,
                    window: i / 40,
                    k: i % 40,
                    t_in_step_s: t,
                    stamp_s: t,
                    m: Measurement {
                        enc: WheelSpeeds::new(wheel_rad_s, wheel_rad_s),
                        pose: Pose {
                            x_m: s * yaw_rad.cos(),
                            y_m: s * yaw_rad.sin(),
                            yaw_rad,
                            ..Default::default()
                        },
                        ..Default::default()
                    },
                }
            })
            .collect()
    }

    fn check(samples: &[Sample]) -> Option<String> {
        let w: Vec<Option<&[Sample]>> = samples.chunks(40).map(Some).collect();
        pose_contradicts_encoders(&w, R, POSE_CONTRADICTION_M_S)
    }

    #[test]
    fn a_slide_against_the_wheels_is_physics_and_a_steady_one_is_a_fault() {
        // Wheels forward at 3 m/s from the start; the body slides backwards from 5 m/s and
        // decelerates at 1.27 m/s² (ice): still -1.2 m/s on average in window 1. Kept.
        let ice = step(|t| (-5.0 + 1.27 * t).min(3.0), 10.0, 0.7);
        assert_eq!(check(&ice), None);
        // The same mean speed against the wheels but steady: not a slide.
        let steady = step(|_| -1.5, 10.0, 0.7);
        let why = check(&steady).expect("a steady motion against the wheels is a fault");
        assert!(
            why.contains("window 1") && why.contains("without slowing"),
            "{why}"
        );
        // With the wheels in window 1, against them in window 2: no ground does that.
        let reversed = step(|t| if t < 4.0 { 3.0 } else { -2.5 }, 10.0, -2.0);
        let why = check(&reversed).expect("a reversal away from the wheels is a fault");
        assert!(why.contains("window 2") && why.contains("window before"), "{why}");
        // A robot spinning while it moves against its wheels: its body-frame velocity turns
        // with it, the argument does not hold, nothing is said.
        let mut spinning = steady.clone();
        for x in &mut spinning {
            x.m.pose.yaw_rad += 0.8 * x.t_in_step_s;
        }
        assert_eq!(check(&spinning), None);
        // Slow (below 1 m/s) or with the wheels: nothing to say.
        assert_eq!(check(&step(|_| -0.8, 10.0, 0.0)), None);
        assert_eq!(check(&step(|_| 2.7, 10.0, 3.0)), None);
        assert_eq!(check(&step(|_| -2.7, -10.0, 3.0)), None);
    }
}
