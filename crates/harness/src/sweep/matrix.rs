//! The sweep matrix file and its expansion into run specifications.

use crate::error::{Error, Result};
use drive_sim_model::config::{parse_toml, positive, Validate};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use drive_sim_protocol::sampler::SAMPLERS;
use drive_sim_protocol::ProtocolConfig;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::Path;
use std::str::FromStr;

/// A sweep: every combination of robot, terrain, sampler and seed, with common run options.
///
/// ```toml
/// name = "example"
/// robots = ["warthog", "husky"]
/// terrains = ["asphalt", "ice"]
/// samplers = ["uniform-wheel", "boundary-aware"]
/// seeds = [1, 2, 3]
/// steps = 150
/// [protocol]           # optional overrides of the protocol defaults
/// border_margin_m = 0.5
/// [options]            # free-form, passed to every run as JSON
/// dt_s = 0.002
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepMatrix {
    /// Name of the sweep (letters, digits, `-`, `_`, `.`).
    pub name: String,
    /// Robots by name or path to a robot file.
    pub robots: Vec<String>,
    /// Terrains by name or path to a terrain file.
    pub terrains: Vec<String>,
    /// Sampler names (see `protocol::sampler::SAMPLERS`).
    pub samplers: Vec<String>,
    /// Seeds; each combination runs once per seed.
    pub seeds: Vec<u64>,
    /// Protocol steps per run.
    pub steps: u32,
    /// Overrides of the protocol defaults, for every run.
    #[serde(default)]
    pub protocol: ProtocolOverrides,
    /// Free-form options forwarded to every run (e.g. simulator settings).
    #[serde(default)]
    pub options: serde_json::Map<String, serde_json::Value>,
}

/// Optional overrides of [`ProtocolConfig`] fields (all but `steps`, which the matrix sets).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolOverrides {
    /// Logging rate, Hz.
    pub rate_hz: Option<f64>,
    /// Window duration, s.
    pub window_s: Option<f64>,
    /// Windows per step.
    pub windows_per_step: Option<u32>,
    /// Standing time before the first step, s.
    pub settle_s: Option<f64>,
    /// Deceleration the safety operator assumes, m/s².
    pub operator_decel_m_s2: Option<f64>,
    /// Margin to the border of the safe area, m.
    pub border_margin_m: Option<f64>,
    /// Attempts of one command before another is drawn.
    pub max_attempts: Option<u32>,
    /// Longest a re-orientation may take, s.
    pub max_reorient_s: Option<f64>,
}

impl ProtocolOverrides {
    /// The protocol defaults with these overrides and `steps` applied.
    pub fn apply(&self, steps: u32) -> ProtocolConfig {
        let d = ProtocolConfig::default();
        ProtocolConfig {
            steps,
            rate_hz: self.rate_hz.unwrap_or(d.rate_hz),
            window_s: self.window_s.unwrap_or(d.window_s),
            windows_per_step: self.windows_per_step.unwrap_or(d.windows_per_step),
            settle_s: self.settle_s.unwrap_or(d.settle_s),
            operator_decel_m_s2: self.operator_decel_m_s2.unwrap_or(d.operator_decel_m_s2),
            border_margin_m: self.border_margin_m.unwrap_or(d.border_margin_m),
            max_attempts: self.max_attempts.unwrap_or(d.max_attempts),
            max_reorient_s: self.max_reorient_s.unwrap_or(d.max_reorient_s),
            ..d
        }
    }
}

/// One run of a sweep: everything the run callback needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Position in the full expansion of the matrix (robots, then terrains, samplers, seeds).
    pub index: usize,
    /// Stable id, `<robot>-<terrain>-<sampler>-s<seed>`; also the run's directory name.
    pub id: String,
    /// Name of the sweep.
    pub sweep: String,
    /// Robot name or path, as in the matrix.
    pub robot: String,
    /// Terrain name or path, as in the matrix.
    pub terrain: String,
    /// Sampler name.
    pub sampler: String,
    /// Seed of the run.
    pub seed: u64,
    /// Protocol parameters of the run.
    pub protocol: ProtocolConfig,
    /// The matrix's free-form options.
    pub options: serde_json::Map<String, serde_json::Value>,
}

/// The part of a sweep one process runs: the specs whose index mod `count` is `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This shard, 0-based, below `count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Default for Shard {
    fn default() -> Self {
        Self { index: 0, count: 1 }
    }
}

impl Shard {
    /// A shard, checked.
    pub fn new(index: usize, count: usize) -> Result<Self> {
        if count == 0 {
            return Err(shard_error("the shard count must be at least 1"));
        }
        if index >= count {
            return Err(shard_error(format!(
                "shard index {index} must be below the count {count} (shards are 0-based)"
            )));
        }
        Ok(Self { index, count })
    }
    /// True if the spec at `spec_index` belongs to this shard.
    pub fn selects(&self, spec_index: usize) -> bool {
        spec_index % self.count == self.index
    }
}

fn shard_error(message: impl Into<String>) -> Error {
    Error::config("--shard", "i/n", message)
}

impl FromStr for Shard {
    type Err = Error;
    /// Parses `i/n`, e.g. `0/4` for the first of four shards.
    fn from_str(s: &str) -> Result<Self> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| shard_error(format!("expected `i/n` (e.g. 0/4), got `{s}`")))?;
        let parse = |x: &str, what: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| shard_error(format!("{what} `{x}` in `{s}` is not a non-negative integer")))
        };
        Shard::new(parse(i, "index")?, parse(n, "count")?)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The id component for a robot or terrain: the file stem of a path, with characters other
