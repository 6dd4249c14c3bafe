//! Twins: a calibrated model as a robot file and a terrain file that `drive-sim run`,
//! `replay` and `calibrate` accept like any other (`--robot OUT/twin/robot.toml --terrain
//! OUT/twin/terrain.toml`).
//!
//! A [`ModelParams`] keeps its effects beside the robot and the terrain; a twin puts each
//! effect in the file of what shows it ([`terrain_side`]): effects of the wheel-terrain
//! contact go to the terrain file (they are properties of that ground under that robot),
//! every other one (commands, wheels, body, sensors) to the robot file. Loading a twin and
//! lifting the effects back out ([`lift_effects`]) gives the calibrated model again, value for
//! value (floats are written in their shortest round-trip form).
//!
//! Every value a fit produced carries a comment: the dataset, the fitted value, its standard
//! error and 95 % interval (or why it has none); the header says which file every other
//! value comes from. Only simulator fits give twins: a kinematic fit's effective values (its
//! baseline, its time constant standing in for the tyres) are not physical parameters.

mod comments;

pub use comments::{annotate_value, commented_toml};
use comments::{comment_for, file_path, value_in_file};

use super::fit::FittedParam;
use super::model::ModelParams;
use super::CalibrationReport;
use crate::error::{Error, Result};
use drive_sim_model::effects::{Effect, Effects};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Whether `effect` belongs in the terrain file of a twin (it changes how this ground grips,
/// [`Effect::on_terrain`]) rather than in the robot file.
pub fn terrain_side(effect: &dyn Effect) -> bool {
    effect.on_terrain()
}

/// Splits a set of effects into the robot's and the terrain's ([`terrain_side`]); only the
/// parameters away from their neutral value are kept.
pub fn split_effects(effects: &Effects) -> Result<(Effects, Effects)> {
    let mut robot = Effects::default();
    let mut terrain = Effects::default();
    for (k, v) in effects.declared() {
        let on_terrain = drive_sim_model::effects::param_owner(k)
            .is_some_and(|(i, _)| terrain_side(drive_sim_model::effects::REGISTRY[i]));
        if on_terrain {
            terrain.set(k, v)?;
        } else {
            robot.set(k, v)?;
        }
    }
    Ok((robot, terrain))
}

/// The robot and terrain files of a model: its effects moved into their `[effects]` tables.
pub fn twin_models(params: &ModelParams) -> Result<(Robot, Terrain)> {
    let all = drive_sim_model::effects_table::combine(
        &params.robot.effects,
        &params.terrain.effects,
        &params.effects,
    )?;
    let (re, te) = split_effects(&all)?;
    let mut robot = params.robot.clone();
    let mut terrain = params.terrain.clone();
    robot.effects = re;
    terrain.effects = te;
    Ok((robot, terrain))
}

/// The model a robot file and a terrain file describe, with their effects lifted out of the
/// files into [`ModelParams::effects`] (so that every plant, the kinematic one included, runs
/// them, and calibration sees them as the starting model's effects).
pub fn lift_effects(robot: &Robot, terrain: &Terrain) -> Result<ModelParams> {
    let effects =
        drive_sim_model::effects_table::combine(&robot.effects, &terrain.effects, &Effects::default())?;
    let mut robot = robot.clone();
    let mut terrain = terrain.clone();
    robot.effects = Effects::default();
    terrain.effects = Effects::default();
    Ok(ModelParams {
        robot,
        terrain,
        effects,
    })
}

/// Where a twin's values come from, for the comments of its files.
#[derive(Debug, Clone)]
pub struct Provenance {
    /// Header lines (without `# `), e.g. the dataset and the command.
    pub header: Vec<String>,
    /// Fitted parameters by report name (`terrain.friction.peak_lateral`,
    /// `robot.powertrain.time_constant_s`, `effect.dead_time_s`), with the dataset(s) they
    /// were fitted on.
    pub fitted: Vec<(FittedParam, String)>,
    /// The model the fit started from, for the declared value beside each fitted one.
    pub before: Option<ModelParams>,
    /// Values set by another method than a fit (a closed-loop search,
    /// `drive_sim_compare::tune`), by report name, with their whole comment.
    pub chosen: Vec<(String, String)>,
}

/// The two files of a twin.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinFiles {
    /// The robot, with its effects.
    pub robot: Robot,
    /// The terrain, with its contact effects.
    pub terrain: Terrain,
    /// `robot.toml`, commented.
    pub robot_toml: String,
    /// `terrain.toml`, commented.
    pub terrain_toml: String,
}

