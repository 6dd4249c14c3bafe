//! A wheel speed approached gradually rather than clipped.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// A soft limit S on each wheel's target, `S · tanh(ω / S)`: the motor's voltage headroom
/// shrinks as it speeds up, so the wheel falls increasingly short of fast targets instead of
/// following them up to a hard clip (`wheel_speed_saturation_rad_s`). Discovery reads it
/// from a wheel equation whose odd powers of the command take gain away at speed
/// (`S ≈ (−1 / (3 c₃))^½` for a cubic coefficient c₃ < 0, the tanh's first term).
pub(crate) struct WheelSoftLimit;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_speed_soft_limit_rad_s",
    unit: "rad/s",
    kind: ParamKind::Limit,
    min: 0.0,
    max: 1000.0,
    neutral: f64::INFINITY,
    // From a limit a third of the largest command (a wheel that barely answers) to one at
    // four times it, where the largest command loses 2 %.
    search: SearchBox::Reach {
        of: ReachOf::Wheel,
        lower: 0.3,
        upper: 4.0,
    },
    resolution: None,
}];

/// `w` through a soft limit `s` (none when `s` is infinite or not positive).
fn soft_limit(w: f64, s: f64) -> f64 {
    if s.is_finite() && s > 0.0 {
        s * (w / s).tanh()
    } else {
        w
    }
}

impl Effect for WheelSoftLimit {
    fn name(&self) -> &'static str {
        "wheel_speed_soft_limit_rad_s"
    }
    fn doc(&self) -> &'static str {
        "each wheel approaches a speed limit gradually, S·tanh(ω/S) (voltage headroom shrinking with speed)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    // Discovery brings it in where a wheel equation loses gain at speed; the measured
    // calibrations have not been measured with it in their catalogue.
    fn default_candidate(&self) -> bool {
        false
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(soft_limit(w.left_rad_s, p[0]), soft_limit(w.right_rad_s, p[0]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_targets_pass_fast_ones_approach_the_limit() {
        let e = WheelSoftLimit;
        let w = e.wheel_targets(&[10.0], WheelSpeeds::new(0.1, -30.0));
        assert!((w.left_rad_s - 0.1).abs() < 1e-4);
        assert!(w.right_rad_s < -9.9 && w.right_rad_s > -10.0);
        let w = e.wheel_targets(&[f64::INFINITY], WheelSpeeds::new(7.0, -3.0));
        assert_eq!((w.left_rad_s, w.right_rad_s), (7.0, -3.0));
    }
}
