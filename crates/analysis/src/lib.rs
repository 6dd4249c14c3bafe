//! The slip and unpredictability pipeline.
//!
//! [`analyze`] takes any [`DriveLog`] (simulated or measured: it cannot tell) and returns an
//! [`Analysis`]: segmentation with explicit exclusions ([`segment`]), realized velocities
//! ([`velocity`]), the sensor cross-check that picks the yaw-rate source ([`crosscheck`]), slips
//! in both frames ([`slip`]), ρ ([`rho`]), the spaces U/S/T ([`spaces`]), the kernel-smoothed
//! transfer functions ([`smoother`]), the risk scenarios ([`risk`]) and the box-plot statistics
//! ([`stats`]). Every result type is serde-serializable; NaN values serialize as `null`.
//!
//! ```no_run
//! use drive_sim_analysis::{analyze, AnalysisParams};
//!
//! // The same pipeline on a measured log and on a simulated one.
//! let log = drive_sim_log::read_log(std::path::Path::new("warthog_gravel.csv"))?;
//! let analysis = analyze(&log, &AnalysisParams::default())?;
//! if let Some(rho) = &analysis.stats.rho {
//!     println!("median ρ {:.3} over {} steps", rho.median, rho.n);
//! }
//! # Ok::<(), drive_sim_analysis::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod error;
pub use error::{Error, Result};

pub mod bootstrap;
pub mod command_mix;
pub mod crosscheck;
mod pipeline;
pub mod pose_updates;
pub mod rho;
pub mod risk;
pub mod scatter;
pub mod segment;
pub mod slip;
pub mod smoother;
pub mod spaces;
pub mod stats;
pub mod turn_memory;
pub mod velocity;

use crosscheck::{CrossCheck, CrossCheckParams, YawRateSource};
use drive_sim_log::{DriveLog, Nominal, Origin};
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};
use rho::{MassProperties, Rho};
use risk::{MaxKineticEnergy, RiskScenario};
use segment::Exclusion;
use serde::{Deserialize, Serialize};
use slip::SlipRecord;
use smoother::{FastParams, KernelCovariance, TransferFunctions};
use spaces::Spaces;
use stats::BoxStats;

/// Bootstrap-by-step 95 % intervals ([`bootstrap`]) of every median `analyze` prints and
/// writes: steady slips (signed, and signed along the command as printed), ρ.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MedianIntervals {
    /// How the intervals were drawn.
    pub bootstrap: bootstrap::Bootstrap,
    /// Median steady ρ.
    pub rho: Option<bootstrap::Interval>,
    /// Median steady longitudinal slip, m/s.
    pub vx_m_s: Option<bootstrap::Interval>,
    /// Median steady lateral slip, m/s.
    pub vy_m_s: Option<bootstrap::Interval>,
    /// Median steady angular slip, rad/s.
    pub wz_rad_s: Option<bootstrap::Interval>,
    /// Median steady left-wheel slip, rad/s.
    pub left_rad_s: Option<bootstrap::Interval>,
    /// Median steady right-wheel slip, rad/s.
    pub right_rad_s: Option<bootstrap::Interval>,
    /// The same for the slips signed along the command ([`AlongCommandStats`]), in its order:
    /// vx, |vy|, wz, left, right.
    pub along_command: [Option<bootstrap::Interval>; 5],
    /// Set when the run has too few steps for a reliable interval (named warning).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// Transfer-function (kernel smoother) settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SmootherParams {
    /// Compute the transfer functions at all.
    pub enabled: bool,
    /// Grid resolution along vx, m/s (paper: 0.1).
    pub resolution_vx_m_s: f64,
    /// Grid resolution along wz, rad/s (paper: 0.1).
    pub resolution_wz_rad_s: f64,
    /// Kernel covariance (paper: 0.64 I for the Warthog figures).
    pub covariance: KernelCovariance,
    /// Fast-smoother accuracy settings.
    pub fast: FastParams,
}

