//! Closing the loop with measured data: how far the simulator is from the robot, which effect
//! the model lacks, and how much adding it closes the gap, on steps the fit never saw.
//!
//! [`calibrate`] runs the loop on a [`DriveLog`]:
//! 1. split the steps into training and held-out sets (seeded, [`fit::split_steps`]);
//! 2. estimate the noise floor from the whole recording ([`metrics::NoiseFloor`]);
//! 3. score the IDD and the declared model on the held-out steps (baseline);
//! 4. fit the terrain / uncertain robot parameters the plant exposes, on the training steps;
//!    the fit is kept if it lowers the score on all training steps and on the held-out ones;
//! 5. residual analysis ([`residual`]) and ranking of candidate effects, each fitted on the
//!    training steps with the terrain / robot parameters refit beside it, and judged by its
//!    held-out error reduction ([`candidates`]);
//! 6. greedy forward selection: add the best effect if it passes the [`SelectionRule`]
//!    (reduction > k bootstrap standard errors and > a minimum relative gain), refit it jointly
//!    with the terrain parameters (those may have absorbed part of the effect), re-rank the
//!    rest on top, repeat. Every fitted change (terrain fit, joint refit) is kept only if it
//!    lowers the score on all the training steps;
//! 7. report everything on the held-out steps: IDD, model before, model after, noise floor.
//!
//! Nothing reads what a log says was injected: the effects are found from the data alone.
//!
//! Caveat: the held-out steps decide which effect is added and whether the terrain fit is kept
//! (that is the evidence asked for), so the final held-out score is slightly optimistic for the
//! selected model; no fit (terrain, effect, joint refit) ever sees the held-out steps.

pub mod candidates;
pub mod figures;
pub mod fit;
pub mod metrics;
pub mod model;
pub mod replay;
pub mod residual;
pub mod surrogate;

pub use candidates::{CandidateEvidence, CommandReach, EffectCandidate, SelectionRule};
pub use fit::{FitOptions, FitResult, FittedParam};
pub use metrics::{ErrorSummary, NoiseFloor};
pub use model::{IddFactory, KinematicFactory, ModelParams, ParamSpec, PlantFactory, SimFactory};
pub use replay::{replay_log, ReplayOptions};
pub use residual::ResidualAnalysis;

use crate::error::{Error, Result};
use crate::log::{DriveLog, Origin};
use crate::robot::Robot;
use crate::terrain::Terrain;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationOptions {
    /// Seed of the train/held-out split and of the bootstrap.
    pub seed: u64,
    /// Fraction of the steps used for fitting.
    pub train_fraction: f64,
    /// Fit at most this many training steps per cost evaluation (a seeded subset; all when
    /// `None`): replays are the expensive part.
    pub max_fit_steps: Option<usize>,
    /// Budget of the terrain / robot-parameter fit.
    pub terrain_fit: FitOptions,
    /// Budget of each candidate-effect fit.
    pub effect_fit: FitOptions,
    /// Budget of the joint refit (terrain parameters + selected effects) after each effect is
    /// added (0 iterations: skip it).
    pub final_fit: FitOptions,
    /// Most effects added.
    pub max_effects: usize,
    /// When an effect counts as an improvement.
    pub rule: SelectionRule,
    /// Only these candidate effects (all the plant implements when `None`).
    pub candidates: Option<Vec<String>>,
    /// Grid resolution of the residual maps (m/s and rad/s).
    pub grid_step: f64,
    /// Kernel variance of the residual maps; by robot size when `None` (0.64 for a robot
    /// faster than 2 m/s as in the paper's Warthog figures, else 0.25 as for the Husky).
    pub kernel_var: Option<f64>,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            seed: 0,
            train_fraction: 0.7,
            max_fit_steps: None,
            terrain_fit: FitOptions::default(),
            effect_fit: FitOptions {
                max_iters: 40,
                sd_tolerance: 1e-3,
            },
            final_fit: FitOptions {
                max_iters: 100,
                sd_tolerance: 1e-3,
            },
            max_effects: 3,
            rule: SelectionRule::default(),
            candidates: None,
            grid_step: 0.1,
            kernel_var: None,
        }
    }
}

/// One row of the before/after table (held-out steps).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableRow {
    /// Metric.
    pub metric: String,
    /// Unit.
    pub unit: String,
    /// Ideal differential drive.
    pub idd: f64,
    /// Declared model (robot file + terrain file, no effect).
    pub sim_before: f64,
    /// Calibrated model.
    pub sim_after: f64,
    /// Noise floor.
    pub floor: f64,
}

