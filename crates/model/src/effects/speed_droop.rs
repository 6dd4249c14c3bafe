//! A wheel-speed controller that gives way under load: its speed falls short of its command by
//! an amount proportional to the torque it delivers (a proportional loop's droop).

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Each side aims at `ω_cmd − D · τ`, `τ` the torque that side's motor delivers (N·m at the
/// wheels, the previous physics step's) and `D` the droop in rad/s per kN·m. A loaded wheel runs
/// slower than commanded; a wheel the ground drives (the slow side of a curve, which the body
/// drags forward, braked by its motor) runs *faster* than commanded. An ideal speed loop (the
/// simulator without this effect) holds every command exactly until its torque limit. On the
/// Warthog's asphalt run the slower wheel of a gentle curve turns 6–12 % faster than its
/// command and the faster one gives way; on ice, where the ground hardly couples the sides,
/// both track 1.00 (README, "A speed loop that gives way"). Needs the contact model's load
/// torque: the kinematic model cannot run it.
pub struct SpeedDroop;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "speed_droop_rad_s_per_knm",
    unit: "rad/s per kN·m",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 100.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 6.0,
    },
    resolution: None,
}];

impl Effect for SpeedDroop {
    fn name(&self) -> &'static str {
        "speed_droop"
    }
    fn doc(&self) -> &'static str {
        "the wheel-speed loop gives way in proportion to the torque it delivers: loaded wheels run slow, wheels the ground drives run fast"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn kinematic(&self) -> bool {
        false
    }
    fn default_candidate(&self) -> bool {
        false
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.speed_droop_rad_s_per_nm = p[0] / 1000.0;
    }
}