impl Default for SmootherParams {
    fn default() -> Self {
        Self {
            enabled: true,
            resolution_vx_m_s: 0.1,
            resolution_wz_rad_s: 0.1,
            covariance: KernelCovariance::default(),
            fast: FastParams::default(),
        }
    }
}

/// Parameters of [`analyze`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnalysisParams {
    /// Half width (samples) of the local-line derivative of the pose (see [`velocity`]).
    pub derivative_half_width: usize,
    /// Minimum samples per window; `None` = 3/4 of the declared samples per window.
    pub min_samples_per_window: Option<usize>,
    /// A steady window whose pose moves against the encoders' direction, both faster than
    /// this (m/s), excludes its step as a localisation fault; `None` keeps such steps
    /// ([`segment::POSE_CONTRADICTION_M_S`]).
    pub pose_contradiction_m_s: Option<f64>,
    /// Cross-check tolerances.
    pub crosscheck: CrossCheckParams,
    /// Force the yaw-rate source instead of the cross-check's choice.
    pub yaw_rate_source: Option<YawRateSource>,
    /// Transfer functions.
    pub smoother: SmootherParams,
}

impl AnalysisParams {
    /// The step rules these parameters set for a log with `samples_per_window` declared samples.
    pub fn segment_rules(&self, samples_per_window: u32) -> segment::SegmentRules {
        let default = segment::SegmentRules::for_samples_per_window(samples_per_window);
        segment::SegmentRules {
            min_samples_per_window: self
                .min_samples_per_window
                .map_or(default.min_samples_per_window, |n| n.max(2)),
            pose_contradiction_m_s: self.pose_contradiction_m_s,
        }
    }
}

impl Default for AnalysisParams {
    fn default() -> Self {
        Self {
            derivative_half_width: 3,
            min_samples_per_window: None,
            pose_contradiction_m_s: Some(segment::POSE_CONTRADICTION_M_S),
            crosscheck: CrossCheckParams::default(),
            yaw_rate_source: None,
            smoother: SmootherParams::default(),
        }
    }
}

/// Slips and ρ of one window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WindowResult {
    /// Window index (0 transient).
    pub window: u32,
    /// Samples in the window.
    pub n_samples: usize,
    /// Velocities and slips (window means).
    pub slip: SlipRecord,
    /// ρ and its terms.
    pub rho: Rho,
}

/// Results of one analysed step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepResult {
    /// Step index.
    pub step: u32,
    /// Every window.
    pub windows: Vec<WindowResult>,
    /// Steady state: mean of the steady windows (1..) of realized velocities.
    pub steady: SlipRecord,
    /// ρ of the steady state.
    pub steady_rho: Rho,
    /// Measured wheel speeds at the step's first sample, rad/s: what the robot was doing when
    /// the step began (the previous step's end, or the operator's manoeuvre), which a half of a
    /// run keeps although it drops the previous step ([`turn_memory`]).
    #[serde(default)]
    pub start_wheels: WheelSpeeds,
}

/// Box-plot statistics of the steady-state slips and ρ over the analysed steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SlipStats {
    /// Longitudinal slip, m/s.
    pub vx_m_s: Option<BoxStats>,
    /// Lateral slip, m/s.
    pub vy_m_s: Option<BoxStats>,
    /// Angular slip, rad/s.
    pub wz_rad_s: Option<BoxStats>,
    /// Left wheel slip, rad/s.
    pub left_rad_s: Option<BoxStats>,
    /// Right wheel slip, rad/s.
    pub right_rad_s: Option<BoxStats>,
    /// ρ.
    pub rho: Option<BoxStats>,
    /// Realized weighted energy K_x, J.
    pub k_x_j: Option<BoxStats>,
    /// The same slips signed along the command (positive = slower than commanded), the
    /// magnitude view: signed slips of commands drawn symmetrically about zero have medians
    /// near zero whatever the terrain.
    pub along_command: AlongCommandStats,
}