/// Overall outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationStatus {
    /// Every optimizer converged.
    pub converged: bool,
    /// What happened, in order (optimizer stops, skipped stages, choices made).
    pub notes: Vec<String>,
}

/// One round of the greedy selection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelectionRound {
    /// Round index, from 0.
    pub round: usize,
    /// Candidates ranked by held-out reduction, best first.
    pub ranking: Vec<CandidateEvidence>,
    /// The effect added in this round, if any.
    pub added: Option<String>,
}

/// Per held-out step scores (same step order as `heldout_steps`), for distributions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepScores {
    /// IDD.
    pub idd: Vec<f64>,
    /// Declared model.
    pub before: Vec<f64>,
    /// Final model.
    pub after: Vec<f64>,
}

/// Everything [`calibrate`] found, serializable to JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationReport {
    /// Dataset name.
    pub dataset: String,
    /// File it was read from, when measured.
    pub source_file: Option<String>,
    /// Plant used as the model.
    pub model_kind: String,
    /// Options used.
    pub options: CalibrationOptions,
    /// Outcome.
    pub status: CalibrationStatus,
    /// Training steps.
    pub train_steps: Vec<u32>,
    /// Held-out steps (every figure of the table is computed on them).
    pub heldout_steps: Vec<u32>,
    /// Before/after table on the held-out steps.
    pub table: Vec<TableRow>,
    /// Noise floor estimate.
    pub floor: NoiseFloor,
    /// Held-out error of the IDD.
    pub idd: ErrorSummary,
    /// Held-out error of the declared model.
    pub before: ErrorSummary,
    /// Held-out error after terrain calibration only.
    pub after_terrain: ErrorSummary,
    /// Held-out error of the final model.
    pub after: ErrorSummary,
    /// Per-step held-out scores.
    pub step_scores: StepScores,
    /// Held-out score reduction before → after, and its bootstrap standard error.
    pub total_reduction: f64,
    /// Bootstrap standard error of `total_reduction`.
    pub total_reduction_se: f64,
    /// Terrain / robot-parameter fit.
    pub terrain_fit: Option<FitResult>,
    /// The terrain fit was kept (false: it did not lower the score on all training steps, or
    /// on the held-out steps; the declared values were kept).
    pub terrain_fit_kept: bool,
    /// Selection rounds; the first one's ranking is the ranked list of candidate effects
    /// against the terrain-calibrated model.
    pub rounds: Vec<SelectionRound>,
    /// Effects in the final model with their fitted values (`effect.<name>`).
    pub effects: Vec<FittedParam>,
    /// Effects the plant implements but that were not evaluated (no known search box).
    pub not_evaluated: Vec<String>,
    /// Model before.
    pub model_before: ModelParams,
    /// Model after.
    pub model_after: ModelParams,
    /// Residual of the terrain-calibrated model (before effects), held-out steps.
    pub residual_before: ResidualAnalysis,
    /// Residual of the final model, held-out steps.
    pub residual_after: ResidualAnalysis,
    /// A command line that reproduces this report.
    pub reproduce: String,
}

/// The robot and terrain a log declares: the robot file named by the log with the operators'
/// nominal wheel radius, baseline and wheel-speed limit, and the terrain file of the same name
/// (the returned notes say when a terrain had to be assumed).
pub fn models_for_log(log: &DriveLog) -> Result<(Robot, Terrain, Vec<String>)> {
    let (mut robot, _) = Robot::resolve(&log.meta.robot)?;
    let n = &log.meta.nominal;
    robot.wheels.radius_m = n.wheel_radius_m;
    robot.wheels.baseline_m = n.baseline_m;
    robot.powertrain.max_wheel_rad_s = n.max_wheel_rad_s;
    let mut notes = Vec::new();
    let terrain = match Terrain::resolve(&log.meta.terrain) {
        Ok((t, _)) => t,
        Err(_) => {
            notes.push(format!(
                "terrain `{}` has no terrain file: started from `asphalt`",
                log.meta.terrain
            ));
            Terrain::resolve("asphalt")?.0
        }
    };
    Ok((robot, terrain, notes))
}

