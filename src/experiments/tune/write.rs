//! A tuning's files: `tune.json`, the twin (`twin/robot.toml`, `twin/terrain.toml`) and, when
//! it was judged on held-out steps, the first judging seed's comparison (`heldout/`: its
//! `comparison.json`, figures and `report.html`, the start model as simulated log 0 and the
//! chosen one as 1); when it was chosen on every step, the same on those steps
//! (`same_steps/`, not held out).

use super::TuneOutcome;
use crate::calibration::twin::{self, TwinFiles};
use crate::compare::write::write_comparison;
use crate::error::Result;
use crate::provenance::Provenance;
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
    crate::output::write_json_atomic(&json, outcome)?;
    crate::provenance::stamp_json_file(&json, provenance)?;
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
