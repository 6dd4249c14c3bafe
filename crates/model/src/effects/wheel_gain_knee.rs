//! A wheel loop whose gain changes above a speed.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// A knee θ in each wheel's speed map: targets up to ±θ pass unchanged, beyond it the wheel
/// gets `g` times what exceeds θ (`sign(ω) · (θ + g · (|ω| − θ))`). A motor past its base
/// speed (field weakening, g < 1) or a driver's lookup table with a second slope. Discovery
/// reads it from a wheel equation's hinge term `sign(ω_cmd)·(|ω_cmd| − θ)₊`, whose knees lie on
/// a grid: this effect fits the knee between the grid's points.
pub(crate) struct WheelGainKnee;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "wheel_knee_rad_s",
        unit: "rad/s",
        kind: ParamKind::Continuous,
        min: 0.0,
        max: 1000.0,
        // With the gain at 1 the knee changes nothing: its own neutral value only says the
        // effect is off when both are.
        neutral: 0.0,
        // A knee beyond the largest command, or at its very start, is a plain gain (the
        // motor gain's); the box keeps it inside the commanded range.
        search: SearchBox::Reach {
            of: ReachOf::Wheel,
            lower: 0.1,
            upper: 0.95,
        },
        resolution: None,
    },
    ParamDef {
        key: "wheel_gain_above_knee",
        unit: "-",
        kind: ParamKind::Continuous,
        min: 0.0,
        max: 10.0,
        neutral: 1.0,
        search: SearchBox::Fixed {
            lower: 0.4,
            upper: 1.6,
        },
        resolution: None,
    },
];

/// `w` through a knee at `theta` with gain `g` above it.
fn knee(w: f64, theta: f64, g: f64) -> f64 {
    if w.abs() <= theta {
        w
    } else {
        w.signum() * (theta + g * (w.abs() - theta))
    }
}

impl Effect for WheelGainKnee {
    fn name(&self) -> &'static str {
        "wheel_gain_knee"
    }
    fn doc(&self) -> &'static str {
        "each wheel's gain changes above a speed (a motor past its base speed, a driver map with a second slope)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    // Discovery brings it in where a wheel equation has a hinge; the measured calibrations
    // have not been measured with it in their catalogue.
    fn default_candidate(&self) -> bool {
        false
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(knee(w.left_rad_s, p[0], p[1]), knee(w.right_rad_s, p[0], p[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn below_the_knee_nothing_changes_above_it_the_excess_is_scaled() {
        let e = WheelGainKnee;
        let w = e.wheel_targets(&[5.0, 0.5], WheelSpeeds::new(4.0, -9.0));
        assert_eq!(w.left_rad_s, 4.0);
        assert!((w.right_rad_s + 7.0).abs() < 1e-12);
        // A gain of 1 changes nothing, wherever the knee is.
        let w = e.wheel_targets(&[2.0, 1.0], WheelSpeeds::new(7.5, -0.3));
        assert_eq!((w.left_rad_s, w.right_rad_s), (7.5, -0.3));
    }
}
