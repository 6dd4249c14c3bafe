//! `drive_sim.run`: one DRIVE run on the simulator, as `drive-sim run` does it
//! ([`record_run_with`]), with a built-in or a Python sampler, logged to MCAP or kept in memory.

use crate::errors::{to_py, SignalWatch};
use crate::sampler::{Collector, PySampler, RowTuple, SharedRows};
use drive_sim_harness::run::{record_run_with, RunEvent, RunHooks, RunRequest, MAX_STEPS};
use drive_sim_model::effects::Effects;
use drive_sim_model::provenance::with_command;
use drive_sim_protocol::sampler::Sampler;
use drive_sim_protocol::CancelToken;
use drive_sim_sim::{SensorNoise, SimConfig};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;

/// What `run` returns to the Python side: the `run.json` text, the log's path (`None` when
/// nothing was written) and the completed steps' rows.
type RunResult = (String, Option<PathBuf>, Vec<RowTuple>);

/// What the run left, once it has stopped (built with the GIL released, so `Send`).
struct Outcome {
    /// The report as JSON, or the error.
    result: Result<String, drive_sim_harness::Error>,
    /// An exception raised in the sampler or by a signal handler.
    raised: Option<PyErr>,
    /// The partial log a failed run left.
    partial: Option<PathBuf>,
    rows: Vec<RowTuple>,
}

/// Runs DRIVE (see `drive_sim.run` for the arguments); `adapter` is the Python sampler's
/// callable, `sampler` then only its label. `command` is recorded as the provenance's command.
#[pyfunction]
#[pyo3(signature = (robot, terrain, steps, seed, sampler, adapter, out, name, force, noise, physics_hz, safe_area, inject, command, draw_like=None))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of `drive_sim.run`, one by one
pub(crate) fn run(
    py: Python<'_>,
    robot: String,
    terrain: String,
    steps: i64,
    seed: u64,
    sampler: String,
    adapter: Option<Py<PyAny>>,
    out: Option<PathBuf>,
    name: Option<String>,
    force: bool,
    noise: String,
    physics_hz: f64,
    safe_area: Option<(f64, f64)>,
    inject: Vec<String>,
    command: Vec<String>,
    draw_like: Option<PathBuf>,
) -> PyResult<RunResult> {
    let steps = u32::try_from(steps).map_err(|_| {
        PyValueError::new_err(format!(
            "<command line>: field `--steps`: must be in 1..={MAX_STEPS} steps, got {steps}"
        ))
    })?;
    let noise = match noise.as_str() {
        "typical" => SensorNoise::typical(),
        "off" => SensorNoise::default(),
        n => {
            return Err(PyValueError::new_err(format!(
                "invalid value '{n}' for '--noise <NOISE>' [possible values: typical, off]"
            )))
        }
    };
    let mut effects = Effects::default();
    for a in &inject {
        effects.apply_assignment(a).map_err(|e| to_py(&e))?;
    }
    let cancel = CancelToken::new();
    let in_memory = out.is_none();
    let req = RunRequest {
        robot,
        terrain,
        steps,
        sampler,
        sim: SimConfig {
            seed,
            physics_hz,
            noise,
            effects,
        },
        injected: inject,
        out: out.unwrap_or_default(),
        name,
        force,
        safe_area: safe_area
            .map(|(length_m, width_m)| drive_sim_model::robot::SafeArea { length_m, width_m }),
        cancel: Some(cancel.clone()),
        draw_like,
    };
    let outcome = py.allow_threads(move || execute(&req, adapter, cancel, in_memory, command));
    finish(py, outcome)
}

/// The run itself, without the GIL (a Python sampler takes it for each draw).
fn execute(
    req: &RunRequest,
    adapter: Option<Py<PyAny>>,
    cancel: CancelToken,
    in_memory: bool,
    command: Vec<String>,
) -> Outcome {
    let rows = SharedRows::default();
    let mut watch = SignalWatch::new(cancel);
    let mut py_sampler = adapter.map(|a| PySampler::new(a, req.sampler.clone(), rows.clone()));
    let mut partial = None;
    let result = {
        let mut collector = Collector::new(rows.clone(), &mut watch);
        let hooks = RunHooks {
            sampler: py_sampler.as_mut().map(|s| s as &mut dyn Sampler),
            also: Some(&mut collector),
            in_memory,
        };
        let mut progress = |e: RunEvent| {
            if let RunEvent::Failed { partial: p } = e {
                partial = Some(p.to_path_buf());
            }
        };
        with_command(command, || record_run_with(req, hooks, &mut progress))
    };
    let raised = py_sampler
        .and_then(|mut s| s.raised.take())
        .or(watch.raised.take());
    let rows = rows.borrow().iter().map(|r| r.tuple()).collect();
    Outcome {
        result: result.and_then(|(report, _)| {
            serde_json::to_string(&report)
                .map_err(|e| drive_sim_harness::Error::Model(drive_sim_model::Error::json("<run report>", e)))
        }),
        raised,
        partial,
        rows,
    }
}

/// The Python result of a run, or its exception: a sampler's own exception is the cause of
/// the `ValueError` naming the step; a Ctrl-C is the `KeyboardInterrupt` itself.
fn finish(py: Python<'_>, outcome: Outcome) -> PyResult<RunResult> {
    let e = match outcome.result {
        Ok(json) => {
            let log = serde_json::from_str::<serde_json::Value>(&json)
                .ok()
                .and_then(|v| v.get("mcap").and_then(|m| m.as_str()).map(PathBuf::from))
                .filter(|p| !p.as_os_str().is_empty());
            return Ok((json, log, outcome.rows));
        }
        Err(e) => e,
    };
    let sampler_failed = matches!(e.model(), Some(drive_sim_model::Error::Sampler { .. }));
    if sampler_failed {
        // The user's sampler failed: what was simulated has no use, and no log is left.
        if let Some(p) = &outcome.partial {
            let _ = std::fs::remove_file(p);
        }
    }
    match outcome.raised {
        Some(raised) if raised.is_instance_of::<PyKeyboardInterrupt>(py) => Err(raised),
        Some(raised) if sampler_failed => {
            let err = to_py(&e);
            err.set_cause(py, Some(raised));
            Err(err)
        }
        _ => Err(to_py(&e)),
    }
}