/// Slip statistics signed along the command: `sign(u) · g` per component (steps with a zero
/// command component left out), and |vy| for the lateral slip (its command is zero).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AlongCommandStats {
    /// `sign(u_vx) · g_vx`, m/s.
    pub vx_m_s: Option<BoxStats>,
    /// `|g_vy|`, m/s.
    pub vy_abs_m_s: Option<BoxStats>,
    /// `sign(u_wz) · g_wz`, rad/s.
    pub wz_rad_s: Option<BoxStats>,
    /// `sign(u_l) · g_l`, rad/s.
    pub left_rad_s: Option<BoxStats>,
    /// `sign(u_r) · g_r`, rad/s.
    pub right_rad_s: Option<BoxStats>,
}

/// One flat row per step and window (and one per step's steady state, `window = None`), for
/// `summary.json`. Excluded steps get one row with NaN numbers and the reason.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    /// Step index.
    pub step: u32,
    /// Window index, `None` for the steady state.
    pub window: Option<u32>,
    /// Commanded left wheel speed, rad/s.
    pub cmd_left_rad_s: f64,
    /// Commanded right wheel speed, rad/s.
    pub cmd_right_rad_s: f64,
    /// Commanded vx (nominal IDD), m/s.
    pub cmd_vx_m_s: f64,
    /// Commanded wz (nominal IDD), rad/s.
    pub cmd_wz_rad_s: f64,
    /// Realized left wheel speed (encoder), rad/s.
    pub left_rad_s: f64,
    /// Realized right wheel speed (encoder), rad/s.
    pub right_rad_s: f64,
    /// Realized vx, m/s.
    pub vx_m_s: f64,
    /// Realized vy, m/s.
    pub vy_m_s: f64,
    /// Realized wz, rad/s.
    pub wz_rad_s: f64,
    /// Body slip vx, m/s.
    pub slip_vx_m_s: f64,
    /// Body slip vy, m/s.
    pub slip_vy_m_s: f64,
    /// Body slip wz, rad/s.
    pub slip_wz_rad_s: f64,
    /// Wheel slip left, rad/s.
    pub slip_left_rad_s: f64,
    /// Wheel slip right, rad/s.
    pub slip_right_rad_s: f64,
    /// ρ.
    pub rho: f64,
    /// Commanded energy K_u, J.
    pub k_u_j: f64,
    /// Weighted realized energy K_x, J.
    pub k_x_j: f64,
    /// Why the step is excluded, if it is.
    pub excluded: Option<String>,
}

impl SummaryRow {
    fn from_record(step: u32, window: Option<u32>, s: &SlipRecord, r: &Rho) -> Self {
        Self {
            step,
            window,
            cmd_left_rad_s: s.cmd_wheels.left_rad_s,
            cmd_right_rad_s: s.cmd_wheels.right_rad_s,
            cmd_vx_m_s: s.cmd_body.vx_m_s,
            cmd_wz_rad_s: s.cmd_body.wz_rad_s,
            left_rad_s: s.realized_wheels.left_rad_s,
            right_rad_s: s.realized_wheels.right_rad_s,
            vx_m_s: s.realized_body.vx_m_s,
            vy_m_s: s.realized_body.vy_m_s,
            wz_rad_s: s.realized_body.wz_rad_s,
            slip_vx_m_s: s.slip_body.vx_m_s,
            slip_vy_m_s: s.slip_body.vy_m_s,
            slip_wz_rad_s: s.slip_body.wz_rad_s,
            slip_left_rad_s: s.slip_wheels.left_rad_s,
            slip_right_rad_s: s.slip_wheels.right_rad_s,
            rho: r.rho,
            k_u_j: r.k_u_j,
            k_x_j: r.k_x_j,
            excluded: None,
        }
    }
    fn excluded(e: &Exclusion) -> Self {
        let n = f64::NAN;
        Self {
            step: e.step,
            window: None,
            cmd_left_rad_s: n,
            cmd_right_rad_s: n,
            cmd_vx_m_s: n,
            cmd_wz_rad_s: n,
            left_rad_s: n,
            right_rad_s: n,
            vx_m_s: n,
            vy_m_s: n,
            wz_rad_s: n,
            slip_vx_m_s: n,
            slip_vy_m_s: n,
            slip_wz_rad_s: n,
            slip_left_rad_s: n,
            slip_right_rad_s: n,
            rho: n,
            k_u_j: n,
            k_x_j: n,
            excluded: Some(e.reason.clone()),
        }
    }
}