fn table(
    idd: &ErrorSummary,
    before: &ErrorSummary,
    after: &ErrorSummary,
    floor: &ErrorSummary,
) -> Vec<TableRow> {
    idd.rows()
        .into_iter()
        .zip(before.rows())
        .zip(after.rows())
        .zip(floor.rows())
        .map(|(((i, b), a), f)| TableRow {
            metric: i.metric,
            unit: i.unit,
            idd: i.value,
            sim_before: b.value,
            sim_after: a.value,
            floor: f.value,
        })
        .collect()
}

/// Runs the calibration loop (see the module doc) of the plant `factory` builds, starting
/// from `robot` and `terrain`, on `log`.
pub fn calibrate(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
) -> Result<CalibrationReport> {
    calibrate_with_progress(log, robot, terrain, factory, opts, &mut |_| {})
}

/// [`calibrate`], telling `progress` in a line what each stage found as it ends (for a CLI:
/// a simulator calibration takes minutes).
pub fn calibrate_with_progress(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<CalibrationReport> {
    if !(opts.train_fraction > 0.0 && opts.train_fraction < 1.0) {
        return Err(Error::Analysis(format!(
            "train fraction must be in (0, 1), got {}",
            opts.train_fraction
        )));
    }
    let slices = replay::step_slices(log);
    let steps: Vec<u32> = slices.iter().map(|s| s.step).collect();
    if steps.len() < 4 {
        return Err(Error::Analysis(format!(
            "calibration needs at least 4 completed steps, `{}` has {}",
            log.meta.name,
            steps.len()
        )));
    }
    let mut notes = Vec::new();
    let mut converged = true;
    let (train_ids, test_ids) = fit::split_steps(&steps, opts.train_fraction, opts.seed);
    let rate = log.meta.rate_hz;
    let all = fit::StepSet::new(&slices, &steps, rate)?;
    let floor = NoiseFloor::estimate(&all.features)?;
    let fit_ids: Vec<u32> = match opts.max_fit_steps {
        Some(k) if k < train_ids.len() => {
            let (mut sub, _) =
                fit::split_steps(&train_ids, k as f64 / train_ids.len() as f64, opts.seed ^ 0x5eed);
            sub.truncate(k.max(1));
            notes.push(format!(
                "cost evaluated on {} of {} training steps",
                sub.len(),
                train_ids.len()
            ));
            sub
        }
        _ => train_ids.clone(),
    };
    let train = fit::StepSet::new(&slices, &fit_ids, rate)?;
    // Every fitted change is kept only if it lowers the score on all training steps (not only
    // the subset the cost used): a fit that overfits the subset is rejected without looking
    // at the held-out steps.
    let train_full = if fit_ids.len() < train_ids.len() {
        Some(fit::StepSet::new(&slices, &train_ids, rate)?)
    } else {
        None
    };
    let train_score = |p: &ModelParams| -> Result<f64> {
        let set = train_full.as_ref().unwrap_or(&train);
        Ok(metrics::score(&set.errors(factory, p)?, &floor))
    };
    let test = fit::StepSet::new(&slices, &test_ids, rate)?;

    let declared = ModelParams::new(robot.clone(), terrain.clone());
    let summary =
        |p: &ModelParams, f: &dyn PlantFactory| -> Result<(ErrorSummary, Vec<metrics::StepErrors>)> {
            let e = test.errors(f, p)?;
            Ok((ErrorSummary::pool(&e, &floor), e))
        };
    let (idd, idd_errors) = summary(&declared, &IddFactory)?;
    let (before, before_errors) = summary(&declared, factory)?;
    progress(&format!(
        "baseline on {} held-out steps: score IDD {:.1}, declared model {:.1} (1 = noise floor)",
        test_ids.len(),
        idd.score,
        before.score
    ));

    // Terrain / robot parameters.
    let specs = factory.calibration_params(&declared);
    let (mut current, terrain_fit, terrain_fit_kept) = if specs.is_empty() {
        notes.push(format!(
            "the {} model exposes no terrain parameter: terrain fit skipped",
            factory.name()
        ));
        (declared.clone(), None, false)
    } else {
        let (m, r) = fit::fit(&train, factory, &declared, &specs, &floor, &opts.terrain_fit)?;
        if !r.converged {
            converged = false;
            notes.push(format!("terrain fit: {}", r.status));
        }
        let (old, new) = (train_score(&declared)?, train_score(&m)?);
        // Like an effect, the fitted terrain is a model change: it stays only if it also
        // lowers the held-out score (a fit that helps the training steps and hurts the others
        // has fitted their noise).
        let heldout = summary(&m, factory)?.0.score;
        if new <= old && heldout <= before.score {
            (m, Some(r), true)
        } else if new <= old {
            notes.push(format!(
                "terrain fit discarded: held-out score {:.3} -> {heldout:.3} (training {old:.3} -> {new:.3})",
                before.score
            ));
            (declared.clone(), Some(r), false)
        } else {
            notes.push(format!(
                "terrain fit discarded: training score {old:.3} -> {new:.3} on all training steps"
            ));
            (declared.clone(), Some(r), false)
        }
    };
    let (after_terrain, _) = summary(&current, factory)?;
    progress(&format!(
        "terrain fit {}: held-out score {:.1}",
        if terrain_fit_kept { "kept" } else { "not kept" },
        after_terrain.score
    ));
    let sim_feats = |p: &ModelParams| -> Result<Vec<metrics::StepFeatures>> {
        let replayed = replay::replay_steps(&test.steps, factory, p, rate)?;
        replayed
            .iter()
            .zip(&test.steps)
            .map(|(r, s)| metrics::step_features(s.step, r))
            .collect()
    };
    let space = robot.command_space();
    let kernel_var = opts.kernel_var.unwrap_or(if robot.limits.max_lin_m_s > 2.0 {
        0.64
    } else {
        0.25
    });
    let residual_before = residual::analyse(
        &sim_feats(&current)?,
        &test.features,
        robot.idd(),
        &space,
        opts.grid_step,
        kernel_var,
    );

    // Candidate effects, greedy forward selection.
    let nominal = robot.idd();
    let reach = log.samples.iter().fold(
        CommandReach {
            wheel_rad_s: 0.0,
            speed_m_s: 0.0,
            yaw_rate_rad_s: 0.0,
        },
        |r, s| {
            let c = s.m.cmd;
            let v = nominal.body_from_wheels(c);
            CommandReach {
                wheel_rad_s: r.wheel_rad_s.max(c.left_rad_s.abs()).max(c.right_rad_s.abs()),
                speed_m_s: r.speed_m_s.max(v.vx_m_s.abs()),
                yaw_rate_rad_s: r.yaw_rate_rad_s.max(v.wz_rad_s.abs()),
            }
        },
    );
    let (mut pool, not_evaluated) = candidates::default_candidates(&factory.effect_names(), &reach);
    if let Some(only) = &opts.candidates {
        pool.retain(|c| only.contains(&c.name));
    }
    let mut rounds = Vec::new();
    let mut selected: Vec<EffectCandidate> = Vec::new();
    for round in 0..opts.max_effects {
        if pool.is_empty() {
            break;
        }
        let ranked = candidates::evaluate_candidates(
            &train,
            &test,
            factory,
            &current,
            &specs,
            terrain_fit_kept.then_some(&declared),
            &floor,
            &pool,
            &opts.effect_fit,
            &SelectionRule {
                seed: opts.rule.seed ^ opts.seed ^ round as u64,
                ..opts.rule
            },
        )?;
        if let Some((ev, _)) = ranked.first() {
            progress(&format!(
                "round {round}: {} candidates, best {} (held-out {:.1} -> {:.1}, ± {:.1}){}",
                ranked.len(),
                ev.effect,
                ev.heldout_before,
                ev.heldout_after,
                ev.reduction_se,
                if ev.significant {
                    ", added"
                } else {
                    ", not significant: stop"
                }
            ));
        }
        for (ev, _) in &ranked {
            if !ev.converged {
                notes.push(format!("round {round}, {}: {}", ev.effect, ev.fit_status));
            }
        }
        let added = match ranked.first() {
            Some((ev, model)) if ev.significant => {
                current = model.clone();
                let name = ev.effect.clone();
                if let Some(i) = pool.iter().position(|c| c.name == name) {
                    selected.push(pool.remove(i));
                }
                Some(name)
            }
            _ => None,
        };
        let stop = added.is_none();
        if !stop && opts.final_fit.max_iters > 0 {
            // Refit the terrain / robot parameters with every selected effect: what they had
            // absorbed of the effect before it was in the model goes back. Kept if not worse
            // on the held-out steps.
            let mut joint = specs.clone();
            joint.extend(
                selected
                    .iter()
                    .flat_map(|c| c.params.iter().filter(|p| !p.discrete).cloned()),
            );
            let (m, r) = fit::fit(&train, factory, &current, &joint, &floor, &opts.final_fit)?;
            let (old, new) = (train_score(&current)?, train_score(&m)?);
            if new <= old {
                current = m;
                notes.push(format!(
                    "round {round}, joint refit: training score {old:.3} -> {new:.3}"
                ));
            } else {
                notes.push(format!(
                    "round {round}, joint refit discarded: training score {old:.3} -> {new:.3}"
                ));
            }
            if !r.converged {
                converged = false;
                notes.push(format!("round {round}, joint refit: {}", r.status));
            }
        }
        rounds.push(SelectionRound {
            round,
            ranking: ranked.into_iter().map(|(e, _)| e).collect(),
            added,
        });
        if stop {
            break;
        }
    }

    if rounds.iter().flat_map(|r| &r.ranking).any(|e| !e.converged) {
        converged = false;
    }

    let (after, after_errors) = summary(&current, factory)?;
    let step_scores = StepScores {
        idd: idd_errors.iter().map(|e| e.score(&floor)).collect(),
        before: before_errors.iter().map(|e| e.score(&floor)).collect(),
        after: after_errors.iter().map(|e| e.score(&floor)).collect(),
    };
    let total_reduction = before.score - after.score;
    let total_reduction_se = candidates::bootstrap_reduction_se(
        &before_errors,
        &after_errors,
        &floor,
        opts.rule.bootstrap_samples,
        opts.seed,
    );
    let residual_after = residual::analyse(
        &sim_feats(&current)?,
        &test.features,
        robot.idd(),
        &space,
        opts.grid_step,
        kernel_var,
    );
    let effects = current
        .effects
        .iter()
        .map(|(k, v)| {
            let name = format!("effect.{k}");
            match selected.iter().flat_map(|c| &c.params).find(|p| p.name == name) {
                Some(spec) => FittedParam::of(spec, None, *v),
                None => FittedParam {
                    name,
                    initial: None,
                    value: *v,
                    lower: f64::NAN,
                    upper: f64::NAN,
                    at_bound: false,
                },
            }
        })
        .collect();
    let source_file = match &log.meta.origin {
        Origin::Measured { file } => Some(file.clone()),
        _ => None,
    };
    let reproduce = format!(
        "drive-sim calibrate {} --out <DIR> --seed {}",
        source_file.as_deref().unwrap_or(&log.meta.name),
        opts.seed
    );
    Ok(CalibrationReport {
        dataset: log.meta.name.clone(),
        source_file,
        model_kind: factory.name(),
        options: opts.clone(),
        status: CalibrationStatus { converged, notes },
        train_steps: train_ids,
        heldout_steps: test_ids,
        table: table(&idd, &before, &after, &ErrorSummary::floor(&floor)),
        floor,
        idd,
        before,
        after_terrain,
        after,
        step_scores,
        total_reduction,
        total_reduction_se,
        terrain_fit,
        terrain_fit_kept,
        rounds,
        effects,
        not_evaluated,
        model_before: declared,
        model_after: current,
        residual_before,
        residual_after,
        reproduce,
    })
}

/// Which plant to calibrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// The rapier simulator ([`SimFactory`]).
    Simulator,
    /// The kinematic grey-box model ([`KinematicFactory`]): seconds instead of minutes.
    Kinematic,
}