/// The twin files of `params`: each fitted value that the files hold as fitted commented with
/// its provenance; a fitted value that a later stage changed (a refit without an interval) is
/// commented as such.
pub fn twin_files(params: &ModelParams, prov: &Provenance) -> Result<TwinFiles> {
    let (robot, terrain) = twin_models(params)?;
    let rv = toml::Value::try_from(&robot).map_err(|source| Error::Toml {
        what: "a twin robot",
        source,
    })?;
    let tv = toml::Value::try_from(&terrain).map_err(|source| Error::Toml {
        what: "a twin terrain",
        source,
    })?;
    let before = match &prov.before {
        Some(b) => {
            let (r, t) = twin_models(b)?;
            Some((
                toml::Value::try_from(&r).map_err(|source| Error::Toml {
                    what: "the robot before calibration",
                    source,
                })?,
                toml::Value::try_from(&t).map_err(|source| Error::Toml {
                    what: "the terrain before calibration",
                    source,
                })?,
            ))
        }
        None => None,
    };
    let mut rc = BTreeMap::new();
    let mut tc = BTreeMap::new();
    // Which file holds a parameter (by report name), at which dotted path, and its value there.
    let locate = |name: &str| -> Option<(bool, String, f64)> {
        let (on_terrain, path) = file_path(name, &tv)?;
        let held = value_in_file(name, &path, if on_terrain { &tv } else { &rv })?;
        Some((on_terrain, path, held))
    };
    for (p, dataset) in &prov.fitted {
        let Some((on_terrain, path, held)) = locate(&p.name) else {
            continue;
        };
        let declared = before
            .as_ref()
            .and_then(|(br, bt)| value_in_file(&p.name, &path, if on_terrain { bt } else { br }));
        let same = held == p.value || (held - p.value).abs() <= 1e-12 * p.value.abs().max(1.0);
        let c = if same {
            comment_for(p, dataset, declared)
        } else {
            format!(
                "[fit] {dataset}: refit in a later stage (no interval for this value; the earlier fit gave {:.6})",
                p.value
            )
        };
        if on_terrain { &mut tc } else { &mut rc }.insert(path, c);
    }
    for (name, comment) in &prov.chosen {
        if let Some((on_terrain, path, _)) = locate(name) {
            if on_terrain { &mut tc } else { &mut rc }.insert(path, comment.clone());
        }
    }
    let mut rh = prov.header.clone();
    rh.push(format!(
        "Robot twin `{}`. Values without a comment are the starting robot's; effects of the wheel-terrain contact are in the terrain file.",
        robot.name
    ));
    let mut th = prov.header.clone();
    th.push(format!(
        "Terrain twin `{}` (for this robot: contact effects included). Values without a comment are the starting terrain's.",
        terrain.name
    ));
    Ok(TwinFiles {
        robot_toml: commented_toml(&robot, &rh, &rc)?,
        terrain_toml: commented_toml(&terrain, &th, &tc)?,
        robot,
        terrain,
    })
}

