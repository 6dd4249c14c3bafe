//! A speed loop with an integral: the speed a new load costs (the droop) is won back over a few
//! seconds, and what the loop has learnt carries over from one DRIVE step to the next.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// With [`super::speed_droop::SpeedDroop`]'s droop `D`, each side aims at `ω_cmd − D · (τ − τ_I)`
/// instead of `ω_cmd − D · τ`, `τ_I` the torque the loop's integral already supplies, which
/// follows the delivered torque `τ` with time constant `T` (a PI loop: `D = 1/K_p`,
/// `T = K_p/K_i`). A load the loop has held for a while costs no speed; a new one costs `D · Δτ`
/// at first and is won back over `T`. The integral is not reset between steps: a turn after a
/// turn the same way starts with its torque already learnt, a turn the other way starts from the
/// opposite torque and falls furthest short.
///
/// The measured Warthog runs show that dependence on the previous step, which a proportional
/// droop (one shortfall per load) cannot give: on asphalt a loaded wheel whose step begins in a
/// turn the same way falls 6 % short in its first steady window, one whose step begins in a turn
/// the other way 20 %, and that one is still gaining speed between the steady windows
/// (README, "A speed loop that remembers"; `drive-sim analyze` → `summary.json`
/// `turn_memory`). Without the droop it does nothing. A replayed step starts with an empty
/// integral: a log does not record the torque the previous step left in it.
pub(crate) struct DroopRecovery;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "droop_recovery_s",
    unit: "s",
    kind: ParamKind::Limit,
    min: 0.0,
    max: 1000.0,
    neutral: f64::INFINITY,
    search: SearchBox::Fixed {
        lower: 0.3,
        upper: 10.0,
    },
    resolution: None,
}];

impl Effect for DroopRecovery {
    fn name(&self) -> &'static str {
        "droop_recovery"
    }
    fn doc(&self) -> &'static str {
        "the drooping speed loop has an integral: a new load's shortfall is won back over a time constant, and the loop carries what it learnt into the next step (needs speed_droop)"
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
        // A limit's 0 means off, as everywhere in the registry: a proportional loop.
        m.speed_droop_recovery_s = if p[0] > 0.0 { p[0] } else { f64::INFINITY };
    }
}
