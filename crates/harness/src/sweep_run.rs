//! What one run of a sweep does (the callback [`crate::sweep::run_sweep`] calls): simulate in
//! memory, analyse, write `run.json` (its key figures) in its directory and return them for the
//! merged table: median slips (signed along the command, the magnitude view), median ρ, the
//! area of T, interruptions, time efficiency, real-time factor.
//!
//! Matrix `[options]` read here: `noise` (`"typical"` default, or `"off"`), `physics_hz`.
//! The protocol is the matrix's (defaults plus its `[protocol]` overrides), not
//! `ProtocolConfig::for_run`: a sweep's runs share one protocol, so the safety operator's
//! braking assumption does not follow the terrain unless the matrix sets it.

use super::simulate::{analysis_params_without_smoother, simulate_into, simulated_meta, unknown_sampler};
use crate::error::{Error, Result};
use crate::sweep::{RunSpec, SweepMatrix};
use drive_sim_analysis::analyze;
use drive_sim_log::mcap::McapWriter;
use drive_sim_model::output::write_json_atomic as write_json;
use drive_sim_model::provenance::{InputFile, Provenance};
use drive_sim_model::robot::{Robot, BUILTIN_ROBOTS};
use drive_sim_model::terrain::{Terrain, BUILTIN_TERRAINS};
use drive_sim_protocol::sampler::make_sampler_for;
use drive_sim_protocol::FrameSink;
use drive_sim_sim::{SensorNoise, SimConfig};
use serde_json::{json, Value};
use std::path::Path;

fn option_err(spec: &RunSpec, field: &str, msg: &str) -> Error {
    Error::config(
        format!("sweep {}", spec.sweep),
        format!("options.{field}"),
        msg.to_string(),
    )
}

/// The keys of a matrix's `[options]` table that a drive-sim sweep run reads; any other key
/// is a typo, refused by [`validate_matrix`] with a "did you mean".
pub const SWEEP_OPTIONS: &[&str] = &["noise", "physics_hz"];

/// The validation pass of a matrix for drive-sim's sweep runs, before any run starts: the
/// steps bound, the `[options]` keys (unknown ones with a "did you mean") and their values.
pub fn validate_matrix(matrix: &SweepMatrix, file: &Path) -> Result<()> {
    let max = super::run::MAX_STEPS;
    if matrix.steps > max {
        return Err(Error::config(
            file,
            "steps",
            format!("must be in 1..={max} steps, got {}", matrix.steps),
        ));
    }
    for key in matrix.options.keys() {
        if !SWEEP_OPTIONS.contains(&key.as_str()) {
            let hint = drive_sim_model::config::did_you_mean(key, SWEEP_OPTIONS.iter().copied())
                .map(|c| format!("did you mean `{c}`? "))
                .unwrap_or_default();
            return Err(Error::config(
                file,
                format!("options.{key}"),
                format!(
                    "unknown option `{key}`; {hint}known options: {}",
                    SWEEP_OPTIONS.join(", ")
                ),
            ));
        }
    }
    if let Some(spec) = matrix.expand().first() {
        let sim = sim_config(spec)?;
        let (lo, hi) = super::run::PHYSICS_HZ_RANGE;
        if !(sim.physics_hz.is_finite() && (lo..=hi).contains(&sim.physics_hz)) {
            return Err(Error::config(
                file,
                "options.physics_hz",
                format!("must be in [{lo}, {hi}] Hz, got {}", sim.physics_hz),
            ));
        }
    }
    Ok(())
}

/// The simulator settings of a run from the matrix's options.
fn sim_config(spec: &RunSpec) -> Result<SimConfig> {
    let noise = match spec.options.get("noise") {
        None => SensorNoise::typical(),
        Some(Value::String(s)) if s == "typical" => SensorNoise::typical(),
        Some(Value::String(s)) if s == "off" => SensorNoise::default(),
        Some(_) => return Err(option_err(spec, "noise", "must be \"typical\" or \"off\"")),
    };
    let physics_hz = match spec.options.get("physics_hz") {
        None => 100.0,
        Some(v) => v
            .as_f64()
            .ok_or_else(|| option_err(spec, "physics_hz", "must be a number (Hz)"))?,
    };
    Ok(SimConfig {
        seed: spec.seed,
        physics_hz,
        noise,
        ..SimConfig::default()
    })
}

