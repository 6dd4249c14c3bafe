//! Each step, each wheel's speed loop settles a little off its target, by a different amount.

use super::step_draw::step_normal;
use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Each side's speed loop settles at `ω_target + σ · z`, with `z` a standard normal drawn once
/// per step and side and held for the whole step: a step-level offset, not sensor noise.
///
/// Why: on the measured Warthog runs the steady wheel speeds of two steps with nearly the same
/// command (within 1 rad/s) differ by far more than the two steady windows of one step do: on
/// asphalt 0.48 rad/s per wheel between such steps, 0.25 within a step; gravel 0.46 and 0.23
/// (`drive-sim analyze`, its "step scatter" line; `drive_sim_analysis::scatter`]). A
/// deterministic model holds one speed per command; the real loop does not (a ground that
/// differs under each step, a loop whose integrator starts each step from where the last one
/// left it). Without it the twins' own runs scatter 0.01–0.12 rad/s (`drive-sim compare`, its
/// step scatter line, which also says how large an offset to add: the two add in quadrature).
/// It is zero-mean: medians, hull areas and smoothed maps, the verdict's statistics, barely
/// move (README, "Step scatter").
///
/// `z` comes from a hash of the run's seed, the step index and the side: the same seed gives
/// the same offsets, and switching the effect on moves no other random draw. A stop (both
/// wheels told zero) gets none: a robot told to stop stands on its brakes. Nor does the
/// operator's manoeuvre between steps: an operator steers by where the robot goes (with the
/// offsets, the simulated operator's open turns missed the centre and its runs left the site).
/// It acts before the speed limits, which clip a target pushed past them.
pub(crate) struct WheelSpeedScatter;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_speed_scatter_rad_s",
    unit: "rad/s",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 5.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 1.5,
    },
    resolution: None,
}];

impl Effect for WheelSpeedScatter {
    fn name(&self) -> &'static str {
        "wheel_speed_scatter"
    }
    fn doc(&self) -> &'static str {
        "each wheel's speed loop settles off its target by a random offset drawn once per step (the step-to-step scatter deterministic models lack)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    /// A random offset cannot lower a least-squares replay score: calibration tries it only
    /// when asked; its size comes from the step scatter (`drive-sim analyze`).
    fn default_candidate(&self) -> bool {
        false
    }
    fn wheel_targets_in(&self, p: &[f64], w: WheelSpeeds, x: &TermInput) -> WheelSpeeds {
        if p[0] == 0.0 || x.is_stop() || x.manoeuvre {
            return w;
        }
        WheelSpeeds::new(
            w.left_rad_s + p[0] * step_normal(x.run_seed, x.step, 0),
            w.right_rad_s + p[0] * step_normal(x.run_seed, x.step, 1),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The offset holds for a step, changes with the step, and a stop gets none.
    #[test]
    fn offset_is_per_step_and_spares_a_stop() {
        let e = WheelSpeedScatter;
        let w = WheelSpeeds::new(5.0, -5.0);
        let x = |step: u32, t: f64| TermInput {
            cmd: w,
            step,
            t_in_step_s: t,
            run_seed: 3,
            ..TermInput::default()
        };
        let a = e.wheel_targets_in(&[0.5], w, &x(4, 0.1));
        assert_eq!(a, e.wheel_targets_in(&[0.5], w, &x(4, 5.0)));
        assert_ne!(a, e.wheel_targets_in(&[0.5], w, &x(5, 0.1)));
        assert_eq!(e.wheel_targets_in(&[0.0], w, &x(4, 0.1)), w);
        let stop = TermInput {
            cmd: WheelSpeeds::default(),
            ..x(4, 0.1)
        };
        let zero = WheelSpeeds::default();
        assert_eq!(e.wheel_targets_in(&[0.5], zero, &stop), zero);
        let manoeuvre = TermInput {
            manoeuvre: true,
            ..x(4, 0.1)
        };
        assert_eq!(e.wheel_targets_in(&[0.5], w, &manoeuvre), w);
    }
}