/// than letters, digits, `_` and `.` replaced by `_` (`-` separates the id's parts).
fn slug(name: &str) -> String {
    let stem = if name.ends_with(".toml") || Path::new(name).components().count() > 1 {
        Path::new(name)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or(name)
    } else {
        name
    };
    stem.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn check_list<T: Ord + std::fmt::Display>(
    field: &str,
    items: &[T],
) -> std::result::Result<(), (String, String)> {
    if items.is_empty() {
        return Err((field.into(), "must list at least one entry".into()));
    }
    let mut seen = BTreeSet::new();
    for (i, x) in items.iter().enumerate() {
        if !seen.insert(x) {
            return Err((format!("{field}[{i}]"), format!("`{x}` is listed twice")));
        }
    }
    Ok(())
}

impl Validate for SweepMatrix {
    fn validate(&self) -> std::result::Result<(), (String, String)> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        {
            return Err((
                "name".into(),
                format!(
                    "`{}` must be non-empty letters, digits, `-`, `_` or `.`",
                    self.name
                ),
            ));
        }
        check_list("robots", &self.robots)?;
        check_list("terrains", &self.terrains)?;
        check_list("samplers", &self.samplers)?;
        check_list("seeds", &self.seeds)?;
        for (i, s) in self.samplers.iter().enumerate() {
            if !SAMPLERS.contains(&s.as_str()) {
                return Err((
                    format!("samplers[{i}]"),
                    format!("unknown sampler `{s}`; available: {}", SAMPLERS.join(", ")),
                ));
            }
        }
        // Two robots (or terrains) whose ids coincide would share run directories.
        for (field, list) in [("robots", &self.robots), ("terrains", &self.terrains)] {
            let mut seen = BTreeSet::new();
            for (i, x) in list.iter().enumerate() {
                if !seen.insert(slug(x)) {
                    return Err((
                        format!("{field}[{i}]"),
                        format!("`{x}` gives the same run id part `{}` as another entry", slug(x)),
                    ));
                }
            }
        }
        if self.steps == 0 {
            return Err(("steps".into(), "must be at least 1".into()));
        }
        let p = &self.protocol;
        for (field, v) in [
            ("protocol.rate_hz", p.rate_hz),
            ("protocol.window_s", p.window_s),
            ("protocol.operator_decel_m_s2", p.operator_decel_m_s2),
            ("protocol.max_reorient_s", p.max_reorient_s),
        ] {
            if let Some(v) = v {
                positive(field, v)?;
            }
        }
        for (field, v) in [
            ("protocol.settle_s", p.settle_s),
            ("protocol.border_margin_m", p.border_margin_m),
        ] {
            if let Some(v) = v {
                drive_sim_model::config::non_negative(field, v)?;
            }
        }
        for (field, v) in [
            ("protocol.windows_per_step", p.windows_per_step),
            ("protocol.max_attempts", p.max_attempts),
        ] {
            if v == Some(0) {
                return Err((field.into(), "must be at least 1".into()));
            }
        }
        if p.windows_per_step == Some(1) {
            return Err((
                "protocol.windows_per_step".into(),
                "must be at least 2 (one transient window, then steady ones)".into(),
            ));
        }
        Ok(())
    }
}

impl SweepMatrix {
    /// Parses and validates matrix text; errors name `file` and the field. Robot and terrain
    /// names are not resolved (see [`SweepMatrix::load`]).
    pub fn parse(text: &str, file: &Path) -> Result<Self> {
        Ok(parse_toml(text, file)?)
    }

    /// Reads a matrix file, validates it, and checks that every robot and terrain resolves
    /// (by name in the catalogs, or as a file).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let m = Self::parse(&text, path)?;
        m.check_names(path)?;
        Ok(m)
    }

    /// Resolves every robot and terrain; an error names the entry, e.g. `robots[1]`.
    pub fn check_names(&self, file: &Path) -> Result<()> {
        for (i, r) in self.robots.iter().enumerate() {
            Robot::resolve(r).map_err(|e| Error::config(file, format!("robots[{i}]"), e.to_string()))?;
        }
        for (i, t) in self.terrains.iter().enumerate() {
            Terrain::resolve(t).map_err(|e| Error::config(file, format!("terrains[{i}]"), e.to_string()))?;
        }
        Ok(())
    }

    /// Number of runs: robots × terrains × samplers × seeds.
    pub fn len(&self) -> usize {
        self.robots.len() * self.terrains.len() * self.samplers.len() * self.seeds.len()
    }

    /// True if the matrix holds no run (never, once validated).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every run, in a fixed order: robots, then terrains, samplers and seeds (seeds vary
    /// fastest). The order and ids depend only on the matrix.
    pub fn expand(&self) -> Vec<RunSpec> {
        let protocol = self.protocol.apply(self.steps);
        let mut specs = Vec::with_capacity(self.len());
        for robot in &self.robots {
            for terrain in &self.terrains {
                for sampler in &self.samplers {
                    for &seed in &self.seeds {
                        specs.push(RunSpec {
                            index: specs.len(),
                            id: format!("{}-{}-{}-s{}", slug(robot), slug(terrain), sampler, seed),
                            sweep: self.name.clone(),
                            robot: robot.clone(),
                            terrain: terrain.clone(),
                            sampler: sampler.clone(),
                            seed,
                            protocol: protocol.clone(),
                            options: self.options.clone(),
                        });
                    }
                }
            }
        }
        specs
    }

    /// The specs of one shard.
    pub fn shard(&self, shard: Shard) -> Vec<RunSpec> {
        self.expand()
            .into_iter()
            .filter(|s| shard.selects(s.index))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slug_of_names_and_paths() {
        assert_eq!(slug("warthog"), "warthog");
        assert_eq!(slug("robots/my robot.toml"), "my_robot");
        assert_eq!(slug("ice-2"), "ice_2");
    }
}