impl ModelKind {
    /// Names accepted by [`ModelKind::parse`].
    pub const NAMES: &'static [&'static str] = &["simulator", "kinematic"];

    /// Parses a model name (for the CLI).
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "simulator" | "sim" => Ok(Self::Simulator),
            "kinematic" => Ok(Self::Kinematic),
            _ => Err(Error::Unknown {
                kind: "model",
                name: name.to_string(),
                available: Self::NAMES.join(", "),
            }),
        }
    }

    /// The factory of this model.
    pub fn factory(self) -> Box<dyn PlantFactory> {
        match self {
            Self::Simulator => Box::new(SimFactory::default()),
            Self::Kinematic => Box::new(KinematicFactory),
        }
    }
}

/// Reads a measured dataset (CSV + sibling JSON) and calibrates `kind` on it, starting from the
/// robot and terrain the log declares ([`models_for_log`]; their notes go to the report).
/// What `drive-sim calibrate MEASURED` runs.
pub fn calibrate_file(csv: &Path, kind: ModelKind, opts: &CalibrationOptions) -> Result<CalibrationReport> {
    let log = crate::log::csv::read_measured_csv(csv)?;
    let (robot, terrain, notes) = models_for_log(&log)?;
    let mut report = calibrate(&log, &robot, &terrain, kind.factory().as_ref(), opts)?;
    report.status.notes.splice(0..0, notes);
    report.reproduce = format!(
        "drive-sim calibrate {} --model {} --seed {} --out <DIR>",
        csv.display(),
        ModelKind::NAMES[kind as usize],
        opts.seed
    );
    Ok(report)
}

