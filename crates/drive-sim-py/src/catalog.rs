//! `drive_sim.robots()`, `terrains()`, `samplers()`: what a run can name, as the command
//! line's `robots`, `terrains` and `samplers --list` show it.

use drive_sim_model::config::{catalog, parse_toml};
use drive_sim_model::robot::{Robot, BUILTIN_ROBOTS};
use drive_sim_model::terrain::{Terrain, BUILTIN_TERRAINS};
use pyo3::prelude::*;

/// Each robot a run can name (built-in, `./robots/`, `$DRIVE_SIM_DATA/robots/`) as JSON: its
/// name, file and, when the file is valid, its parameters (else `error`).
#[pyfunction]
pub(crate) fn robots() -> Vec<String> {
    catalog("robot", BUILTIN_ROBOTS)
        .into_iter()
        .map(|e| {
            let parsed =
                parse_toml::<Robot>(&e.text, &e.origin).map(|r| serde_json::to_value(r).unwrap_or_default());
            entry(&e.name, &e.origin, parsed)
        })
        .collect()
}

/// Each terrain a run can name, as [`robots`] does robots.
#[pyfunction]
pub(crate) fn terrains() -> Vec<String> {
    catalog("terrain", BUILTIN_TERRAINS)
        .into_iter()
        .map(|e| {
            let parsed = parse_toml::<Terrain>(&e.text, &e.origin)
                .map(|t| serde_json::to_value(t).unwrap_or_default());
            entry(&e.name, &e.origin, parsed)
        })
        .collect()
}

fn entry(name: &str, origin: &std::path::Path, parsed: drive_sim_model::Result<serde_json::Value>) -> String {
    let mut v = serde_json::json!({ "name": name, "source": origin.display().to_string() });
    match parsed {
        Ok(p) => v["parameters"] = p,
        Err(e) => v["error"] = e.to_string().into(),
    }
    v.to_string()
}

/// The built-in samplers: `(name, one-line description)`, in registry order.
#[pyfunction]
pub(crate) fn samplers() -> Vec<(&'static str, &'static str)> {
    drive_sim_protocol::samplers::REGISTRY
        .iter()
        .map(|e| (e.name, e.summary))
        .collect()
}