/// A step whose steady windows record another command beside the one it holds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SteadyCommandChange {
    /// Step index.
    pub step: u32,
    /// The command it holds (its slips are taken against it), with how many of the steady
    /// samples record it.
    pub held: drive_sim_log::HeldCommand,
    /// Its last sample's command, rad/s.
    pub last_cmd: WheelSpeeds,
}

/// Everything the pipeline computes on one log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Analysis {
    /// Dataset name.
    pub dataset: String,
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Where the log came from.
    pub origin: Origin,
    /// Nominal parameters used (IDD, U, mass, footprint).
    pub nominal: Nominal,
    /// Mass and yaw inertia used by ρ.
    pub mass: MassProperties,
    /// Parameters used.
    pub params: AnalysisParams,
    /// Sensor cross-check.
    pub crosscheck: CrossCheck,
    /// Yaw-rate source actually used (the cross-check's choice unless overridden).
    pub yaw_rate_source: YawRateSource,
    /// Analysed steps.
    pub steps: Vec<StepResult>,
    /// Excluded steps and why.
    pub exclusions: Vec<Exclusion>,
    /// Steady-state statistics.
    pub stats: SlipStats,
    /// RMSE of the nominal IDD prediction of the steady-state body velocity.
    pub idd_rmse: BodyVelocity,
    /// Analysed steps whose command lies outside the declared command space U (the log's
    /// nominal limits do not describe what was commanded).
    pub commands_outside_u: usize,
    /// Analysed steps whose steady windows record another command beside the one they hold
    /// (a log recording the next step's command early): each is analysed under its held
    /// command ([`drive_sim_log::held_command`]).
    #[serde(default)]
    pub steady_command_changes: Vec<SteadyCommandChange>,
    /// The analysed steps' commands by quadrant, and how likely their balance is under
    /// uniform draws ([`command_mix`]).
    #[serde(default)]
    pub command_mix: command_mix::CommandMix,
    /// U, S, T and the area of T.
    pub spaces: Spaces,
    /// Maximum kinetic energy over U.
    pub max_kinetic_energy: MaxKineticEnergy,
    /// Risk scenarios (translation, rotation).
    pub risk: Vec<RiskScenario>,
    /// Smoothed steady-state slips and ρ over U (fields: vx, vy, wz, left, right, rho).
    pub transfer: Option<TransferFunctions>,
    /// Bootstrap intervals of the medians.
    #[serde(default)]
    pub median_ci95: MedianIntervals,
    /// Step-to-step and within-step scatter of the steady wheel speeds ([`scatter`]).
    #[serde(default)]
    pub step_scatter: scatter::StepScatter,
    /// How loaded wheels track by the previous step's turn ([`turn_memory`]).
    #[serde(default)]
    pub turn_memory: turn_memory::TurnMemory,
    /// How often the logged pose changes ([`pose_updates`]; `None` with too few changes).
    #[serde(default)]
    pub pose_updates: Option<pose_updates::PoseUpdates>,
    /// Flat rows for summary.json.
    pub rows: Vec<SummaryRow>,
}

