//! The twin's files: `twin/robot.toml` and its terrain file(s) with every fitted and tuned
//! value commented, the held-out twin's in `held_out/` (the model judged on the steps its choice
//! never saw, so that anyone can judge it again), `twin.json` with its provenance, and `twin.md`.

use crate::error::{Error, Result};
use crate::pass::Pass;
use crate::report::{markdown, terrain_file, TwinReport};
use drive_sim_calibration::twin::{self, check_twin, Provenance, TwinCheck, TWIN_CHECK_STEPS};
use drive_sim_calibration::ModelParams;
use drive_sim_model::output::write_atomic;
use drive_sim_model::provenance::{stamp_json_file, InputFile};
use std::path::{Path, PathBuf};

/// Each ground's twin run in closed loop for [`TWIN_CHECK_STEPS`] steps: the tuned model, or
/// the calibrated one when the tuned one does not complete (`true`: the tuned one is written).
/// Neither completing is an error: no runnable twin.
pub(crate) fn check_runs(
    tuned: &[ModelParams],
    calibrated: &[ModelParams],
    seed: u64,
) -> Result<Vec<(TwinCheck, bool)>> {
    let mut out = Vec::new();
    for (t, c) in tuned.iter().zip(calibrated) {
        let run = |m: &ModelParams| -> Result<TwinCheck> {
            let (robot, terrain) = twin::twin_models(m)?;
            Ok(check_twin(&robot, &terrain, TWIN_CHECK_STEPS, seed)?)
        };
        let first = run(t)?;
        if first.ran {
            out.push((first, true));
            continue;
        }
        let second = run(c)?;
        if !second.ran {
            return Err(Error::NoRunnableTwin {
                why: format!(
                    "the tuned twin: {}; the calibrated one: {}",
                    first.failure_note().unwrap_or_default(),
                    second.failure_note().unwrap_or_default()
                ),
            });
        }
        out.push((second, false));
    }
    Ok(out)
}

/// What [`write_twin`] writes.
pub(crate) struct Written<'a> {
    pub(crate) report: &'a TwinReport,
    /// The held-out pass (its twins, as judged).
    pub(crate) held: &'a Pass,
    /// The final pass (the models written).
    pub(crate) fin: &'a Pass,
    /// The log files given (the provenance's inputs).
    pub(crate) logs: &'a [PathBuf],
}

/// Which pass's twin a set of files holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Which {
    /// Chosen on the odd steps, judged on the even ones: `held_out/`.
    HeldOut,
    /// Chosen on every step: `twin/`.
    Final,
}

/// The folder of the held-out twin's files, beside `twin/`.
pub(crate) const HELD_OUT_DIR: &str = "held_out";

/// Writes the twin into `dir`; returns the files' names relative to it.
pub(crate) fn write_twin(w: &Written, dir: &Path) -> Result<Vec<PathBuf>> {
    let r = w.report;
    let mut names = Vec::new();
    for (g, check) in r.twin_checks.iter().enumerate() {
        let tuned = check.written == "tuned";
        let model = if tuned {
            &w.fin.twin[g]
        } else {
            &w.fin.calibrated[g]
        };
        names.extend(write_ground(w, Which::Final, g, model, tuned, &dir.join("twin"))?);
    }
    // The held-out twin as the judge ran it: tuned when its check accepted the tuning.
    for (g, model) in w.held.twin.iter().enumerate() {
        names.extend(write_ground(
            w,
            Which::HeldOut,
            g,
            model,
            true,
            &dir.join(HELD_OUT_DIR),
        )?);
    }
    let json = dir.join("twin.json");
    let text = serde_json::to_string_pretty(r).map_err(|e| Error::json(&json, e))?;
    write_atomic(&json, text.as_bytes())?;
    let inputs = w.logs.iter().map(|p| InputFile::of_file("log", p)).collect();
    stamp_json_file(
        &json,
        &drive_sim_model::provenance::Provenance::new(
            inputs,
            serde_json::to_value(r.options).unwrap_or_default(),
        ),
    )?;
    names.push(PathBuf::from("twin.json"));
    write_atomic(&dir.join("twin.md"), markdown(r).as_bytes())?;
    names.push(PathBuf::from("twin.md"));
    Ok(names)
}

