//! A wheel that answers backwards with another gain than forwards.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Each wheel told to turn backwards gets `g` times its target (`g · ω` for ω < 0): a motor
/// driver or gearbox that is not symmetric. It acts per wheel, on the sign of that wheel's
/// own target, so a spin in place meets it on one side; the controller's reverse geometry
/// (`reverse_baseline_scale`) acts on the body's direction instead. Discovery reads it from a
/// wheel equation with a term that only acts backwards.
pub(crate) struct WheelReverseGain;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_reverse_gain",
    unit: "-",
    kind: ParamKind::Continuous,
    min: 0.01,
    max: 10.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.5,
        upper: 1.5,
    },
    resolution: None,
}];

fn reverse(w: f64, g: f64) -> f64 {
    if w < 0.0 {
        g * w
    } else {
        w
    }
}

impl Effect for WheelReverseGain {
    fn name(&self) -> &'static str {
        "wheel_reverse_gain"
    }
    fn doc(&self) -> &'static str {
        "each wheel's gain is another backwards than forwards (an asymmetric driver or gearbox)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    // Discovery brings it in where a wheel equation acts only backwards; the measured
    // calibrations have not been measured with it in their catalogue.
    fn default_candidate(&self) -> bool {
        false
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(reverse(w.left_rad_s, p[0]), reverse(w.right_rad_s, p[0]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_backward_targets_are_scaled() {
        let w = WheelReverseGain.wheel_targets(&[1.2], WheelSpeeds::new(3.0, -5.0));
        assert_eq!(w.left_rad_s, 3.0);
        assert!((w.right_rad_s + 6.0).abs() < 1e-12);
    }
}