/// Every fitted parameter of a report whose value is in the final model, latest fit first:
/// the final joint fit, the effects added, the base fit (when kept). The final joint fit holds
/// the final model's values whether or not it replaced the selection (not kept, it is the
/// covariance at the selected model), which a joint refit of an earlier round may have moved
/// away from the base fit's.
pub fn fitted_params(report: &CalibrationReport) -> Vec<FittedParam> {
    let mut out: Vec<FittedParam> = Vec::new();
    let mut push = |p: &FittedParam| {
        if !out.iter().any(|q| q.name == p.name) {
            out.push(p.clone());
        }
    };
    if let Some(f) = &report.final_fit {
        f.params.iter().for_each(&mut push);
    }
    report.effects.iter().for_each(&mut push);
    if let Some(f) = report.terrain_fit.as_ref().filter(|_| report.terrain_fit_kept) {
        f.params.iter().for_each(&mut push);
    }
    out
}

/// The twin of a simulator calibration. A kinematic calibration has none (its fitted values
/// are effective, not physical): an error says so.
pub fn twin_of_report(report: &CalibrationReport) -> Result<TwinFiles> {
    if report.model_kind != "simulator" {
        return Err(Error::TwinOfKinematicModel {
            model_kind: report.model_kind.clone(),
            why: ", whose values are effective, not physical",
        });
    }
    let dataset = report
        .source_file
        .clone()
        .unwrap_or_else(|| report.dataset.clone());
    let prov = Provenance {
        header: vec![
            format!(
                "Twin calibrated by drive-sim on `{}` ({}), simulator model, seed {}.",
                report.dataset, dataset, report.options.seed
            ),
            format!(
                "Test score {:.3} (declared model {:.3}; 1 = noise floor) on {} held-out steps.",
                report.after.score,
                report.before.score,
                report.heldout_steps.len()
            ),
            format!("Reproduce: {}", report.reproduce),
            "[fit] comments: fitted value, standard error (clustered sandwich) and 95 % interval, on the training steps.".into(),
        ],
        fitted: fitted_params(report)
            .into_iter()
            .map(|p| (p, report.dataset.clone()))
            .collect(),
        before: Some(report.model_before.clone()),
        chosen: Vec::new(),
    };
    twin_files(&report.model_after, &prov)
}

/// Steps of the closed-loop check of a twin ([`check_twin`]): enough for a few interruptions and
/// re-orientations (a failing twin can fail as early as step 3), a fraction of a second.
pub const TWIN_CHECK_STEPS: u32 = 30;

/// What a short DRIVE run of a twin showed (`calibration.json`'s `twin_check`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinCheck {
    /// Steps asked for.
    pub steps: u32,
    /// Seed of the run (the sampler's and the simulator's).
    pub seed: u64,
    /// The run completed every step.
    pub ran: bool,
    /// Steps completed.
    pub steps_completed: u32,
    /// Interrupted attempts (unknown when the run stopped on an error).
    pub interruptions: Option<u32>,
    /// Why it stopped, when it did not complete.
    pub error: Option<String>,
}

impl TwinCheck {
    /// The note a report carries when the twin did not run (`None` when it ran).
    pub fn failure_note(&self) -> Option<String> {
        self.error.as_ref().map(|why| {
            format!(
                "a {}-step DRIVE of the twin stopped after {} steps: {why}",
                self.steps, self.steps_completed
            )
        })
    }
}

/// Runs the DRIVE protocol in closed loop on the twin, as `drive-sim run --robot
/// twin/robot.toml --terrain twin/terrain.toml --steps N --seed S` does, without a log.
/// Calibration only replays the commands of the measured run; a fitted term can behave on
/// those and misbehave on commands the run never gave (an operator's re-orientation), and only
/// a closed loop shows it. A failure is the check's outcome, not an error.
pub fn check_twin(robot: &Robot, terrain: &Terrain, steps: u32, seed: u64) -> Result<TwinCheck> {
    let protocol = drive_sim_protocol::ProtocolConfig::for_run(robot, terrain, steps);
    let mut sampler = drive_sim_protocol::sampler::make_sampler_for("uniform-wheel", seed, &protocol)
        .ok_or(Error::SamplerMissing("uniform-wheel"))?;
    let cfg = drive_sim_sim::SimConfig {
        seed,
        ..Default::default()
    };
    let mut sim = drive_sim_sim::Simulator::new(robot, terrain, cfg)?;
    let mut sink = Discard::default();
    let outcome = drive_sim_protocol::run_drive(&mut sim, robot, sampler.as_mut(), &protocol, &mut sink);
    Ok(match outcome {
        Ok(summary) => TwinCheck {
            steps,
            seed,
            ran: summary.steps_completed == steps,
            steps_completed: summary.steps_completed,
            interruptions: Some(summary.interruptions),
            error: None,
        },
        Err(e) => TwinCheck {
            steps,
            seed,
            ran: false,
            steps_completed: sink.completed,
            interruptions: None,
            error: Some(e.to_string()),
        },
    })
}