/// Writes ground `g`'s files of one pass's twin into `folder` (the robot file with the first
/// ground); returns their names relative to `folder`'s parent.
fn write_ground(
    w: &Written,
    which: Which,
    g: usize,
    model: &ModelParams,
    tuned: bool,
    folder: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(folder).map_err(|e| Error::io(folder, e))?;
    let sub = PathBuf::from(folder.file_name().unwrap_or_default());
    let files = twin::twin_files(model, &provenance_of(w, which, g, tuned))?;
    let mut names = Vec::new();
    if g == 0 {
        write_atomic(&folder.join("robot.toml"), files.robot_toml.as_bytes())?;
        names.push(sub.join("robot.toml"));
    }
    let ground = &w.report.grounds[g];
    let name = terrain_file(&ground.name, w.report.grounds.len());
    write_atomic(&folder.join(&name), files.terrain_toml.as_bytes())?;
    names.push(sub.join(name));
    Ok(names)
}

/// The comments of a ground's twin files: the fitted values with their intervals, the tuned
/// ones with how they were chosen, and the judgements in the header.
fn provenance_of(w: &Written, which: Which, g: usize, tuned: bool) -> Provenance {
    let r = w.report;
    let (judged, pass, made) = match which {
        Which::HeldOut => (
            &r.held_out,
            w.held,
            "Held-out twin made by `drive-sim twin` from the odd steps of",
        ),
        Which::Final => (&r.final_twin, w.fin, "Twin made by `drive-sim twin` from"),
    };
    let cal = &judged.pass.calibration[g];
    let mut header = vec![
        format!(
            "{made} {} (ground `{}`), seed {}.",
            r.runs
                .iter()
                .map(|x| x.dataset.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            cal.ground,
            r.options.seed
        ),
        format!(
            "Reproduce: drive-sim twin {} --seed {} --budget {}",
            w.logs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(" "),
            r.options.seed,
            r.options.budget
        ),
    ];
    // The twin written names both judgements; the held-out twin only its own.
    let judgements: Vec<_> = match which {
        Which::HeldOut => r.held_out.judgements.iter().collect(),
        Which::Final => r
            .held_out
            .judgements
            .iter()
            .chain(&r.final_twin.judgements)
            .collect(),
    };
    for j in judgements.into_iter().filter(|j| j.ground == cal.ground) {
        header.push(format!(
            "Judged on {} of {}{}: {} (p {:.3}); see twin.md.",
            crate::judging::steps_text(&j.steps),
            j.against,
            if j.held_out { " (held out)" } else { "" },
            if j.outcome.indistinguishable {
                "compare cannot tell it from the robot"
            } else {
                "compare tells it from the robot"
            },
            j.outcome.loss.p
        ));
    }
    if !tuned {
        header.push("The tuned model did not complete its closed-loop check: these are the calibrated model's values.".into());
    }
    header.push("[fit] comments: calibrated by replay (clustered sandwich over the training steps); [log] comments: measured on the steps (random effects); [twin] comments: tuned in closed loop.".into());
    // Both rounds' values, each round's when its check accepted it.
    let rounds = judged
        .pass
        .tuning
        .iter()
        .chain(judged.pass.refinement.as_ref().and_then(|r| r.tuning.as_ref()))
        .filter(|t| tuned && t.accepted);
    let chosen = rounds
        .flat_map(|t| {
            t.values
            .iter()
            .filter(|v| v.ground.as_deref().is_none_or(|gr| gr == cal.ground))
            .map(|v| {
                let name = if v.name.contains('.') {
                    v.name.clone()
                } else {
                    format!("effect.{}", v.name)
                };
                (
                    name,
                    format!(
                        "[twin] {:.6} {}, chosen in closed loop in [{}, {}] (calibrated: {}){}{}; check on fresh seeds: loss reduction {:.3} ± {:.3} (SE)",
                        v.chosen,
                        v.unit,
                        v.lower,
                        v.upper,
                        if v.calibrated.is_finite() { format!("{:.6}", v.calibrated) } else { "off".into() },
                        v.interval
                            .map_or(String::new(), |[a, b]| format!("; profile interval [{a:.6}, {b:.6}]")),
                        v.near_best.map_or(String::new(), |[a, b]| format!("; near-best range [{a:.6}, {b:.6}]")),
                        t.check.mean_reduction,
                        t.check.se
                    ),
                )
            })
        })
        .collect::<Vec<_>>();
    let measured = judged.pass.measured.iter().map(|v| {
        (
            format!("effect.{}", v.name),
            format!("[log] {:.6} {}, measured: {}", v.value, v.unit, v.from),
        )
    });
    let chosen = measured.chain(chosen).collect();
    Provenance {
        header,
        fitted: cal
            .fitted
            .iter()
            .map(|p| (p.clone(), cal.dataset.clone()))
            .collect(),
        before: Some(pass.declared[g].clone()),
        chosen,
    }
}
