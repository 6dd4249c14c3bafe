//! A wheel loop that learns the load of a turn and carries it into the next step.

use super::term::filtered_history;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage, TermInput};
use crate::kinematics::WheelSpeeds;

/// A turn loads a skid-steered robot's wheels: the outer side pushes, the inner side brakes,
/// and once the tyres slide the moment resisting the turn stops growing with the yaw rate. The
/// load is `s = tanh(wz_cmd / w_s)`, the commanded yaw rate in the nominal geometry over the
/// rate `w_s` where the turn saturates. A speed loop with an integral learns the load over a
/// time τ, `L' = (s − L) / τ`, and until it has, the outer wheel falls short and the inner one
/// overshoots by `m · (s − L)`: a turn after a turn the same way starts with its load learnt,
/// a turn after a turn the other way starts from the opposite one and falls further short
/// (the asymmetry `drive_sim_analysis::turn_memory` measures on runs). The learnt load runs
/// over the DRIVE steps ([`super::StepContext::history`]); within a step the command is
/// constant and the load's value closed-form. Discovery reads it from a wheel equation that
/// remembers the commanded yaw rate over seconds.
pub(crate) struct TurnMemory;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "turn_memory_give_rad_s",
        unit: "rad/s",
        kind: ParamKind::Continuous,
        min: 0.0,
        max: 50.0,
        neutral: 0.0,
        search: SearchBox::Fixed {
            lower: 0.02,
            upper: 4.0,
        },
        resolution: None,
    },
    ParamDef {
        key: "turn_memory_s",
        unit: "s",
        kind: ParamKind::Continuous,
        min: 0.01,
        max: 600.0,
        // A loop that learns at once gives nothing away: the shortest time is the effect off.
        neutral: 0.01,
        // From a wheel's own lag (below 0.5 s the time constant explains it) to memories
        // that outlast three steps.
        search: SearchBox::Fixed {
            lower: 0.5,
            upper: 20.0,
        },
        resolution: None,
    },
    ParamDef {
        key: "turn_memory_saturation_rad_s",
        unit: "rad/s",
        kind: ParamKind::Continuous,
        min: 1e-3,
        max: 100.0,
        // A turn whose load never saturates loads nothing at the commanded rates: the largest
        // saturation is the effect off.
        neutral: 100.0,
        // Above 2 rad/s the load is nearly linear over DRIVE's yaw rates (up to about 4 rad/s
        // on the Warthog) and the saturation trades with the give: the box stops there, and a
        // search starts mid-box, about 1 rad/s.
        search: SearchBox::Fixed {
            lower: 0.05,
            upper: 2.0,
        },
        resolution: None,
    },
];

/// The turn's load for a command whose nominal yaw rate is `wz_rad_s`.
fn load(wz_rad_s: f64, saturation_rad_s: f64) -> f64 {
    (wz_rad_s / saturation_rad_s).tanh()
}

impl Effect for TurnMemory {
    fn name(&self) -> &'static str {
        "turn_memory"
    }
    fn doc(&self) -> &'static str {
        "the wheel loop learns a turn's load over seconds and carries it into the next step (a speed loop with an integral)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    // Discovery brings it in where a wheel equation remembers the commanded yaw rate; the
    // measured calibrations have not been measured with it in their catalogue.
    fn default_candidate(&self) -> bool {
        false
    }
    fn wheel_targets_in(&self, p: &[f64], w: WheelSpeeds, x: &TermInput) -> WheelSpeeds {
        let (give, tau, sat) = (p[0], p[1], p[2]);
        // Stops are not DRIVE steps (a robot told to stop stands on its brakes), and an
        // operator's manoeuvre is not the protocol's.
        if give == 0.0 || x.is_stop() || x.manoeuvre {
            return w;
        }
        let s = load(x.cmd_body.wz_rad_s, sat);
        let past = x.history.iter().zip(&x.history_cmd_body);
        let learnt_at_start = filtered_history(past.map(|(p, b)| (load(b.wz_rad_s, sat), p.duration_s)), tau);
        let short = give * (s - learnt_at_start) * (-x.t_in_step_s.max(0.0) / tau).exp();
        // The outer wheel of a left turn (s > 0) is the right one.
        WheelSpeeds::new(w.left_rad_s + short, w.right_rad_s - short)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::term::{PastStep, HISTORY_STEPS};
    use crate::kinematics::IdealDiffDrive;

    fn idd() -> IdealDiffDrive {
        IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        }
    }

    /// The input `t_s` into a step commanded `cmd` after steps of 6 s commanded `before`.
    fn input(before: &[WheelSpeeds], cmd: WheelSpeeds, t_s: f64) -> TermInput {
        let mut ctx = super::super::StepContext::default();
        for &b in before {
            ctx = ctx.next(b, 6.0);
        }
        let mut x = TermInput::at_step(&ctx, cmd, &idd());
        x.t_in_step_s = t_s;
        x
    }

    #[test]
    fn a_turn_after_a_turn_the_other_way_falls_shorter_than_after_one_the_same_way() {
        let p = [1.0, 3.0, 0.5];
        let left = WheelSpeeds::new(-4.0, 4.0);
        let right = WheelSpeeds::new(4.0, -4.0);
        let same = TurnMemory.wheel_targets_in(&p, left, &input(&[left, left], left, 0.5));
        let other = TurnMemory.wheel_targets_in(&p, left, &input(&[right, right], left, 0.5));
        // A left turn: the right wheel is the outer one and falls short.
        assert!(other.right_rad_s < same.right_rad_s && same.right_rad_s < 4.0);
        assert!(other.left_rad_s > same.left_rad_s);
        // After two 6 s turns the same way with τ = 3 s, the load is 98 % learnt: the give is
        // 2 % of the full one; after the other way, 1.98 times it.
        let full = 1.0 * (0.5f64 / 3.0).exp().recip() * load(idd().body_from_wheels(left).wz_rad_s, 0.5);
        let learnt = 1.0 - (-12.0f64 / 3.0).exp();
        assert!(
            (4.0 - same.right_rad_s - full * (1.0 - learnt)).abs() < 1e-9,
            "{same:?}"
        );
        assert!(
            (4.0 - other.right_rad_s - full * (1.0 + learnt)).abs() < 1e-9,
            "{other:?}"
        );
    }

    #[test]
    fn the_memory_fades_within_the_step_and_stops_and_straight_lines_after_straight_lines_are_untouched() {
        let p = [1.0, 2.0, 0.5];
        let turn = WheelSpeeds::new(-3.0, 3.0);
        let early = TurnMemory.wheel_targets_in(&p, turn, &input(&[], turn, 0.0));
        let late = TurnMemory.wheel_targets_in(&p, turn, &input(&[], turn, 6.0));
        assert!((turn.right_rad_s - early.right_rad_s) > 20.0 * (turn.right_rad_s - late.right_rad_s));
        let straight = WheelSpeeds::new(3.0, 3.0);
        let x = input(&[straight], straight, 0.1);
        assert_eq!(TurnMemory.wheel_targets_in(&p, straight, &x), straight);
        let stop = WheelSpeeds::default();
        assert_eq!(
            TurnMemory.wheel_targets_in(&p, stop, &input(&[turn], stop, 0.1)),
            stop
        );
        assert_eq!(HISTORY_STEPS, input(&[turn], turn, 0.0).history.len());
        assert_eq!(
            input(&[turn], turn, 0.0).history[HISTORY_STEPS - 1],
            PastStep {
                cmd: turn,
                duration_s: 6.0
            }
        );
    }
}
