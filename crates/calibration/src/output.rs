//! What a calibration reports ([`CalibrationReport`] and its parts, the `calibration.json` that
//! users' scripts read: fields are added, never renamed or removed) and the files it is written
//! to.

use super::*;

/// How a declared effect (one the starting model's robot or terrain file has, such as the
/// Warthog's measured wheel-speed limit) fares on this log: refit as a base parameter, then
/// judged on the validation steps by switching it off in the final model (the test steps stay
/// for the report's scores).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeclaredEffectCheck {
    /// Registry name of the effect.
    pub effect: String,
    /// Its parameters: declared value, refit value and interval (`effect.<parameter>`).
    pub params: Vec<FittedParam>,
    /// Validation score of the final model with this effect switched off minus with it: what
    /// the effect buys on steps no fit saw (positive: the log needs it).
    pub removal_increase: f64,
    /// Bootstrap standard error of `removal_increase` (validation steps resampled, paired).
    pub removal_increase_se: f64,
    /// `removal_increase` beyond the selection's `k_se` standard errors.
    pub confirmed: bool,
    /// `removal_increase` below minus `k_se` standard errors: the log contradicts the
    /// declaration, and the effect is switched off in this log's final model.
    #[serde(default)]
    pub contradicted: bool,
    /// In words.
    pub verdict: String,
}

/// One row of the before/after table (test steps).
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
    /// Every optimizer stopped on a convergence criterion.
    pub converged: bool,
    /// What happened, in order (optimizer stops, skipped stages, choices made).
    pub notes: Vec<String>,
}

/// Per test step scores (same step order as `heldout_steps`), for distributions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepScores {
    /// IDD.
    pub idd: Vec<f64>,
    /// Declared model.
    pub before: Vec<f64>,
    /// Final model.
    pub after: Vec<f64>,
}

/// Everything [`calibrate`] found, serializable to JSON (see the module doc for which steps
/// each field is computed on).
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
    /// Training steps (fits, noise floor, command reach).
    pub train_steps: Vec<u32>,
    /// Validation steps (model choices).
    #[serde(default)]
    pub validation_steps: Vec<u32>,
    /// Test steps: every figure of the table is computed on them, and only there.
    pub heldout_steps: Vec<u32>,
    /// Steps of the log in no set: those the analysis excludes, with why (a localisation
    /// fault, an incomplete step).
    #[serde(default)]
    pub excluded_steps: Vec<drive_sim_analysis::segment::Exclusion>,
    /// Before/after table on the test steps.
    pub table: Vec<TableRow>,
    /// Noise floor estimate (training steps).
    pub floor: NoiseFloor,
    /// Test error of the IDD.
    pub idd: ErrorSummary,
    /// Test error of the declared model.
    pub before: ErrorSummary,
    /// Test error after the base (terrain) fit only.
    pub after_terrain: ErrorSummary,
    /// Test error of the final model.
    pub after: ErrorSummary,
    /// Per-step test scores.
    pub step_scores: StepScores,
    /// Test score reduction before → after.
    pub total_reduction: f64,
    /// Bootstrap standard error of `total_reduction` (test steps resampled).
    pub total_reduction_se: f64,
    /// Base (terrain / robot) fit, with intervals.
    pub terrain_fit: Option<FitResult>,
    /// The base fit was kept (false: it did not lower the validation score).
    pub terrain_fit_kept: bool,
    /// Screening with the kinematic model (simulator calibrations).
    #[serde(default)]
    pub screening: Option<ScreeningReport>,
    /// Forward selection rounds; the first one's ranking is the ranked list of candidate
    /// effects against the base-fitted model.
    pub rounds: Vec<SelectionRound>,
    /// Pairs tried after the forward pass.
    #[serde(default)]
    pub pairs: Vec<CandidateEvidence>,
    /// The backward pass.
    #[serde(default)]
    pub backward: Vec<BackwardStep>,
    /// The final joint fit, with the covariance of every parameter.
    #[serde(default)]
    pub final_fit: Option<FitResult>,
    /// The final joint fit replaced the selected model.
    #[serde(default)]
    pub final_fit_kept: bool,
    /// Parameters that ended on a bound: likely stand-ins for an effect the model lacks.
    #[serde(default)]
    pub stand_ins: Vec<String>,
    /// What discovery did after selection (rounds, equations, what was added and why).
    #[serde(default)]
    pub discovery: Option<stages::discovery::DiscoveryReport>,
    /// Residual diagnosis of the declared model on the test steps (RMSE / floor per channel).
    #[serde(default)]
    pub diagnosis_before: Option<diagnosis::Diagnosis>,
    /// Residual diagnosis of the calibrated model on the test steps.
    #[serde(default)]
    pub diagnosis_after: Option<diagnosis::Diagnosis>,
    /// Effects in the final model with their fitted values (`effect.<name>`) and intervals.
    pub effects: Vec<FittedParam>,
    /// The effects the starting model declared (robot and terrain files), refit and judged.
    #[serde(default)]
    pub declared_effects: Vec<DeclaredEffectCheck>,
    /// Registered effects this model cannot run (contact effects for the kinematic model).
    pub not_evaluated: Vec<String>,
    /// Model before.
    pub model_before: ModelParams,
    /// Model after.
    pub model_after: ModelParams,
    /// Residual of the base-fitted model (before effects), test steps.
    pub residual_before: ResidualAnalysis,
    /// Residual of the final model, test steps.
    pub residual_after: ResidualAnalysis,
    /// A command line that reproduces this report.
    pub reproduce: String,
    /// The twin's closed-loop check (simulator calibrations written by `calibrate`): a short
    /// DRIVE run of the twin files ([`twin::check_twin`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twin_check: Option<twin::TwinCheck>,
}

/// The calibrated terrain as a terrain TOML file, with a header saying where it comes from.
pub fn fitted_terrain_toml(report: &CalibrationReport) -> Result<String> {
    let body = toml::to_string(&report.model_after.terrain).map_err(|source| Error::Toml {
        what: "the fitted terrain",
        source,
    })?;
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

/// Writes the per-stage timings to `dir/timings.json` (kept apart from `calibration.json`,
/// which stays byte-identical for a seed).
pub fn write_timings(timings: &Timings, dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let path = dir.join("timings.json");
    let json = serde_json::to_string_pretty(timings).map_err(|e| Error::json(&path, e))?;
    std::fs::write(&path, json).map_err(|e| Error::io(&path, e))?;
    Ok(path)
}

/// Writes into `dir` (created if needed): `calibration.json` (the whole report),
/// `<dataset>_fitted_terrain.toml`, the figures (SVG + PNG) and `report.html`; returns the
/// paths written.
pub fn write_report(report: &CalibrationReport, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let json_path = dir.join("calibration.json");
    let json = serde_json::to_string_pretty(report).map_err(|e| Error::json(&json_path, e))?;
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