/// A replay of a whole log and how far it is from the recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplayComparison {
    /// The replayed log (same steps, windows and sampling as the recording).
    pub replayed: DriveLog,
    /// Error of the replay over all steps.
    pub model: ErrorSummary,
    /// Error of the IDD over all steps.
    pub idd: ErrorSummary,
    /// Noise floor of the recording.
    pub floor: ErrorSummary,
}

/// Replays every step of `log` on the declared model `kind` (no fit) and compares it with the
/// recording, beside the IDD and the noise floor. What `drive-sim replay MEASURED` runs.
pub fn replay_and_compare(log: &DriveLog, kind: ModelKind) -> Result<ReplayComparison> {
    let (robot, terrain, _) = models_for_log(log)?;
    let params = ModelParams::new(robot, terrain);
    let factory = kind.factory();
    let slices = replay::step_slices(log);
    let steps: Vec<u32> = slices.iter().map(|s| s.step).collect();
    let all = fit::StepSet::new(&slices, &steps, log.meta.rate_hz)?;
    let floor = NoiseFloor::estimate(&all.features)?;
    let model = ErrorSummary::pool(&all.errors(factory.as_ref(), &params)?, &floor);
    let idd = ErrorSummary::pool(&all.errors(&IddFactory, &params)?, &floor);
    let replayed = replay_log(log, factory.as_ref(), &params, &ReplayOptions::default())?;
    Ok(ReplayComparison {
        replayed,
        model,
        idd,
        floor: ErrorSummary::floor(&floor),
    })
}

