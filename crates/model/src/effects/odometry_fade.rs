//! The lidar odometry reads a held command's speed lower as the command goes on.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};
use crate::measurement::Pose;

/// The pose's displacement is read at `1 − κ t` of the true one, `t` the time since the held
/// command began (floored at zero), so a constant speed reads `κ · 2 s` lower in the second
/// steady window than in the first. Headings are read as they are.
///
/// Why: on the measured Warthog runs at a wheel speed that does not fall (+0.08–0.09 rad/s
/// between the steady windows), the body speed read from the lidar (ICP) poses falls between
/// windows 1 and 2 by 0.18 and 0.26 m/s on average on asphalt, 0.07 on gravel, 0.01 on ice, in
/// straight driving as much as in turns (`scripts/twin_vs_run.py`). The source's own smoothed
/// ICP estimate falls by as much, so it is in the poses, not in an estimator. A body that slowed
/// by a tenth on asphalt under a held wheel speed would be slipping more and more; an odometry
/// whose registration falls behind a long straight motion reads the same. This effect is that
/// odometry; the logs alone cannot tell the two apart.
///
/// The fade restarts with each command ([`FadingOdometry::restart`]) and does not act while the
/// operator manoeuvres between steps.
pub(crate) struct OdometryFade;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "odometry_fade_per_s",
    unit: "1/s",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 0.5,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 0.1,
    },
    resolution: None,
}];

impl Effect for OdometryFade {
    fn name(&self) -> &'static str {
        "odometry_fade"
    }
    fn doc(&self) -> &'static str {
        "the lidar odometry reads a held command's speed lower as the command goes on (its displacement at 1 − κ t of the true one)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    /// Fitted by replay on the whole asphalt run it is 0.0125 1/s [0.0024, 0.0227], a gain
    /// of 0.14 ± 0.05 on a validation score of 9.68, 1.6 % of it: less than the selection
    /// asks (`drive-sim calibrate ../shared/data/measured/warthog_asphalt.csv --candidates
    /// odometry_fade --no-discovery`). The calibration tries it when asked; a robot file can
    /// declare it.
    fn default_candidate(&self) -> bool {
        false
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.odometry_fade_per_s = p[0];
    }
}

/// The pose a fading odometry reports: each displacement of the true pose since the last
/// reading, scaled by `1 − κ t`, added to the last reported position. The plants (the
/// simulator and the kinematic surrogate) hold one each.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FadingOdometry {
    /// The true pose at the last reading and the pose reported then.
    last: Option<(Pose, Pose)>,
}

impl FadingOdometry {
    /// Forgets the last reading: the next one reports the true pose (a new command, a reset).
    pub fn restart(&mut self) {
        self.last = None;
    }

    /// The pose reported for `truth`, `t_s` after the held command began, with the fade
    /// `fade_per_s` (κ, 1/s); `faded` false reads displacements as they are (a manoeuvre).
    pub fn read(&mut self, truth: Pose, t_s: f64, fade_per_s: f64, faded: bool) -> Pose {
        if fade_per_s == 0.0 {
            return truth;
        }
        let reported = match self.last {
            None => truth,
            Some((before, was)) => {
                let scale = if faded {
                    (1.0 - fade_per_s * t_s.max(0.0)).max(0.0)
                } else {
                    1.0
                };
                Pose {
                    x_m: was.x_m + scale * (truth.x_m - before.x_m),
                    y_m: was.y_m + scale * (truth.y_m - before.y_m),
                    ..truth
                }
            }
        };
        self.last = Some((truth, reported));
        reported
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At a constant speed the reported speed is `v (1 − κ t)`: the second of two equal spans
    /// reads `κ` times their spacing less; off, or restarted, it reads the truth.
    #[test]
    fn a_constant_speed_reads_lower_as_the_command_goes_on() {
        let at = |x: f64| Pose {
            x_m: x,
            ..Pose::default()
        };
        let (v, k, dt) = (3.0, 0.05, 0.05);
        let mut o = FadingOdometry::default();
        let read: Vec<f64> = (0..=120)
            .map(|i| {
                let t = i as f64 * dt;
                o.read(at(v * t), t, k, true).x_m
            })
            .collect();
        let speed = |i: usize| (read[i + 1] - read[i]) / dt;
        // Between 3 s and 5 s (samples 60 and 100), 2 s apart: 2 κ v = 0.3 m/s lower.
        assert!((speed(60) - speed(100) - 2.0 * k * v).abs() < 1e-9);
        assert!((speed(60) - v * (1.0 - k * 3.05)).abs() < 1e-9);
        let mut off = FadingOdometry::default();
        assert_eq!(off.read(at(7.0), 4.0, 0.0, true), at(7.0));
        o.restart();
        assert_eq!(o.read(at(50.0), 0.0, k, true), at(50.0));
        assert_eq!(
            o.read(at(51.0), 3.0, k, false).x_m,
            51.0,
            "a manoeuvre reads as it is"
        );
    }
}
