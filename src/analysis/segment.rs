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