/// The calibrated terrain as a terrain TOML file, with a header saying where it comes from.
pub fn fitted_terrain_toml(report: &CalibrationReport) -> Result<String> {
    let body = toml::to_string(&report.model_after.terrain)
        .map_err(|e| Error::Analysis(format!("cannot serialize the fitted terrain: {e}")))?;
    Ok(format!(
        "# Fitted to `{}` by drive-sim calibrate ({} model, seed {}).\n\
         # Held-out score {:.3} (declared model {:.3}, 1 = noise floor); held-out steady vx RMSE\n\
         # {:.4} m/s (floor {:.4}), wz RMSE {:.4} rad/s (floor {:.4}), on {} held-out steps.\n\
         # Effects in the calibrated model (not part of the terrain): {}.\n{}",
        report.dataset,
        report.model_kind,
        report.options.seed,
        report.after.score,
        report.before.score,
        report.after.steady_vx_m_s,
        report.floor.steady[0],
        report.after.steady_wz_rad_s,
        report.floor.steady[2],
        report.heldout_steps.len(),
        if report.effects.is_empty() {
            "none".to_string()
        } else {
            report
                .effects
                .iter()
                .map(|e| format!("{}={:.4}", e.name, e.value))
                .collect::<Vec<_>>()
                .join(", ")
        },
        body
    ))
}

/// Writes into `dir` (created if needed): `calibration.json` (the whole report),
/// `<dataset>_fitted_terrain.toml`, the figures (SVG + PNG) and `report.html`; returns the
/// paths written.
pub fn write_report(report: &CalibrationReport, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let json_path = dir.join("calibration.json");
    let json = serde_json::to_string_pretty(report)
        .map_err(|e| Error::Analysis(format!("cannot serialize the report: {e}")))?;
    std::fs::write(&json_path, json).map_err(|e| Error::io(&json_path, e))?;
    let toml_path = dir.join(format!("{}_fitted_terrain.toml", report.dataset));
    std::fs::write(&toml_path, fitted_terrain_toml(report)?).map_err(|e| Error::io(&toml_path, e))?;
    let figures = figures::write_figures(report, dir)?;
    let html = figures::write_html(report, &figures, dir)?;
    let mut paths = vec![json_path, toml_path];
    for (_, f) in figures {
        paths.push(f.svg);
        paths.push(f.png);
    }
    paths.push(html);
    Ok(paths)
}
