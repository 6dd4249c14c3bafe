//! `drive_sim.analyze`, `compare`, `calibrate` and `twin`: the command line's `analyze`,
//! `compare`, `calibrate` and `twin` through the same library functions, into a directory
//! (the Python side passes a temporary one when the caller gives none) whose JSON the Python
//! side reads back, so that the numbers are the command line's.

use crate::errors::{to_py, StageError};
use drive_sim_calibration::{calibrate_logs, CalibrateRequest, Calibrated};
use drive_sim_compare::{CompareOptions, Input, TfSmoother};
use drive_sim_harness::analyze::{analyze_logs, AnalyzeOptions};
use drive_sim_log::{OpenOptions, UseSteps};
use drive_sim_model::provenance::with_command;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Runs `f` without the GIL, naming `command` in the provenance of what it writes; its error
/// as the Python exception.
fn detached<T: Send, E: StageError + Send>(
    py: Python<'_>,
    command: Vec<String>,
    f: impl FnOnce() -> Result<T, E> + Send,
) -> PyResult<T> {
    py.allow_threads(|| with_command(command, f))
        .map_err(|e| to_py(&e))
}

/// A value of a closed set by name, or the command line's message for an invalid one.
fn choose<T: Copy>(option: &str, value: &str, all: &[T], name: impl Fn(T) -> &'static str) -> PyResult<T> {
    all.iter().copied().find(|t| name(*t) == value).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|t| name(*t)).collect();
        PyValueError::new_err(format!(
            "invalid value '{value}' for '{option}' [possible values: {}]",
            names.join(", ")
        ))
    })
}

fn open_options(robot: Option<String>, terrain: Option<String>, roles: Option<String>) -> OpenOptions {
    OpenOptions {
        robot,
        terrain,
        roles,
    }
}

/// `drive-sim analyze LOG... --out DIR`: writes the report into `out`; returns the steady
/// rows (window `None`, not excluded) of each log as `(dataset, rows JSON)`.
#[pyfunction]
#[pyo3(signature = (logs, out, resolution, kernel_variance, keep_pose_contradictions, robot, terrain, roles, command))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of `drive_sim.analyze`, one by one
pub(crate) fn analyze(
    py: Python<'_>,
    logs: Vec<PathBuf>,
    out: PathBuf,
    resolution: f64,
    kernel_variance: Option<f64>,
    keep_pose_contradictions: bool,
    robot: Option<String>,
    terrain: Option<String>,
    roles: Option<String>,
    command: Vec<String>,
) -> PyResult<Vec<(String, String)>> {
    if logs.is_empty() {
        return Err(PyValueError::new_err("no log to analyse"));
    }
    let opts = AnalyzeOptions {
        logs,
        out,
        resolution,
        kernel_variance,
        keep_pose_contradictions,
        input: open_options(robot, terrain, roles),
    };
    let done = detached(py, command, || analyze_logs(&opts, &mut |_| {}))?;
    done.analyses
        .iter()
        .map(|a| {
            let steady: Vec<_> = a
                .rows
                .iter()
                .filter(|r| r.window.is_none() && r.excluded.is_none())
                .collect();
            let json = serde_json::to_string(&steady)
                .map_err(|e| to_py(&drive_sim_model::Error::json("<rows>", e)))?;
            Ok((a.dataset.clone(), json))
        })
        .collect()
}

