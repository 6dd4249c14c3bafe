//! `summary.json` and `transfer_functions.json`: the numbers behind the report, per dataset.

use super::LogSummary;
use crate::error::Result;
use drive_sim_analysis::Analysis;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// `summary.json`: per dataset the rows (one per step and window) and the aggregates.
#[derive(Serialize)]
struct Summary<'a> {
    tool: String,
    datasets: Vec<DatasetSummary<'a>>,
    /// Ratios of median ρ between every pair of datasets (row over column).
    median_rho_ratios: Vec<(String, String, f64)>,
}

#[derive(Serialize)]
struct DatasetSummary<'a> {
    dataset: &'a str,
    robot: &'a str,
    terrain: &'a str,
    origin: &'a drive_sim_log::Origin,
    nominal: &'a drive_sim_log::Nominal,
    steps_analysed: usize,
    steps_excluded: usize,
    interruptions: usize,
    time_efficiency: f64,
    yaw_rate_source: drive_sim_analysis::crosscheck::YawRateSource,
    crosscheck: &'a drive_sim_analysis::crosscheck::CrossCheck,
    stats: &'a drive_sim_analysis::SlipStats,
    median_ci95: &'a drive_sim_analysis::MedianIntervals,
    idd_rmse: &'a drive_sim_model::kinematics::BodyVelocity,
    commands_outside_u: usize,
    /// Steps whose steady windows record another command beside the one they hold (analysed
    /// under the held one).
    steady_command_changes: &'a [drive_sim_analysis::SteadyCommandChange],
    /// The analysed steps' commands by quadrant and the balances' binomial p-values.
    command_mix: drive_sim_analysis::command_mix::CommandMix,
    t_area_pct_body: f64,
    t_area_pct_wheels: f64,
    lateral_speed: &'a drive_sim_analysis::spaces::LateralSpeed,
    max_kinetic_energy: &'a drive_sim_analysis::risk::MaxKineticEnergy,
    risk: &'a [drive_sim_analysis::risk::RiskScenario],
    exclusions: &'a [drive_sim_analysis::segment::Exclusion],
    rows: &'a [drive_sim_analysis::SummaryRow],
    /// Step-to-step against within-step scatter of the steady wheel speeds, computed from the
    /// same analysed steps as `rows`.
    step_scatter: drive_sim_analysis::scatter::StepScatter,
    /// How loaded wheels track by the previous step's turn, from the same analysed steps.
    turn_memory: drive_sim_analysis::turn_memory::TurnMemory,
    /// How often the logged pose changes (`null` with too few changes).
    pose_updates: Option<drive_sim_analysis::pose_updates::PoseUpdates>,
}

impl<'a> DatasetSummary<'a> {
    fn of(log: &LogSummary, a: &'a Analysis) -> Self {
        Self {
            dataset: &a.dataset,
            robot: &a.robot,
            terrain: &a.terrain,
            origin: &a.origin,
            nominal: &a.nominal,
            steps_analysed: a.steps.len(),
            steps_excluded: a.exclusions.len(),
            interruptions: log.interruptions,
            time_efficiency: log.time_efficiency,
            yaw_rate_source: a.yaw_rate_source,
            crosscheck: &a.crosscheck,
            stats: &a.stats,
            median_ci95: &a.median_ci95,
            idd_rmse: &a.idd_rmse,
            commands_outside_u: a.commands_outside_u,
            steady_command_changes: &a.steady_command_changes,
            command_mix: a.command_mix,
            t_area_pct_body: a.spaces.t_area_pct_body,
            t_area_pct_wheels: a.spaces.t_area_pct_wheels,
            lateral_speed: &a.spaces.lateral,
            max_kinetic_energy: &a.max_kinetic_energy,
            risk: &a.risk,
            exclusions: &a.exclusions,
            rows: &a.rows,
            step_scatter: a.step_scatter,
            turn_memory: a.turn_memory,
            pose_updates: a.pose_updates,
        }
    }
}

/// Ratios of median ρ of every ordered pair of distinct datasets (row over column).
fn median_rho_ratios(analyses: &[&Analysis]) -> Vec<(String, String, f64)> {
    let med = |a: &Analysis| a.stats.rho.map_or(f64::NAN, |b| b.median);
    let mut ratios = Vec::new();
    for x in analyses {
        for y in analyses {
            if x.dataset != y.dataset {
                ratios.push((x.dataset.clone(), y.dataset.clone(), med(x) / med(y)));
            }
        }
    }
    ratios
}

/// The two JSON files written.
pub(super) struct JsonFiles {
    /// `summary.json`.
    pub(super) summary: PathBuf,
    /// `transfer_functions.json`.
    pub(super) transfer_functions: PathBuf,
}

/// Writes `summary.json` and `transfer_functions.json` of `items` into `dir`.
pub(super) fn write_json_files(
    items: &[(&LogSummary, &Analysis)],
    analyses: &[&Analysis],
    dir: &Path,
) -> Result<JsonFiles> {
    let summary_path = dir.join("summary.json");
    drive_sim_model::output::write_json_atomic(
        &summary_path,
        &Summary {
            tool: format!("drive-sim {}", env!("CARGO_PKG_VERSION")),
            datasets: items.iter().map(|(log, a)| DatasetSummary::of(log, a)).collect(),
            median_rho_ratios: median_rho_ratios(analyses),
        },
    )?;
    let tf: Vec<_> = analyses.iter().map(|a| (&a.dataset, &a.transfer)).collect();
    let tf_path = dir.join("transfer_functions.json");
    drive_sim_model::output::write_json_atomic(&tf_path, &tf)?;
    Ok(JsonFiles {
        summary: summary_path,
        transfer_functions: tf_path,
    })
}
