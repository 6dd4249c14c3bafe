//! A tuning's files: `tune.json`, the twin (`twin/robot.toml`, `twin/terrain.toml`) and, when
//! it was judged on held-out steps, the first judging seed's comparison (`heldout/`: its
//! `comparison.json`, figures and `report.html`, the start model as simulated log 0 and the
//! chosen one as 1); when it was chosen on every step, the same on those steps
//! (`same_steps/`, not held out).

use super::TuneOutcome;
use crate::write::write_comparison;
use drive_sim_calibration::twin::{self, TwinFiles};
use drive_sim_model::error::Error;
use drive_sim_model::error::Result;
use drive_sim_model::provenance::Provenance;
use std::path::{Path, PathBuf};

/// Writes the tuning's files into `dir`; returns their paths.
pub fn write_tune(
    outcome: &TuneOutcome,
    twin_files: &TwinFiles,
    real_u: &[(f64, f64)],
    provenance: &Provenance,
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    let json = dir.join("tune.json");
    drive_sim_model::output::write_json_atomic(&json, outcome)?;
    drive_sim_model::provenance::stamp_json_file(&json, provenance)?;
    let mut files = vec![json];
    files.extend(twin::write_twin(twin_files, &dir.join("twin"))?);
    if let Some(first) = outcome.heldout.as_ref().and_then(|h| h.reports.first()) {
        files.extend(write_comparison(first, real_u, &dir.join("heldout"))?);
    }
    if let Some(first) = outcome.same_steps.as_ref().and_then(|h| h.reports.first()) {
        files.extend(write_comparison(first, real_u, &dir.join("same_steps"))?);
    }
    Ok(files)
}

/// The twin files of a tuning: the twin's model, each tuned value commented with how it was
/// chosen (no interval: a closed-loop search gives none; `tune.json` holds every point it
/// evaluated).
pub fn twin_of(outcome: &TuneOutcome, start_source: &str, reproduce: &str) -> Result<twin::TwinFiles> {
    let model = outcome
        .model
        .as_ref()
        .ok_or_else(|| Error::Analysis("a tuning read back from JSON has no model".into()))?;
    let mut header = vec![
        format!(
            "Twin tuned in closed loop by drive-sim on `{}` ({} steps), starting from {start_source}.",
            outcome.dataset,
            outcome.options.choose_on.as_str()
        ),
        format!(
            "Loss (compare's statistics, 1 per term at its verdict's threshold) {} -> {:.3} on seeds {:?}; check on fresh seeds: reduction {:.3} ± {:.3} (SE), {}.",
            outcome.start_loss.map_or_else(|| "failed".into(), |l| format!("{l:.3}")),
            outcome.chosen_loss,
            outcome.choose_seeds,
            outcome.check.mean_reduction,
            outcome.check.se,
            if outcome.accepted { "accepted" } else { "not accepted: these are the start's values" }
        ),
        format!("Reproduce: {reproduce}"),
    ];
    if let Some(h) = &outcome.heldout {
        header.push(format!(
            "Judged on the {} {} steps: see tune.json (heldout) and heldout/report.html.",
            h.real_steps,
            h.steps.as_str()
        ));
    }
    let chosen = if outcome.accepted {
        outcome
            .params
            .iter()
            .map(|p| {
                let unit = if p.unit == "-" {
                    String::new()
                } else {
                    format!(" {}", p.unit)
                };
                (
                    p.name.clone(),
                    format!(
                        "[tune] {}: {:.6}{unit}, chosen in closed loop in [{}, {}] (start: {}); no interval",
                        outcome.dataset,
                        p.chosen,
                        p.lower,
                        p.upper,
                        p.start.map_or_else(|| "off".to_string(), |v| format!("{v:.6}"))
                    ),
                )
            })
            .collect()
    } else {
        Vec::new()
    };
    twin::twin_files(
        model,
        &twin::Provenance {
            header,
            fitted: Vec::new(),
            before: None,
            chosen,
        },
    )
}
