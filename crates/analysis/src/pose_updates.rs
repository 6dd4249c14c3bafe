//! How often the logged pose changes: the lidar odometry's update intervals.
//!
//! Why: a DRIVE logger samples the last pose its odometry published. When scan matching is
//! slower than the logger, the logged pose stands still for a few samples and jumps, and a
//! window's velocity, a slope through its poses, moves with where the jumps fall against the
//! window's ends. On the measured Warthog runs the pose changes about once in four samples at
//! 20 Hz; a simulator that reads a pose at every sample gives its windows none of that scatter.
//! This module measures the intervals on a log so that a twin's odometry
//! (`drive_sim_model`'s `pose_updates` effect) can be given the log's, by moments: the model's
//! intervals are `period + jitter · Exp(1)` (mean `period + jitter`, variance `jitter²`), and
//! sampling at `Δ` adds about `Δ²/6` to the variance (an interval's fractional part in samples,
//! uniform, rounds it up or down), so `jitter = √(v − Δ²/6)`, `period = m − jitter`.

use drive_sim_model::measurement::{Pose, Sample};
use serde::{Deserialize, Serialize};

/// Fewer intervals than this and the moments are not reported.
pub const MIN_INTERVALS: usize = 20;

/// The pose stream's update intervals over a log's windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseUpdates {
    /// Samples read (consecutive pairs inside a window of a commanded step).
    pub samples: usize,
    /// Share of those whose pose repeats the one before exactly.
    pub held_share: f64,
    /// Complete intervals between two pose changes inside one window.
    pub intervals: usize,
    /// Their mean, s.
    pub mean_interval_s: f64,
    /// Their standard deviation, s.
    pub interval_sd_s: f64,
    /// The logger's sample period Δ, s.
    pub sample_period_s: f64,
    /// Shortest interval of the model `period + jitter · Exp(1)` with these moments, s.
    pub period_s: f64,
    /// Mean of its exponential part, s.
    pub jitter_s: f64,
}

impl PoseUpdates {
    /// The intervals of several logs of one robot taken together (their moments pooled, each
    /// log weighted by its intervals); `None` for none. The logs' sample periods are taken as
    /// equal (the first one's).
    pub fn pooled(logs: &[PoseUpdates]) -> Option<PoseUpdates> {
        let first = logs.first()?;
        let n: usize = logs.iter().map(|p| p.intervals).sum();
        let w = |p: &PoseUpdates| p.intervals as f64 / n as f64;
        let mean: f64 = logs.iter().map(|p| w(p) * p.mean_interval_s).sum();
        let second: f64 = logs
            .iter()
            .map(|p| w(p) * (p.interval_sd_s.powi(2) + p.mean_interval_s.powi(2)))
            .sum();
        let samples: usize = logs.iter().map(|p| p.samples).sum();
        let held: f64 = logs.iter().map(|p| p.held_share * p.samples as f64).sum();
        Some(from_moments(
            samples,
            held / samples as f64,
            n,
            mean,
            (second - mean * mean).max(0.0),
            first.sample_period_s,
        ))
    }

    /// Whether the odometry published at every sample (no interval longer than one sample):
    /// nothing for a twin to hold.
    pub fn every_sample(&self) -> bool {
        self.mean_interval_s <= 1.01 * self.sample_period_s
    }
}

impl std::fmt::Display for PoseUpdates {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pose updates: {:.0} % of the samples repeat the pose before; a change every {:.3} s (sd {:.3}, {} intervals): period {:.3} s + jitter {:.3} s",
            100.0 * self.held_share,
            self.mean_interval_s,
            self.interval_sd_s,
            self.intervals,
            self.period_s,
            self.jitter_s
        )
    }
}

fn same(a: &Pose, b: &Pose) -> bool {
    a.x_m == b.x_m && a.y_m == b.y_m && a.yaw_rad == b.yaw_rad
}

/// The update intervals of `samples` (ordered by step, then time), logged every
/// `sample_period_s`: inside each window of a step that commands the wheels (a stop is not a
/// DRIVE step), the times between successive pose changes. `None` below [`MIN_INTERVALS`].
pub fn pose_updates(samples: &[Sample], sample_period_s: f64) -> Option<PoseUpdates> {
    let (mut read, mut held) = (0usize, 0usize);
    let mut intervals = Vec::new();
    let mut last_change: Option<f64> = None;
    for pair in samples.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if a.step != b.step || a.window != b.window {
            last_change = None;
            continue;
        }
        if b.m.cmd.left_rad_s == 0.0 && b.m.cmd.right_rad_s == 0.0 {
            continue;
        }
        read += 1;
        if same(&a.m.pose, &b.m.pose) {
            held += 1;
            continue;
        }
        if let Some(t) = last_change {
            intervals.push(b.t_in_step_s - t);
        }
        last_change = Some(b.t_in_step_s);
    }
    if intervals.len() < MIN_INTERVALS || sample_period_s.is_nan() || sample_period_s <= 0.0 {
        return None;
    }
    let n = intervals.len() as f64;
    let mean = intervals.iter().sum::<f64>() / n;
    let var = intervals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    Some(from_moments(
        read,
        held as f64 / read as f64,
        intervals.len(),
        mean,
        var,
        sample_period_s,
    ))
}

