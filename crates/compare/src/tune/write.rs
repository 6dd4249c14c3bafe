//! A tuning's files: `tune.json`, the twin (`twin/robot.toml`, `twin/terrain.toml`) and, when
//! it was judged on held-out steps, the first judging seed's comparison (`heldout/`: its
//! `comparison.json`, figures and `report.html`, the start model as simulated log 0 and the
//! chosen one as 1); when it was chosen on every step, the same on those steps
//! (`same_steps/`, not held out). And the table `drive-sim tune` prints ([`table`]).

use super::{HeldOut, JudgedRun, TuneOutcome};
use crate::error::Error;
use crate::error::Result;
use crate::write::write_comparison;
use drive_sim_calibration::twin::{self, TwinFiles};
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
    let model = outcome.model.as_ref().ok_or(Error::TuningWithoutModel)?;
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
    Ok(twin::twin_files(
        model,
        &twin::Provenance {
            header,
            fitted: Vec::new(),
            before: None,
            chosen,
        },
    )?)
}

/// The table `drive-sim tune` prints: each parameter's start and choice, the search's and the
/// check's outcome, each judgement's runs with their verdicts, and the notes.
pub fn table(o: &TuneOutcome) -> String {
    let mut s = params_table(o);
    s.push_str(&format!(
        "loss on the {} {} steps, seeds {:?}: start {} -> chosen {:.3} ({} points, {})\n",
        o.real_steps_chosen_on,
        o.options.choose_on.as_str(),
        o.choose_seeds,
        o.start_loss
            .map_or_else(|| "failed".into(), |l| format!("{l:.3}")),
        o.chosen_loss,
        o.search.evaluations,
        o.search.stop
    ));
    s.push_str(&format!(
        "check on fresh seeds {:?}: reduction {:.3} ± {:.3} (SE) -> {}\n",
        o.check.seeds,
        o.check.mean_reduction,
        o.check.se,
        if o.accepted {
            "accepted: the twin is the chosen model"
        } else {
            "not accepted: the twin is the start"
        }
    ));
    for (h, held_out) in [(&o.heldout, true), (&o.same_steps, false)] {
        if let Some(h) = h {
            s.push_str(&judgement_table(h, held_out));
        }
    }
    if o.heldout.is_some() {
        s.push_str(&format!(
            "(halves: the real run's {} steps against its {} steps, as a model matching the first exactly would be judged)\n",
            o.options.choose_on.as_str(),
            o.options.choose_on.other_half().map_or("", |h| h.as_str())
        ));
    }
    for n in &o.notes {
        s.push_str(&format!("note: {n}\n"));
    }
    s
}

/// One row per tuned parameter: its start, its choice and its box.
fn params_table(o: &TuneOutcome) -> String {
    let mut s = format!("{:<36} {:>12} {:>12}   box\n", "parameter", "start", "chosen");
    for p in &o.params {
        s.push_str(&format!(
            "{:<36} {:>12} {:>12.4}   [{}, {}] {}{}\n",
            p.name,
            p.start.map_or_else(|| "off".into(), |v| format!("{v:.4}")),
            p.chosen,
            p.lower,
            p.upper,
            p.unit,
            if p.at_bound { " (at its bound)" } else { "" }
        ));
    }
    s
}

/// A judgement's runs, one row each (the start's, the chosen model's, then the real halves'),
/// under a line that says which steps judged them.
fn judgement_table(h: &HeldOut, held_out: bool) -> String {
    let mut s = format!(
        "judged on the {} {} steps ({}), one run per fresh seed:\n",
        h.real_steps,
        h.steps.as_str(),
        if held_out {
            "never used above"
        } else {
            "the steps it was chosen on: not held out"
        }
    );
    s.push_str(&format!("{:<8} {:>6} {:>10}  verdict\n", "model", "seed", "loss"));
    let halves: &[JudgedRun] = match &h.real_halves {
        Some(r) => std::slice::from_ref(r),
        None => &[],
    };
    for (label, runs) in [
        ("start", &h.start[..]),
        ("chosen", &h.chosen[..]),
        ("halves", halves),
    ] {
        for r in runs {
            s.push_str(&format!(
                "{label:<8} {:>6} {:>10}  {}\n",
                if label == "halves" {
                    "-".to_string()
                } else {
                    r.seed.to_string()
                },
                r.loss
                    .as_ref()
                    .map_or_else(|| "-".into(), |l| format!("{:.3}", l.total)),
                verdict_words(r)
            ));
        }
    }
    s
}

/// A judged run's verdict in words: "reproduces" or what differs, with the maps the
/// permutation test tells apart; why the run failed; or "-".
fn verdict_words(r: &JudgedRun) -> String {
    match (&r.verdict, &r.error) {
        (Some(v), _) => {
            let word = if v.reproduces {
                "reproduces".to_string()
            } else {
                format!(
                    "differs: {}",
                    [
                        v.significant.clone(),
                        v.areas_beyond_tolerance
                            .iter()
                            .map(|a| format!("{a} > 5 pp"))
                            .collect(),
                        v.tf_beyond_yardstick.clone(),
                    ]
                    .concat()
                    .join(", ")
                )
            };
            if v.tf_significant.is_empty() {
                word
            } else {
                format!(
                    "{word} (maps differing by the permutation test: {})",
                    v.tf_significant.join(", ")
                )
            }
        }
        (None, Some(e)) => format!("run failed: {e}"),
        (None, None) => "-".into(),
    }
}
