//! A wheel that does not answer small commands.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// A deadband θ on each wheel's target: a target within ±θ leaves the wheel still, a larger
/// one loses θ (`sign(ω) · (|ω| − θ)`). A motor driver that ignores small commands, or static
/// friction its feed-forward does not cover. Discovery reads it from a wheel equation's
/// negative term in sign(ω_cmd), which can reproduce the band's edges but not the zero inside
/// it.
pub(crate) struct WheelDeadband;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_deadband_rad_s",
    unit: "rad/s",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 100.0,
    neutral: 0.0,
    // Up to 2 rad/s: an eighth of the Warthog's top wheel speed, a third of the Husky's; a
    // wider band would stop a robot from driving slowly at all.
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 2.0,
    },
    resolution: None,
}];

/// `w` through a deadband of half-width `theta`.
fn deadband(w: f64, theta: f64) -> f64 {
    if w.abs() <= theta {
        0.0
    } else {
        w - theta.copysign(w)
    }
}

impl Effect for WheelDeadband {
    fn name(&self) -> &'static str {
        "wheel_deadband_rad_s"
    }
    fn doc(&self) -> &'static str {
        "each wheel ignores targets within ±θ and loses θ beyond (driver deadband, static friction)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(deadband(w.left_rad_s, p[0]), deadband(w.right_rad_s, p[0]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_the_band_the_wheel_stays_still_beyond_it_loses_the_band() {
        let e = WheelDeadband;
        let w = e.wheel_targets(&[0.5], WheelSpeeds::new(0.4, -3.0));
        assert_eq!(w.left_rad_s, 0.0);
        assert!((w.right_rad_s + 2.5).abs() < 1e-12);
        let w = e.wheel_targets(&[0.5], WheelSpeeds::new(-0.5, 2.0));
        assert_eq!(w.left_rad_s, 0.0);
        assert!((w.right_rad_s - 1.5).abs() < 1e-12);
        // The neutral value changes nothing.
        let w = e.wheel_targets(&[0.0], WheelSpeeds::new(0.1, -0.1));
        assert_eq!((w.left_rad_s, w.right_rad_s), (0.1, -0.1));
    }
}
