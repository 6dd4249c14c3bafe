//! The lidar odometry publishes a pose now and then; the logger holds the last one.

use super::step_draw::{event_exponential, event_uniform};
use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};
use crate::measurement::Pose;

/// Scan matching publishes a pose every `T_k = period + jitter · E_k` seconds (`E_k` a standard
/// exponential drawn per update): at least the lidar's period, more when the registration of a
/// scan takes longer. The DRIVE logger samples the last published pose at its own rate, so the
/// logged pose stands still between updates and jumps at each one.
///
/// Why: on the measured runs most logged poses repeat the one before while the robot moves:
/// 72–85 % of the samples on the Warthog runs (the pose changes about once in four samples at
/// 20 Hz, with holds up to twelve), 52 % on the Husky (a 10 Hz odometry read at 20 Hz)
/// (`drive-sim analyze`, its "pose updates" line; `drive_sim_analysis::pose_updates`). A
/// window's velocity is a slope through its poses, and where the updates fall against the
/// window's ends moves it: on the Warthog the body's speed over its wheels' scatters by about
/// 5 % from window to window (windows of one step independently), which a pose read at every
/// sample does not give, and which the unpredictability ρ of steps the robot drives well
/// folds into larger values. The effect is measured on a log, not fitted: its parameters come
/// from the intervals between pose changes ([`PoseUpdates`]'s doc says how).
///
/// The draws come from a hash of the run's seed and the update's index: the same seed gives
/// the same updates, and switching the effect on moves no other random draw.
pub(crate) struct PoseUpdateEffect;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "pose_update_period_s",
        unit: "s",
        kind: ParamKind::Continuous,
        min: 0.0,
        max: 5.0,
        // A pose at every reading: the effect off.
        neutral: 0.0,
        search: SearchBox::Fixed {
            lower: 0.0,
            upper: 0.5,
        },
        resolution: None,
    },
    ParamDef {
        key: "pose_update_jitter_s",
        unit: "s",
        kind: ParamKind::Continuous,
        min: 0.0,
        max: 5.0,
        neutral: 0.0,
        search: SearchBox::Fixed {
            lower: 0.0,
            upper: 0.5,
        },
        resolution: None,
    },
];

impl Effect for PoseUpdateEffect {
    fn name(&self) -> &'static str {
        "pose_updates"
    }
    fn doc(&self) -> &'static str {
        "the lidar odometry publishes a pose every period + jitter·Exp(1) s and the logger holds the last one (scan matching slower than the logger)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    /// Random holds cannot lower a least-squares replay score, and a log measures them
    /// directly: calibration never fits them; `drive-sim twin` declares them from the log.
    fn default_candidate(&self) -> bool {
        false
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.pose_update_period_s = p[0];
        m.pose_update_jitter_s = p[1];
    }
}

/// The stream of [`super::step_draw`] the updates draw from (the wheel scatter uses 0 and 1).
const STREAM: u8 = 16;
/// Longer than this behind, the next update is rescheduled from now (a plant reset, a long
/// pause): catching up one interval at a time would publish nothing new.
const MAX_BEHIND_S: f64 = 10.0;

/// The pose a logger reads from an odometry that publishes at random intervals. The plants
/// (the simulator and the kinematic surrogate) hold one each; it runs through steps and pauses
/// alike (the odometry does not know the protocol) and starts over when the plant is reset.
///
/// Measured on a log (`drive_sim_analysis`'s `pose_updates`), the intervals between pose
/// changes, sampled at `Δ`, have mean `m` and variance `v`; the model's intervals have mean
/// `period + jitter` and variance `jitter²`, and sampling adds about `Δ²/6` (an interval's
/// fractional part in samples, uniform, rounds up or down), so `jitter = √(v − Δ²/6)` and
/// `period = m − jitter`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PoseUpdates {
    /// The last published pose and the time of the next update, once the first one is read.
    state: Option<(Pose, f64)>,
    /// Updates drawn so far (the index of the next draw).
    drawn: u64,
}

impl PoseUpdates {
    /// Forgets the last update: the next reading publishes (a reset of the plant).
    pub fn restart(&mut self) {
        self.state = None;
    }

    /// The pose the logger reads at `time_s` when the odometry's pose is `pose`, with updates
    /// every `period_s + jitter_s · Exp(1)` seconds drawn from `seed`; both zero publish every
    /// reading.
    pub fn read(&mut self, pose: Pose, time_s: f64, period_s: f64, jitter_s: f64, seed: u64) -> Pose {
        if period_s <= 0.0 && jitter_s <= 0.0 {
            return pose;
        }
        let interval = |drawn: &mut u64| {
            let e = event_exponential(seed, *drawn, STREAM);
            *drawn += 1;
            period_s + jitter_s * e
        };
        match self.state {
            Some((held, next_s)) if time_s < next_s => held,
            Some((_, next_s)) if time_s - next_s < MAX_BEHIND_S => {
                let mut next = next_s;
                while next <= time_s {
                    next += interval(&mut self.drawn);
                }
                self.state = Some((pose, next));
                pose
            }
            _ => {
                // The first update falls anywhere in its interval: a logger starts at no
                // particular phase of the odometry.
                let phase = event_uniform(seed, self.drawn, STREAM + 1);
                let next = time_s + phase * interval(&mut self.drawn);
                self.state = Some((pose, next));
                pose
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64) -> Pose {
        Pose {
            x_m: x,
            ..Pose::default()
        }
    }

    /// Read at 20 Hz, a 10 Hz odometry with no jitter publishes every second reading; off, every
    /// reading; a restart publishes at once.
    #[test]
    fn a_steady_odometry_slower_than_the_logger_holds_its_pose() {
        let mut off = PoseUpdates::default();
        assert_eq!(off.read(at(3.0), 1.0, 0.0, 0.0, 7), at(3.0));
        let mut o = PoseUpdates::default();
        let read: Vec<f64> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.05;
                o.read(at(t), t, 0.1, 0.0, 7).x_m
            })
            .collect();
        let changes = read.windows(2).filter(|w| w[1] != w[0]).count();
        assert!((98..=100).contains(&changes), "{changes} changes in 199 readings");
        // A held pose is one the odometry published: never ahead of the truth.
        assert!(read
            .iter()
            .enumerate()
            .all(|(i, &x)| x <= i as f64 * 0.05 + 1e-12));
        o.restart();
        assert_eq!(o.read(at(42.0), 10.0, 0.1, 0.0, 7), at(42.0));
    }

    /// With jitter the intervals' mean is `period + jitter` and their standard deviation
    /// `jitter`, within what 20 000 updates allow; the same seed gives the same updates.
    #[test]
    fn intervals_have_the_declared_mean_and_spread() {
        let (period, jitter, dt) = (0.1, 0.08, 0.002);
        let run = |seed| {
            let mut o = PoseUpdates::default();
            let mut times = Vec::new();
            let mut last = f64::NAN;
            for i in 0..2_000_000u64 {
                let t = i as f64 * dt;
                let x = o.read(at(t), t, period, jitter, seed).x_m;
                if x != last {
                    times.push(t);
                    last = x;
                }
            }
            times
        };
        let times = run(3);
        let d: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        // Sampling at 2 ms rounds each interval up by under 2 ms.
        assert!(
            (mean - period - jitter - dt / 2.0).abs() < 5.0 * jitter / n.sqrt() + 1e-4,
            "mean {mean}"
        );
        assert!((sd - jitter).abs() < 0.05 * jitter, "sd {sd}");
        assert_eq!(times[..100], run(3)[..100]);
        assert_ne!(times[..100], run(4)[..100]);
    }
}