/// The twin of a simulator calibration, checked in closed loop ([`check_twin`],
/// [`TWIN_CHECK_STEPS`] steps, seed `seed`): the check goes into the report
/// (`twin_check`, and a note in `status.notes` when the twin does not run).
pub fn checked_twin(report: &mut CalibrationReport, seed: u64) -> Result<(TwinFiles, TwinCheck)> {
    let twin = twin_of_report(report)?;
    let check = check_twin(&twin.robot, &twin.terrain, TWIN_CHECK_STEPS, seed)?;
    if let Some(note) = check.failure_note() {
        report.status.notes.push(format!("twin check: {note}"));
    }
    report.twin_check = Some(check.clone());
    Ok((twin, check))
}

/// A frame sink that keeps nothing but the count of completed steps.
#[derive(Default)]
struct Discard {
    completed: u32,
}

impl drive_sim_model::measurement::FrameSink for Discard {
    fn frame(&mut self, _frame: &drive_sim_model::measurement::Frame) -> drive_sim_model::Result<()> {
        Ok(())
    }
    fn step_done(&mut self, completed: u32) {
        self.completed = completed;
    }
}

/// Writes `dir/robot.toml` and `dir/terrain.toml`; returns their paths.
pub fn write_twin(twin: &TwinFiles, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut paths = Vec::new();
    for (name, text) in [
        ("robot.toml", &twin.robot_toml),
        ("terrain.toml", &twin.terrain_toml),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
        paths.push(p);
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Param, ParamSpec};

    #[test]
    fn annotate_value_changes_only_the_comment() {
        let text = "[effects]\nspeed_droop_rad_s_per_knm = 1.5  # [tune] d: 1.5, chosen; no interval\nmotor_stall_torque_nm = 2000.0\nx = 1 # kept\n";
        let a = annotate_value(text, "speed_droop_rad_s_per_knm", "95 % set [1, 2]").unwrap();
        assert!(
            a.contains("= 1.5  # [tune] d: 1.5, chosen; 95 % set [1, 2]\n"),
            "{a}"
        );
        let b = annotate_value(text, "motor_stall_torque_nm", "set").unwrap();
        assert!(b.contains("motor_stall_torque_nm = 2000.0  # set\n"), "{b}");
        let c = annotate_value(text, "x", "set").unwrap();
        assert!(c.contains("x = 1 # kept; set\n"), "{c}");
        assert!(
            annotate_value(text, "speed_droop", "set").is_none(),
            "a prefix is not the key"
        );
        let before: toml::Value = toml::from_str(text).unwrap();
        let after: toml::Value = toml::from_str(&a).unwrap();
        assert_eq!(before, after);
    }

    fn model() -> ModelParams {
        let (robot, _) = Robot::resolve("warthog").unwrap();
        let (terrain, _) = Terrain::resolve("gravel").unwrap();
        // As calibration sees a model: the files' own effects lifted out of them.
        let mut m = lift_effects(&robot, &terrain).unwrap();
        m.terrain.friction.peak_lateral = 0.912_345_678_901_234_5;
        m.effects.set("wheel_speed_saturation_rad_s", 12.6).unwrap();
        m.effects.set("turning_resistance_scale", 1.37).unwrap();
        m.effects.set("motor_gain_left", 0.93).unwrap();
        m.effects.set("term_body_vy__wz", 0.085).unwrap();
        m
    }

    /// A value fitted on `gravel_run` with standard error `se` and its 95 % interval.
    fn fitted_param(name: &str, value: f64, (lower, upper): (f64, f64), se: f64) -> FittedParam {
        FittedParam {
            name: name.into(),
            initial: None,
            value,
            lower,
            upper,
            at_bound: false,
            unit: "-".into(),
            se: Some(se),
            ci95: Some([value - 1.96 * se, value + 1.96 * se]),
            identifiable: Some(true),
            identifiability_note: None,
            neutral_in_interval: None,
            confounded: false,
        }
    }

    fn provenance(fitted: FittedParam, before: Option<ModelParams>) -> Provenance {
        Provenance {
            header: vec!["test".into()],
            fitted: vec![(fitted, "gravel_run".into())],
            before,
            chosen: Vec::new(),
        }
    }

    #[test]
    fn contact_effects_go_to_the_terrain() {
        let (r, t) = twin_models(&model()).unwrap();
        assert_eq!(r.effects.get("wheel_speed_saturation_rad_s"), Some(12.6));
        assert_eq!(t.effects.get("turning_resistance_scale"), Some(1.37));
        assert!(t.effects.get("motor_gain_left") == Some(1.0));
    }

    #[test]
    fn files_round_trip_value_for_value() {
        let m = model();
        let fitted = fitted_param(
            "terrain.friction.peak_lateral",
            m.terrain.friction.peak_lateral,
            (0.5, 1.5),
            0.01,
        );
        let files = twin_files(&m, &provenance(fitted, None)).unwrap();
        assert!(
            files
                .terrain_toml
                .contains("peak_lateral = 0.9123456789012345  # [fit] gravel_run"),
            "{}",
            files.terrain_toml
        );
        let r: Robot = drive_sim_model::config::parse_toml(&files.robot_toml, "robot.toml".as_ref()).unwrap();
        let t: Terrain =
            drive_sim_model::config::parse_toml(&files.terrain_toml, "terrain.toml".as_ref()).unwrap();
        let back = lift_effects(&r, &t).unwrap();
        assert_eq!(back.terrain, m.terrain);
        assert_eq!(back.robot, m.robot);
        assert_eq!(back.effects.declared(), m.effects.declared());
        // A discovered term lists the features it uses, not its 21 others at 0; a named
        // effect all its parameters (the right motor's gain of 1 beside the left's).
        assert!(files.robot_toml.contains("term_body_vy__wz = 0.085"));
        assert!(
            !files.robot_toml.contains("term_body_vy__abs_wz"),
            "{}",
            files.robot_toml
        );
        assert!(files.robot_toml.contains("motor_gain_right = 1.0"));
    }
    #[test]
    fn a_fitted_share_of_the_peak_comments_the_sliding_value_it_sets() {
        let before = model();
        let mut m = before.clone();
        let share = Param::SlidingShareLongitudinal;
        let specs = [ParamSpec::new(share, 0.5, 1.0)];
        m = m.with_values(&specs, &[0.9]).unwrap();
        let fitted = fitted_param(&share.name(), share.get(&m), (0.5, 1.0), 0.02);
        let files = twin_files(&m, &provenance(fitted, Some(before.clone()))).unwrap();
        let line = files
            .terrain_toml
            .lines()
            .find(|l| l.starts_with("sliding_longitudinal = "))
            .unwrap();
        let declared = share.get(&before);
        assert!(
            line.contains("# [fit] gravel_run: share of the peak 0.900000 ± 2.000e-2")
                && line.contains(&format!("declared {declared}")),
            "{line}"
        );
        assert!(
            (files.terrain.friction.sliding_longitudinal - 0.9 * m.terrain.friction.peak_longitudinal).abs()
                < 1e-12
        );
    }
}
