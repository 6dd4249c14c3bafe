//! Segmentation of a log into steps and windows, with explicit exclusions.
//!
//! A step is analysed only if every window `0..windows_per_step` is present, each with at least
//! `min_samples_per_window` samples, and every measurement is finite. Anything else is excluded
//! with a reason that the result lists: nothing is dropped silently.

use crate::log::{DriveLog, Sample};
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

fn sample_is_finite(s: &Sample) -> bool {
    let m = &s.m;
    m.cmd.is_finite()
        && m.enc.is_finite()
        && m.pose.is_finite()
        && [
            m.imu.wz_rad_s,
            m.imu.ax_m_s2,
            m.imu.ay_m_s2,
            m.imu.az_m_s2,
            s.t_in_step_s,
        ]
        .iter()
        .all(|v| v.is_finite())
}

/// A gap in the samples of a step: two consecutive samples further apart in time than 2.5
/// sample periods (a dropped stretch of recording), or going back in time.
fn time_gap(block: &[Sample], meta: &crate::log::LogMeta) -> Option<String> {
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
fn pose_jump(block: &[Sample], meta: &crate::log::LogMeta) -> Option<String> {
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

/// Splits `log.samples` into complete steps; the others become [`Exclusion`]s.
pub fn segment(log: &DriveLog, min_samples_per_window: usize) -> (Vec<StepSegment<'_>>, Vec<Exclusion>) {
    let wps = log.meta.windows_per_step as usize;
    let mut steps = Vec::new();
    let mut exclusions = Vec::new();
    let samples = &log.samples;
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
            if let Some(bad) = block.iter().find(|s| !sample_is_finite(s)) {
                problem = Some(format!(
                    "non-finite measurement at window {}, sample {}",
                    bad.window, bad.k
                ));
            }
        }
        if problem.is_none() {
            problem = time_gap(block, &log.meta).or_else(|| pose_jump(block, &log.meta));
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
