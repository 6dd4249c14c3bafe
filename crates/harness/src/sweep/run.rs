//! Running the specs of a shard: one directory per run, completion markers, rayon.

use super::matrix::{RunSpec, Shard, SweepMatrix};
use crate::error::{Error, Result};
use drive_sim_model::output::write_json_atomic;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Name of the completion marker in a run's directory: written last, atomically, holding the
/// [`RunRecord`].
pub const DONE_FILE: &str = "done.json";

/// Name of the file in the output directory that records the matrix and shard it holds.
pub const MANIFEST_FILE: &str = "sweep.json";

/// What a completed run leaves in its marker: its spec and the figures its callback returned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The run.
    pub spec: RunSpec,
    /// What the run callback returned.
    pub result: serde_json::Value,
}

/// The output directory's manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Manifest {
    pub matrix: SweepMatrix,
    pub shard: Shard,
}

/// How to run a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Output directory; each run writes in `<out_dir>/<id>/`.
    pub out_dir: PathBuf,
    /// The shard this process runs.
    pub shard: Shard,
    /// Worker threads; `None` uses rayon's global pool (all cores).
    pub threads: Option<usize>,
}

/// What happened to one run.
#[derive(Debug, Clone, PartialEq)]
pub enum RunOutcome {
    /// Run now; its result.
    Done(RunRecord),
    /// Found complete from an earlier invocation; not run again.
    Skipped(RunRecord),
    /// The callback failed (or panicked); the run stays incomplete and is redone next time.
    Failed {
        /// Id of the run.
        id: String,
        /// The error.
        message: String,
    },
}

impl RunOutcome {
    /// Id of the run.
    pub fn id(&self) -> &str {
        match self {
            RunOutcome::Done(r) | RunOutcome::Skipped(r) => &r.spec.id,
            RunOutcome::Failed { id, .. } => id,
        }
    }
}

/// The outcomes of the runs of a shard, in spec order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SweepReport {
    /// One per selected spec.
    pub outcomes: Vec<RunOutcome>,
}

impl SweepReport {
    /// Runs done by this invocation.
    pub fn done(&self) -> usize {
        self.count(|o| matches!(o, RunOutcome::Done(_)))
    }
    /// Runs found complete and skipped.
    pub fn skipped(&self) -> usize {
        self.count(|o| matches!(o, RunOutcome::Skipped(_)))
    }
    /// Runs that failed.
    pub fn failed(&self) -> usize {
        self.count(|o| matches!(o, RunOutcome::Failed { .. }))
    }
    fn count(&self, f: impl Fn(&RunOutcome) -> bool) -> usize {
        self.outcomes.iter().filter(|o| f(o)).count()
    }
}

/// Runs the shard `opts.shard` of `matrix` (see [`run_sweep_with_progress`]).
pub fn run_sweep<F>(matrix: &SweepMatrix, opts: &RunOptions, run: F) -> Result<SweepReport>
where
    F: Fn(&RunSpec, &Path) -> Result<serde_json::Value> + Sync,
{
    run_sweep_with_progress(matrix, opts, run, |_| {})
}

/// Runs the shard `opts.shard` of `matrix`: writes the manifest, then [`run_specs`].
/// `progress` is called from the worker threads as each run ends.
pub fn run_sweep_with_progress<F, P>(
    matrix: &SweepMatrix,
    opts: &RunOptions,
    run: F,
    progress: P,
) -> Result<SweepReport>
where
    F: Fn(&RunSpec, &Path) -> Result<serde_json::Value> + Sync,
    P: Fn(&RunOutcome) + Sync,
{
    std::fs::create_dir_all(&opts.out_dir).map_err(|e| Error::io(&opts.out_dir, e))?;
    let manifest_path = opts.out_dir.join(MANIFEST_FILE);
    let manifest = Manifest {
        matrix: matrix.clone(),
        shard: opts.shard,
    };
    if let Ok(text) = std::fs::read_to_string(&manifest_path) {
        // Resuming into a directory of another sweep would mix incompatible runs.
        if let Ok(old) = serde_json::from_str::<Manifest>(&text) {
            if old.matrix.name != matrix.name {
                return Err(Error::config(
                    &manifest_path,
                    "matrix.name",
                    format!(
                        "the directory holds sweep `{}`, not `{}`; use another output directory",
                        old.matrix.name, matrix.name
                    ),
                ));
            }
        }
    }
    write_json_atomic(&manifest_path, &manifest)?;
    let specs = matrix.shard(opts.shard);
    run_specs(&specs, opts, run, progress)
}

/// Runs `specs` in parallel, each in `<out_dir>/<id>/`: a run whose directory holds a
/// completion marker for the same spec is skipped; any other content of its directory (a
/// partial run) is deleted first. The marker is written only when the callback succeeds.
pub fn run_specs<F, P>(specs: &[RunSpec], opts: &RunOptions, run: F, progress: P) -> Result<SweepReport>
where
    F: Fn(&RunSpec, &Path) -> Result<serde_json::Value> + Sync,
    P: Fn(&RunOutcome) + Sync,
{
    let work = || -> Vec<Result<RunOutcome>> {
        specs
            .par_iter()
            .map(|spec| {
                let o = run_one(spec, &opts.out_dir, &run)?;
                progress(&o);
                Ok(o)
            })
            .collect()
    };
    let results = match opts.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| Error::config("--threads", "threads", e.to_string()))?
            .install(work),
        None => work(),
    };
    Ok(SweepReport {
        outcomes: results.into_iter().collect::<Result<Vec<_>>>()?,
    })
}

/// Reads the completion marker of a run directory, if it is there and readable.
pub(crate) fn read_record(dir: &Path) -> Option<RunRecord> {
    let text = std::fs::read_to_string(dir.join(DONE_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

fn run_one<F>(spec: &RunSpec, out_dir: &Path, run: &F) -> Result<RunOutcome>
where
    F: Fn(&RunSpec, &Path) -> Result<serde_json::Value> + Sync,
{
    let dir = out_dir.join(&spec.id);
    if let Some(rec) = read_record(&dir) {
        if &rec.spec == spec {
            return Ok(RunOutcome::Skipped(rec));
        }
    }
    // After SIGINT / SIGTERM no new run starts; the next invocation resumes from here.
    if drive_sim_model::interrupt::requested() {
        return Ok(RunOutcome::Failed {
            id: spec.id.clone(),
            message: "not started: interrupted".into(),
        });
    }
    // Partial output, or a marker for different parameters: start the run afresh.
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    // A panicking simulation must not take the other runs down with it.
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(spec, &dir)));
    let result = match outcome {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            return Ok(RunOutcome::Failed {
                id: spec.id.clone(),
                message: e.to_string(),
            })
        }
        Err(panic) => {
            let message = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panicked".to_string());
            return Ok(RunOutcome::Failed {
                id: spec.id.clone(),
                message: format!("panic: {message}"),
            });
        }
    };
    let rec = RunRecord {
        spec: spec.clone(),
        result,
    };
    // Atomic: a killed sweep leaves either no marker or a whole one.
    write_json_atomic(&dir.join(DONE_FILE), &rec)?;
    Ok(RunOutcome::Done(rec))
}