/// NaN/absent-safe JSON number.
fn num(x: Option<f64>) -> Value {
    match x {
        Some(v) if v.is_finite() => json!(v),
        _ => Value::Null,
    }
}

/// One sweep run: simulate, analyse, write `run.json` in `dir`, return the key figures.
pub fn sweep_run(spec: &RunSpec, dir: &Path) -> Result<Value> {
    sweep_run_with(spec, dir, false)
}

/// [`sweep_run`], also keeping the run's MCAP log as `<dir>/<id>.mcap` when `keep_log`
/// (streamed as the run goes; the figures then name it under `log`).
pub fn sweep_run_with(spec: &RunSpec, dir: &Path, keep_log: bool) -> Result<Value> {
    let (robot, robot_file) = Robot::resolve(&spec.robot)?;
    let (terrain, terrain_file) = Terrain::resolve(&spec.terrain)?;
    let mut sampler = make_sampler_for(&spec.sampler, spec.seed, &spec.protocol)
        .ok_or_else(|| unknown_sampler(&spec.sampler))?;
    let sim = sim_config(spec)?;
    let log_name = format!("{}.mcap", spec.id);
    let mut writer = if keep_log {
        let meta = simulated_meta(
            spec.id.clone(),
            &robot,
            &terrain,
            &spec.protocol,
            spec.seed,
            &spec.sampler,
        );
        Some(McapWriter::create(dir.join(&log_name), &meta)?)
    } else {
        None
    };
    let run = match simulate_into(
        &robot,
        &terrain,
        sampler.as_mut(),
        &spec.protocol,
        sim,
        writer.as_mut().map(|w| w as &mut dyn FrameSink),
    ) {
        Ok(r) => r,
        // An interrupted run's log is closed readable; the run stays incomplete (no marker)
        // and is redone when the sweep resumes.
        Err(Error::Model(e @ drive_sim_model::Error::Interrupted { .. })) => {
            if let Some(w) = writer {
                w.finish_interrupted()?;
            }
            return Err(e.into());
        }
        Err(e) => return Err(e),
    };
    if let Some(w) = writer {
        w.finish()?;
    }
    let a = analyze(&run.log, &analysis_params_without_smoother())?;
    let st = &a.stats;
    let med = |b: Option<drive_sim_analysis::stats::BoxStats>| num(b.map(|b| b.median));
    let s = &run.summary;
    let figures = json!({
        "median_slip": {
            "vx_m_s": med(st.along_command.vx_m_s),
            "vy_abs_m_s": med(st.along_command.vy_abs_m_s),
            "wz_rad_s": med(st.along_command.wz_rad_s),
            "left_rad_s": med(st.along_command.left_rad_s),
            "right_rad_s": med(st.along_command.right_rad_s),
        },
        "median_rho": med(st.rho),
        "t_area_pct_body": num(Some(a.spaces.t_area_pct_body)),
        "t_area_pct_wheels": num(Some(a.spaces.t_area_pct_wheels)),
        "steps_analysed": a.steps.len(),
        "interruptions": s.interruptions,
        "time_efficiency": num(Some(s.time_efficiency)),
        "simulated_s": num(Some(s.total_time_s)),
        "wall_s": num(Some(run.wall_s)),
        "real_time_factor": num(Some(s.total_time_s / run.wall_s.max(1e-9))),
    });
    let mut figures = figures;
    if keep_log {
        figures["log"] = json!(log_name);
    }
    // Beside run.json rather than in it: run.json's figures are merged into the sweep's
    // table, where a per-process command line would make the shards differ.
    write_json(
        &dir.join("provenance.json"),
        &Provenance::new(
            vec![
                InputFile::of_model("robot", &robot_file, BUILTIN_ROBOTS),
                InputFile::of_model("terrain", &terrain_file, BUILTIN_TERRAINS),
            ],
            serde_json::to_value(spec).unwrap_or(Value::Null),
        ),
    )?;
    write_json(&dir.join("run.json"), &figures)?;
    Ok(figures)
}