/// `drive-sim compare REAL SIM... --out DIR`: writes the comparison into `out`; returns
/// `comparison.json`'s text.
#[pyfunction]
#[pyo3(signature = (real, sims, out, resamples, seed, alpha, permutations, tf_smoother, yardstick_splits, real_steps, robot, terrain, roles, command))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of `drive_sim.compare`, one by one
pub(crate) fn compare(
    py: Python<'_>,
    real: PathBuf,
    sims: Vec<PathBuf>,
    out: PathBuf,
    resamples: Option<usize>,
    seed: Option<u64>,
    alpha: f64,
    permutations: Option<usize>,
    tf_smoother: &str,
    yardstick_splits: Option<usize>,
    real_steps: &str,
    robot: Option<String>,
    terrain: Option<String>,
    roles: Option<String>,
    command: Vec<String>,
) -> PyResult<String> {
    if sims.is_empty() {
        return Err(PyValueError::new_err("no simulated log to compare with"));
    }
    let defaults = CompareOptions::default();
    let opts = CompareOptions {
        bootstrap: drive_sim_analysis::bootstrap::Bootstrap {
            resamples: resamples.unwrap_or(defaults.bootstrap.resamples),
            seed: seed.unwrap_or(defaults.bootstrap.seed),
            ..defaults.bootstrap
        },
        alpha,
        tf_permutations: permutations.unwrap_or(defaults.tf_permutations),
        tf_smoother: choose("--tf-smoother", tf_smoother, &TfSmoother::ALL, TfSmoother::as_str)?,
        tf_yardstick_splits: yardstick_splits.unwrap_or(drive_sim_compare::DEFAULT_YARDSTICK_SPLITS),
        ..defaults
    };
    let real_steps = choose("--real-steps", real_steps, &UseSteps::ALL, UseSteps::as_str)?;
    let input = open_options(robot, terrain, roles);
    detached(py, command, || -> drive_sim_compare::Result<String> {
        opts.validate()?;
        let real_log = real_steps.select(&drive_sim_log::open(&real, &input)?.log);
        let sim_logs = sims
            .iter()
            .map(|p| Ok(drive_sim_log::open(p, &input)?.log))
            .collect::<drive_sim_compare::Result<Vec<_>>>()?;
        let inputs: Vec<Input> = sim_logs
            .iter()
            .zip(&sims)
            .map(|(log, f)| Input {
                log,
                file: Some(f.as_path()),
            })
            .collect();
        let report = drive_sim_compare::compare(
            Input {
                log: &real_log,
                file: Some(real.as_path()),
            },
            &inputs,
            &opts,
        )?;
        drive_sim_compare::write::write_comparison(
            &report,
            &real_log.meta.nominal.command_space().polygon_body(),
            &out,
        )?;
        serde_json::to_string(&report)
            .map_err(|e| drive_sim_compare::Error::json(out.join("comparison.json"), e))
    })
}

/// `drive-sim calibrate LOG... --out DIR`: writes the calibration into `out`; returns the
/// files written.
#[pyfunction]
#[pyo3(signature = (logs, out, model, optimizer, seed, max_effects, max_fit_steps, candidates, use_steps, discover, robot, terrain, roles, command))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of `drive_sim.calibrate`, one by one
pub(crate) fn calibrate(
    py: Python<'_>,
    logs: Vec<PathBuf>,
    out: PathBuf,
    model: String,
    optimizer: String,
    seed: u64,
    max_effects: Option<usize>,
    max_fit_steps: Option<usize>,
    candidates: Option<Vec<String>>,
    use_steps: &str,
    discover: bool,
    robot: Option<String>,
    terrain: Option<String>,
    roles: Option<String>,
    command: Vec<String>,
) -> PyResult<Vec<PathBuf>> {
    let req = CalibrateRequest {
        logs,
        out,
        input: open_options(robot, terrain, roles),
        model,
        optimizer,
        seed,
        max_effects: max_effects.unwrap_or(drive_sim_calibration::CalibrationOptions::default().max_effects),
        max_fit_steps,
        candidates,
        use_steps: choose("--use-steps", use_steps, &UseSteps::ALL, UseSteps::as_str)?,
        discover,
    };
    let done = detached(py, command, || calibrate_logs(&req, &|_| {}))?;
    Ok(match done {
        Calibrated::Single(o) => o.files.clone(),
        Calibrated::Joint(o) => o.files.clone(),
    })
}

/// `drive-sim twin LOG... --out DIR`: makes the twin into `out`; returns `twin.json`'s text.
#[pyfunction]
#[pyo3(signature = (logs, out, seed, budget, leave_one_out, judge_sims, judge_references, knobs, robot, terrain, roles, command))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of `drive_sim.twin`, one by one
pub(crate) fn twin(
    py: Python<'_>,
    logs: Vec<PathBuf>,
    out: PathBuf,
    seed: u64,
    budget: f64,
    leave_one_out: bool,
    judge_sims: Option<u32>,
    judge_references: Option<u32>,
    knobs: Option<Vec<String>>,
    robot: Option<String>,
    terrain: Option<String>,
    roles: Option<String>,
    command: Vec<String>,
) -> PyResult<String> {
    let defaults = drive_sim_twin::TwinOptions::default();
    let req = drive_sim_twin::TwinRequest {
        logs,
        out,
        input: open_options(robot, terrain, roles),
        options: drive_sim_twin::TwinOptions {
            seed,
            budget,
            leave_one_out,
            judge_sims: judge_sims.unwrap_or(defaults.judge_sims),
            judge_references: judge_references.unwrap_or(defaults.judge_references),
        },
        knobs,
    };
    detached(py, command, || -> drive_sim_twin::Result<String> {
        let made = drive_sim_twin::make_twin(&req, &|_| {})?;
        serde_json::to_string(&made.report)
            .map_err(|e| drive_sim_twin::Error::json(req.out.join("twin.json"), e))
    })
}