/// The model `period + jitter · Exp(1)` with the intervals' mean and variance (the module's
/// doc says why `Δ²/6` comes off the variance).
fn from_moments(
    samples: usize,
    held_share: f64,
    intervals: usize,
    mean: f64,
    var: f64,
    sample_period_s: f64,
) -> PoseUpdates {
    let jitter = (var - sample_period_s.powi(2) / 6.0).max(0.0).sqrt();
    PoseUpdates {
        samples,
        held_share,
        intervals,
        mean_interval_s: mean,
        interval_sd_s: var.sqrt(),
        sample_period_s,
        period_s: (mean - jitter).max(0.0),
        jitter_s: jitter,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::WheelSpeeds;
    use drive_sim_model::measurement::Measurement;

    /// A log written by a generator of its own (not the model's odometry): poses published at
    /// known instants, read at 20 Hz.
    fn log(update_times: &dyn Fn(u32) -> Vec<f64>, steps: u32) -> Vec<Sample> {
        let mut out = Vec::new();
        for step in 0..steps {
            let updates = update_times(step);
            for window in 0..3u32 {
                for k in 0..40u32 {
                    let t = window as f64 * 2.0 + k as f64 * 0.05;
                    // The pose published last: its index among the updates.
                    let i = updates.iter().take_while(|&&u| u <= t + 1e-9).count();
                    let mut m = Measurement {
                        cmd: WheelSpeeds::new(5.0, 5.0),
                        ..Measurement::default()
                    };
                    m.pose.x_m = i as f64;
                    out.push(Sample {
                        step,
                        window,
                        k,
                        t_in_step_s: t,
                        stamp_s: step as f64 * 6.0 + t,
                        m,
                    });
                }
            }
        }
        out
    }

    /// Updates every 0.2 s (four samples) exactly: no jitter, period 0.2 s, three samples in
    /// four held.
    #[test]
    fn a_steady_five_hertz_odometry_is_measured() {
        let every = |_| (0..31).map(|i| 0.01 + 0.2 * i as f64).collect();
        let p = pose_updates(&log(&every, 10), 0.05).unwrap();
        assert!((p.mean_interval_s - 0.2).abs() < 1e-9, "{p:?}");
        assert!(p.jitter_s < 1e-9 && (p.period_s - 0.2).abs() < 1e-9, "{p:?}");
        assert!((p.held_share - 0.75).abs() < 0.02, "{p:?}");
        assert!(!p.every_sample());
    }

    /// Intervals `0.1 + 0.1 · Exp(1)` from a generator's own random numbers: the moments find
    /// period and jitter within a few hundredths of a second.
    #[test]
    fn jittered_updates_give_back_their_period_and_jitter() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut times = Vec::new();
        for _ in 0..400 {
            let mut t = -rng.random_range(0.0..0.2);
            let mut v = Vec::new();
            while t < 6.0 {
                t += 0.1 - 0.1 * (1.0 - rng.random_range(0.0f64..1.0)).ln();
                v.push(t);
            }
            times.push(v);
        }
        let p = pose_updates(&log(&|s| times[s as usize].clone(), 400), 0.05).unwrap();
        assert!((p.period_s - 0.1).abs() < 0.03, "{p:?}");
        assert!((p.jitter_s - 0.1).abs() < 0.03, "{p:?}");
    }

    /// The null case: a pose at every sample is measured as such.
    #[test]
    fn a_pose_at_every_sample_holds_nothing() {
        let every = |_| (0..121).map(|i| 0.05 * i as f64 - 1e-6).collect();
        let p = pose_updates(&log(&every, 5), 0.05).unwrap();
        assert_eq!(p.held_share, 0.0);
        assert!(p.every_sample(), "{p:?}");
        assert!(p.jitter_s < 1e-6, "{p:?}");
    }

    /// Two logs pooled give the moments of their intervals taken together: a log pooled with
    /// itself is itself, and a steady 5 Hz log with a steady 10 Hz one of as many intervals has
    /// mean 0.15 s and standard deviation 0.05 s.
    #[test]
    fn pooled_logs_add_their_intervals() {
        let five = |_| (0..31).map(|i| 0.01 + 0.2 * i as f64).collect();
        let ten = |_| (0..61).map(|i| 0.01 + 0.1 * i as f64).collect();
        let a = pose_updates(&log(&five, 19), 0.05).unwrap();
        let b = pose_updates(&log(&ten, 9), 0.05).unwrap();
        assert_eq!(a.intervals, b.intervals);
        let same = PoseUpdates::pooled(&[a, a]).unwrap();
        assert!((same.mean_interval_s - a.mean_interval_s).abs() < 1e-12);
        assert!((same.jitter_s - a.jitter_s).abs() < 1e-6);
        let both = PoseUpdates::pooled(&[a, b]).unwrap();
        assert!((both.mean_interval_s - 0.15).abs() < 1e-9, "{both:?}");
        assert!((both.interval_sd_s - 0.05).abs() < 1e-9, "{both:?}");
        assert!(PoseUpdates::pooled(&[]).is_none());
    }
}
