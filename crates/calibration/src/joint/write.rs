//! A joint calibration's outputs: its twin (one robot file, one terrain file per log), the
//! closed-loop check of each log's twin, and the files written.

use super::JointReport;
use crate::error::{Error, Result};
use crate::fit::FittedParam;
use crate::twin;

/// The twin of a joint simulator calibration: one robot file, one terrain file per log
/// ([`super::terrain_file_name`]), each value commented with the datasets it was fitted on.
pub fn joint_twin(report: &JointReport) -> Result<(String, Vec<(String, String)>)> {
    if report.model_kind != "simulator" {
        return Err(Error::TwinOfKinematicModel {
            model_kind: report.model_kind.clone(),
            why: "",
        });
    }
    let all: Vec<&str> = report.logs.iter().map(|l| l.dataset.as_str()).collect();
    let header = vec![
        format!(
            "Twin calibrated by drive-sim jointly on {} logs of `{}` ({}), simulator model.",
            all.len(),
            report.robot,
            all.join(", ")
        ),
        format!("Reproduce: {}", report.reproduce),
        "[fit] comments: fitted value, standard error (clustered sandwich over every log's training steps) and 95 % interval.".into(),
    ];
    let mut robot_toml = String::new();
    let mut terrains = Vec::new();
    for (k, l) in report.logs.iter().enumerate() {
        let mut fitted: Vec<(FittedParam, String)> = report
            .robot_params
            .iter()
            .map(|p| (p.clone(), all.join(" + ")))
            .collect();
        fitted.extend(l.terrain_params.iter().map(|p| (p.clone(), l.dataset.clone())));
        let mut h = header.clone();
        h.push(format!(
            "This log's test score {:.3} (its own calibration {:.3}; 1 = noise floor) on {} held-out steps.",
            l.joint.score,
            l.single_score,
            l.test_steps.len()
        ));
        let prov = twin::Provenance {
            header: h,
            fitted,
            before: Some(report.singles[k].model_before.clone()),
            chosen: Vec::new(),
        };
        let files = twin::twin_files(&l.model, &prov)?;
        if k == 0 {
            robot_toml = files.robot_toml;
        }
        terrains.push((l.terrain_file.clone(), files.terrain_toml));
    }
    Ok((robot_toml, terrains))
}

/// Runs each log's twin of a joint simulator calibration (the robot with that log's terrain) in
/// closed loop ([`twin::check_twin`], seed `seed`), records it in the log's `twin_check` and
/// names a twin that does not run in the report's notes. Returns the datasets whose twin did
/// not run.
pub fn check_joint_twin(report: &mut JointReport, seed: u64) -> Result<Vec<String>> {
    let mut failed = Vec::new();
    for l in &mut report.logs {
        let (robot, terrain) = twin::twin_models(&l.model)?;
        let check = twin::check_twin(&robot, &terrain, twin::TWIN_CHECK_STEPS, seed)?;
        if let Some(note) = check.failure_note() {
            report.notes.push(format!("twin check ({}): {note}", l.dataset));
            failed.push(l.dataset.clone());
        }
        l.twin_check = Some(check);
    }
    Ok(failed)
}

/// Writes `dir/calibration.json` (the joint report), each log's own calibration in
/// `dir/<dataset>/` (as `calibrate LOG` writes it), and for a simulator model the twin in
/// `dir/twin/`: `robot.toml` and one `terrain_<dataset>.toml` per log. Returns the paths.
pub fn write_joint(report: &JointReport, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut paths = Vec::new();
    let json_path = dir.join("calibration.json");
    let json = serde_json::to_string_pretty(report).map_err(|e| Error::json(&json_path, e))?;
    std::fs::write(&json_path, json).map_err(|e| Error::io(&json_path, e))?;
    paths.push(json_path);
    for r in &report.singles {
        paths.extend(crate::write_report(r, &dir.join(&r.dataset))?);
    }
    if report.model_kind == "simulator" {
        let (robot, terrains) = joint_twin(report)?;
        let tdir = dir.join("twin");
        std::fs::create_dir_all(&tdir).map_err(|e| Error::io(&tdir, e))?;
        let p = tdir.join("robot.toml");
        std::fs::write(&p, robot).map_err(|e| Error::io(&p, e))?;
        paths.push(p);
        for (name, text) in terrains {
            let p = tdir.join(name);
            std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
            paths.push(p);
        }
    }
    Ok(paths)
}