fn mean_of(xs: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = xs.fold((0.0, 0usize), |a, x| (a.0 + x, a.1 + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Root mean square of each component.
pub fn rms(v: &[BodyVelocity]) -> BodyVelocity {
    let r = |f: fn(&BodyVelocity) -> f64| mean_of(v.iter().map(|b| f(b).powi(2))).sqrt();
    BodyVelocity::new(r(|b| b.vx_m_s), r(|b| b.vy_m_s), r(|b| b.wz_rad_s))
}

/// Runs the whole pipeline on a log.
pub fn analyze(log: &DriveLog, params: &AnalysisParams) -> Result<Analysis> {
    let meta = &log.meta;
    let nominal = pipeline::NominalModel::of(&meta.nominal);
    let (segments, exclusions) = pipeline::segment_steps(log, params)?;
    let kin = pipeline::kinematics(&segments, params.derivative_half_width, &nominal.idd);
    let crosscheck = pipeline::cross_check(&segments, &kin, meta.rate_hz, &params.crosscheck);
    // Without an IMU the pose is the only yaw rate, whatever was asked.
    let source = match params.yaw_rate_source {
        Some(forced) if crosscheck.imu => forced,
        _ => crosscheck.yaw_rate_source,
    };
    let steps = pipeline::step_results(&segments, &kin, source, &nominal);
    let steady_command_changes = pipeline::steady_command_changes(&segments);

    let cols = pipeline::SteadyColumns::of(&steps);
    let stats = pipeline::slip_stats(&steps, &cols);
    let median_ci95 = pipeline::median_intervals(steps.len(), &cols);
    let idd_rmse = rms(&steps.iter().map(|s| s.steady.slip_body).collect::<Vec<_>>());
    let commands_outside_u = steps
        .iter()
        .filter(|s| !nominal.space.contains_wheels(s.steady.cmd_wheels))
        .count();
    let command_mix = command_mix::command_mix(steps.iter().map(|s| s.steady.cmd_wheels));
    let spaces = pipeline::command_spaces(&nominal.space, &steps);
    let max_kinetic_energy = risk::max_kinetic_energy(&nominal.space, &nominal.mass);
    let risk = pipeline::risk_scenarios(meta, &steps);
    let transfer = params
        .smoother
        .enabled
        .then(|| pipeline::transfer_functions(&params.smoother, &nominal.space, &steps, &cols));
    let rows = pipeline::summary_rows(&steps, &exclusions);
    let wheels: Vec<scatter::StepWheels> = steps.iter().map(scatter::StepWheels::of).collect();
    let step_scatter = scatter::step_scatter(&wheels);
    let turn_memory = turn_memory::turn_memory(&wheels);
    let pose_updates = pose_updates::pose_updates(&log.samples, 1.0 / meta.rate_hz);
    Ok(Analysis {
        dataset: meta.name.clone(),
        robot: meta.robot.clone(),
        terrain: meta.terrain.clone(),
        origin: meta.origin.clone(),
        nominal: meta.nominal.clone(),
        mass: nominal.mass,
        params: *params,
        crosscheck,
        yaw_rate_source: source,
        steps,
        exclusions,
        stats,
        idd_rmse,
        commands_outside_u,
        steady_command_changes,
        command_mix,
        spaces,
        max_kinetic_energy,
        risk,
        transfer,
        median_ci95,
        step_scatter,
        turn_memory,
        pose_updates,
        rows,
    })
}

impl Analysis {
    /// Steady-state ρ of every analysed step.
    pub fn steady_rhos(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.steady_rho.rho).collect()
    }
}

/// Median steady-state ρ of `a` over the median of the pooled steady-state ρ of `others`: the
/// paper's terrain comparison ("the median of ice is 1.6 times the median of grass, gravel and
/// asphalt combined").
pub fn rho_median_ratio(a: &Analysis, others: &[&Analysis]) -> f64 {
    let pooled: Vec<f64> = others.iter().flat_map(|o| o.steady_rhos()).collect();
    stats::median_ratio(&a.steady_rhos(), &pooled)
}

/// RMSE of the nominal ideal-differential-drive prediction of the steady-state body velocity
/// (vx, vy, wz) against the realized one, over the analysed steps (default parameters, no
/// transfer functions). This is the RMS of the steady-state body slip.
pub fn ideal_dd_rmse(log: &DriveLog) -> Result<BodyVelocity> {
    let params = AnalysisParams {
        smoother: SmootherParams {
            enabled: false,
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    };
    Ok(analyze(log, &params)?.idd_rmse)
}
