//! Running and scoring one case of the randomized discovery benchmark
//! (`benches/discovery_benchmark.rs`; one case per family in `tests/long/discovery_families.rs`):
//! the generator's log, the kinematic calibration with discovery, and the case's record
//! against its truth.

use super::random_cases::{Case, Channel, Family};
use crate::common::generator::drive_log_with;
use drive_sim::calibration::{calibrate, CalibrationOptions, CalibrationReport, KinematicFactory};
use drive_sim::terrain::Terrain;
use serde::Serialize;

/// The case's log (`steps` DRIVE steps of the generator) calibrated with the kinematic model
/// and discovery, with `candidates` only (`None`: the whole catalogue).
pub fn calibrate_case(
    case: &Case,
    steps: u32,
    candidates: Option<Vec<String>>,
) -> Result<CalibrationReport, String> {
    let (log, robot) = drive_log_with(&case.name, case.spec(), case.extra, steps);
    let (terrain, _) = Terrain::resolve("asphalt").map_err(|e| e.to_string())?;
    let opts = CalibrationOptions {
        seed: case.seed,
        candidates,
        ..CalibrationOptions::default()
    };
    calibrate(&log, &robot, &terrain, &KinematicFactory, &opts).map_err(|e| e.to_string())
}

/// The fitted value of a parameter of the exact effect against its truth.
#[derive(Debug, Clone, Serialize)]
pub struct ValueCheck {
    pub key: String,
    pub truth: f64,
    pub fitted: Option<f64>,
    pub se: Option<f64>,
    /// Within 10 % of the truth or 3 standard errors (the criterion of tests/long/discovery.rs).
    pub ok: bool,
}

/// One case's result.
#[derive(Debug, Clone, Serialize)]
pub struct Record {
    pub name: String,
    pub family: Family,
    pub seed: u64,
    pub magnitudes: Vec<(String, f64)>,
    /// Where the effect acts.
    pub channels: Vec<String>,
    /// The catalogue effect that explains it exactly.
    pub exact: Option<String>,
    /// Effects of the final model with their parameters (`name(key=value, ...)`).
    pub kept: Vec<String>,
    /// Targets of the discovered terms kept.
    pub term_targets: Vec<String>,
    /// Every equation discovery found (`target: text`).
    pub equations: Vec<String>,
    /// The sparse regression each equation used, in the order of `equations`.
    pub solvers: Vec<String>,
    /// What discovery added, round by round.
    pub added: Vec<String>,
    /// Each discovery round's stage and why it added what it did (or nothing), and the
    /// quantities it skipped with the reason.
    pub discovery_notes: Vec<String>,
    /// Channels flagged on the test steps before (declared model) and after calibration.
    pub flagged_before: Vec<String>,
    pub flagged_after: Vec<String>,
    /// The channel with the largest RMSE / floor over its flag after calibration.
    pub worst_channel: String,
    pub worst_ratio: f64,
    pub worst_threshold: f64,
    /// The channels where the effect acts, each with its RMSE / floor on the test steps after
    /// calibration (every diagnosis channel of those quantities: steady, transient, pose).
    pub effect_channel_ratios: Vec<(String, f64)>,
    pub within_flags: bool,
    pub structure: bool,
    pub values: Vec<ValueCheck>,
    pub seconds: f64,
    pub error: Option<String>,
}

impl Record {
    pub fn failed(case: &Case, seconds: f64, error: String) -> Self {
        Self {
            worst_channel: String::new(),
            worst_ratio: f64::NAN,
            worst_threshold: f64::NAN,
            within_flags: false,
            structure: false,
            seconds,
            error: Some(error),
            ..Self::of_case(case)
        }
    }

    pub fn of_case(case: &Case) -> Self {
        Self {
            name: case.name.clone(),
            family: case.family,
            seed: case.seed,
            magnitudes: case.magnitudes.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            channels: case.truth.channels.iter().map(|c| c.name().to_string()).collect(),
            exact: case.truth.exact.as_ref().map(|e| e.effect.to_string()),
            kept: Vec::new(),
            term_targets: Vec::new(),
            equations: Vec::new(),
            solvers: Vec::new(),
            added: Vec::new(),
            discovery_notes: Vec::new(),
            flagged_before: Vec::new(),
            flagged_after: Vec::new(),
            worst_channel: String::new(),
            worst_ratio: 0.0,
            worst_threshold: 0.0,
            effect_channel_ratios: Vec::new(),
            within_flags: false,
            structure: false,
            values: Vec::new(),
            seconds: 0.0,
            error: None,
        }
    }

    /// A null case's false discovery: any effect kept, or anything discovery added.
    pub fn false_discovery(&self) -> bool {
        !self.kept.is_empty() || !self.added.is_empty()
    }
}

