//! The robot's velocity controller uses its own wheel radius and separation.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::IdealDiffDrive;

/// The controller turns the (nominal) command into wheel targets with its own geometry: a
/// wheel command is read as the nominal body velocity it stands for, and the controller's
/// kinematics give the wheels. Its radius scales the common mode (speed) of the targets by its
/// inverse; its separation (e.g. a `wheel_separation_multiplier` of a ROS diff-drive
/// controller) scales the differential mode (turning).
pub(crate) struct ControllerKinematics;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "controller_radius_scale",
        unit: "-",
        kind: ParamKind::Continuous,
        min: 0.01,
        max: 100.0,
        neutral: 1.0,
        search: SearchBox::Fixed {
            lower: 0.4,
            upper: 2.0,
        },
        resolution: None,
    },
    ParamDef {
        key: "controller_baseline_scale",
        unit: "-",
        kind: ParamKind::Continuous,
        min: 0.01,
        max: 100.0,
        neutral: 1.0,
        search: SearchBox::Fixed {
            lower: 0.3,
            upper: 3.0,
        },
        resolution: None,
    },
];

impl Effect for ControllerKinematics {
    fn name(&self) -> &'static str {
        "controller_kinematics"
    }
    fn doc(&self) -> &'static str {
        "the velocity controller converts commands with its own wheel radius and separation"
    }
    fn stage(&self) -> Stage {
        Stage::Command
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn uses_body_space(&self) -> bool {
        true
    }
    fn controller_geometry(&self, p: &[f64], g: IdealDiffDrive) -> IdealDiffDrive {
        IdealDiffDrive {
            wheel_radius_m: g.wheel_radius_m * p[0],
            baseline_m: g.baseline_m * p[1],
        }
    }
}