/// The registered effect that owns the report parameter `effect.<key>`.
pub fn owner(key: &str) -> String {
    drive_sim::effects::param_owner(key)
        .map(|(i, _)| drive_sim::effects::REGISTRY[i].name().to_string())
        .unwrap_or_else(|| key.to_string())
}

/// The diagnosis channel `channel` (`steady vx`, `transient enc_left`, `pose rotation`)
/// measures the quantity `t`.
fn measures(t: Channel, channel: &str) -> bool {
    let (kind, quantity) = channel.split_once(' ').unwrap_or(("", channel));
    match t {
        Channel::WheelLeft => quantity == "enc_left",
        Channel::WheelRight => quantity == "enc_right",
        Channel::BodyVx => quantity == "vx",
        Channel::BodyVy => quantity == "vy",
        Channel::BodyWz => quantity == "wz",
        Channel::Imu => quantity == "imu_wz",
        Channel::Pose => kind == "pose",
    }
}

/// Scores `r` against the case's truth.
pub fn score(case: &Case, r: &CalibrationReport, seconds: f64) -> Record {
    let mut rec = Record::of_case(case);
    rec.seconds = seconds;
    // Effects kept, grouped by the effect that owns each parameter (a term has many).
    let mut kept: Vec<(String, Vec<String>)> = Vec::new();
    for p in r.effects.iter().filter(|p| p.name.starts_with("effect.")) {
        let key = p.name.trim_start_matches("effect.");
        let effect = owner(key);
        let short = key.rsplit("__").next().unwrap_or(key);
        let text = format!("{short}={:.4}", p.value);
        match kept.iter_mut().find(|(e, _)| *e == effect) {
            Some((_, v)) => v.push(text),
            None => kept.push((effect, vec![text])),
        }
    }
    let kept_names: Vec<String> = kept.iter().map(|(e, _)| e.clone()).collect();
    rec.kept = kept
        .iter()
        .map(|(e, v)| format!("{e}({})", v.join(", ")))
        .collect();
    rec.term_targets = kept_names
        .iter()
        .filter_map(|e| e.strip_prefix("term_").map(str::to_string))
        .collect();
    let rounds = r.discovery.iter().flat_map(|d| &d.rounds);
    rec.equations = rounds
        .clone()
        .flat_map(|round| &round.equations)
        .map(|e| format!("{}: {}", e.target, e.text))
        .collect();
    rec.solvers = rounds
        .clone()
        .flat_map(|round| &round.equations)
        .map(|e| e.equation.solver.name().to_string())
        .collect();
    rec.added = rounds.clone().filter_map(|round| round.added.clone()).collect();
    rec.discovery_notes = rounds
        .flat_map(|round| {
            std::iter::once(format!("{}: {}", round.stage, round.why)).chain(
                round
                    .skipped
                    .iter()
                    .map(|s| format!("{} skipped: {}", s.target, s.reason)),
            )
        })
        .collect();
    rec.flagged_before = r
        .diagnosis_before
        .iter()
        .flat_map(|d| d.flagged())
        .map(str::to_string)
        .collect();
    if let Some(d) = &r.diagnosis_after {
        rec.flagged_after = d.flagged().into_iter().map(str::to_string).collect();
        rec.within_flags = rec.flagged_after.is_empty();
        if let Some(c) = d
            .channels
            .iter()
            .max_by(|a, b| (a.ratio / a.threshold).total_cmp(&(b.ratio / b.threshold)))
        {
            rec.worst_channel = c.channel.clone();
            rec.worst_ratio = c.ratio;
            rec.worst_threshold = c.threshold;
        }
        rec.effect_channel_ratios = d
            .channels
            .iter()
            .filter(|c| case.truth.channels.iter().any(|&t| measures(t, &c.channel)))
            .map(|c| (c.channel.clone(), c.ratio))
            .collect();
    }
    let truth = &case.truth;
    let targets: Vec<&str> = truth.targets.iter().map(|c| c.name()).collect();
    rec.structure = if truth.expect_nothing {
        kept_names.is_empty() && rec.added.is_empty()
    } else if let Some(exact) = &truth.exact {
        kept_names.iter().any(|e| e == exact.effect)
    } else {
        !rec.term_targets.is_empty() && rec.term_targets.iter().all(|t| targets.contains(&t.as_str()))
    };
    if let Some(exact) = &truth.exact {
        rec.values = exact
            .params
            .iter()
            .map(|(key, truth)| {
                let p = r.effects.iter().find(|p| p.name == format!("effect.{key}"));
                let fitted = p.map(|p| p.value);
                let se = p.and_then(|p| p.se);
                let tol = (0.1 * truth.abs()).max(3.0 * se.unwrap_or(0.0));
                ValueCheck {
                    key: key.to_string(),
                    truth: *truth,
                    fitted,
                    se,
                    ok: fitted.is_some_and(|v| (v - truth).abs() <= tol),
                }
            })
            .collect();
    }
    rec
}
