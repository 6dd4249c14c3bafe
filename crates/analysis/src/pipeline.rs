//! The stages of [`analyze`](crate::analyze), in the order it runs them: segmentation,
//! velocities, sensor cross-check, slips and ρ per window and step, then the aggregates over
//! the steps (statistics, bootstrap intervals, spaces, risk, transfer functions, summary rows).
//! Each stage is a pure function of the earlier stages' results.

use super::{
    bootstrap, crosscheck, mean_of, rho, risk, slip, smoother, spaces, AlongCommandStats, AnalysisParams,
    MedianIntervals, SlipStats, SmootherParams, SteadyCommandChange, StepResult, SummaryRow, WindowResult,
};
use crate::crosscheck::{CrossCheck, CrossCheckParams, YawRateSource};
use crate::error::{Error, Result};
use crate::rho::MassProperties;
use crate::segment::{self, Exclusion, StepSegment};
use crate::slip::SlipRecord;
use crate::smoother::{Grid, TransferFunctions};
use crate::stats::BoxStats;
use crate::velocity::{self, SampleKinematics};
use drive_sim_log::{held_command, DriveLog, LogMeta, Nominal};
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace, IdealDiffDrive, WheelSpeeds};

/// The log's nominal model as the stages use it.
pub(crate) struct NominalModel {
    /// Ideal differential drive: commanded body velocities and slips.
    pub(crate) idd: IdealDiffDrive,
    /// Declared command space U.
    pub(crate) space: CommandSpace,
    /// Mass and yaw inertia for ρ.
    pub(crate) mass: MassProperties,
}

impl NominalModel {
    pub(crate) fn of(nominal: &Nominal) -> Self {
        Self {
            idd: nominal.idd(),
            space: nominal.command_space(),
            mass: MassProperties::from_nominal(nominal),
        }
    }
}

/// Segmentation: the complete steps, and the excluded ones with why; an error when no step is
/// complete (nothing else can be computed).
pub(crate) fn segment_steps<'a>(
    log: &'a DriveLog,
    params: &AnalysisParams,
) -> Result<(Vec<StepSegment<'a>>, Vec<Exclusion>)> {
    let meta = &log.meta;
    let rules = params.segment_rules(meta.samples_per_window);
    let (segments, exclusions) = segment::segment(log, &rules);
    if segments.is_empty() {
        let why: Vec<String> = exclusions
            .iter()
            .take(3)
            .map(|e| format!("step {}: {}", e.step, e.reason))
            .collect();
        return Err(Error::NoCompleteStep {
            dataset: meta.name.clone(),
            excluded: exclusions.len(),
            first_reasons: why,
        });
    }
    Ok((segments, exclusions))
}

/// The kinematics of one step: per window, per sample.
pub(crate) type StepKinematics = Vec<Vec<SampleKinematics>>;

/// Velocities: the kinematics of every sample of every window of every step.
pub(crate) fn kinematics(
    segments: &[StepSegment<'_>],
    half_width: usize,
    idd: &IdealDiffDrive,
) -> Vec<StepKinematics> {
    segments
        .iter()
        .map(|s| {
            s.windows
                .iter()
                .map(|w| velocity::window_kinematics(w, half_width, idd))
                .collect()
        })
        .collect()
}

/// The sensor cross-check over every window, with the accelerations of each step's transient
/// window.
pub(crate) fn cross_check(
    segments: &[StepSegment<'_>],
    kin: &[StepKinematics],
    rate_hz: f64,
    params: &CrossCheckParams,
) -> CrossCheck {
    let all_windows: Vec<Vec<SampleKinematics>> = kin.iter().flatten().cloned().collect();
    let accelerations: Vec<[f64; 4]> = segments
        .iter()
        .filter_map(|s| {
            s.windows
                .first()
                .and_then(|w| velocity::half_window_acceleration(w))
        })
        .collect();
    crosscheck::cross_check(&all_windows, &accelerations, rate_hz, params)
}

/// Slips and ρ of every window and of the steady state of every step.
pub(crate) fn step_results(
    segments: &[StepSegment<'_>],
    kin: &[StepKinematics],
    source: YawRateSource,
    nominal: &NominalModel,
) -> Vec<StepResult> {
    segments
        .iter()
        .zip(kin)
        .map(|(seg, wins)| step_result(seg, wins, source, nominal))
        .collect()
}

/// The steps whose steady windows record another command beside the one they hold (see
/// [`held_command`]), in step order.
pub(crate) fn steady_command_changes(segments: &[StepSegment<'_>]) -> Vec<SteadyCommandChange> {
    segments
        .iter()
        .filter_map(|seg| {
            let samples = || seg.windows.iter().flat_map(|w| w.iter());
            let held = held_command(samples())?;
            let last_cmd = samples().last()?.m.cmd;
            held.changes_in_steady().then_some(SteadyCommandChange {
                step: seg.step,
                held,
                last_cmd,
            })
        })
        .collect()
}

fn step_result(
    seg: &StepSegment<'_>,
    wins: &StepKinematics,
    source: YawRateSource,
    nominal: &NominalModel,
) -> StepResult {
    let cmd = held_command(seg.windows.iter().flat_map(|w| w.iter()))
        .map(|h| h.cmd)
        .unwrap_or_default();
    let windows: Vec<WindowResult> = wins
        .iter()
        .enumerate()
        .map(|(w, k)| window_result(seg.windows[w], w, k, cmd, source, nominal))
        .collect();
    let rec = steady_record(&windows, cmd, &nominal.idd);
    let start_wheels = wins
        .first()
        .and_then(|w| w.first())
        .map(|s| s.enc)
        .unwrap_or_default();
    StepResult {
        step: seg.step,
        start_wheels,
        windows,
        steady_rho: rho::rho(&nominal.mass, rec.cmd_body, rec.realized_body),
        steady: rec,
    }
}

/// Slip and ρ of window `w` (samples `samples`, kinematics `k`) under the held command `cmd`.
fn window_result(
    samples: &[drive_sim_log::Sample],
    w: usize,
    k: &[SampleKinematics],
    cmd: WheelSpeeds,
    source: YawRateSource,
    nominal: &NominalModel,
) -> WindowResult {
    let wheels = WheelSpeeds::new(
        mean_of(k.iter().map(|s| s.enc.left_rad_s)),
        mean_of(k.iter().map(|s| s.enc.right_rad_s)),
    );
    let pose = velocity::window_mean_body_velocity(samples);
    let wz = match source {
        YawRateSource::Imu => mean_of(k.iter().map(|s| s.imu_wz_rad_s)),
        YawRateSource::Pose => pose.wz_rad_s,
    };
    let body = BodyVelocity::new(pose.vx_m_s, pose.vy_m_s, wz);
    let rec = slip::slip(&nominal.idd, cmd, wheels, body);
    WindowResult {
        window: samples.first().map_or(w as u32, |s| s.window),
        n_samples: k.len(),
        slip: rec,
        rho: rho::rho(&nominal.mass, rec.cmd_body, rec.realized_body),
    }
}

/// Slip of the steady state: the mean over the steady windows (1..) of the realized velocities.
fn steady_record(windows: &[WindowResult], cmd: WheelSpeeds, idd: &IdealDiffDrive) -> SlipRecord {
    let steady: Vec<&WindowResult> = windows.iter().filter(|w| w.window >= 1).collect();
    let wheels = WheelSpeeds::new(
        mean_of(steady.iter().map(|w| w.slip.realized_wheels.left_rad_s)),
        mean_of(steady.iter().map(|w| w.slip.realized_wheels.right_rad_s)),
    );
    let body = BodyVelocity::new(
        mean_of(steady.iter().map(|w| w.slip.realized_body.vx_m_s)),
        mean_of(steady.iter().map(|w| w.slip.realized_body.vy_m_s)),
        mean_of(steady.iter().map(|w| w.slip.realized_body.wz_rad_s)),
    );
    slip::slip(idd, cmd, wheels, body)
}

/// `sign(u) · g`, NaN when `u` is zero.
fn along(u: f64, g: f64) -> f64 {
    if u == 0.0 {
        f64::NAN
    } else {
        u.signum() * g
    }
}

/// One value per analysed step, for `f`.
fn column(steps: &[StepResult], f: impl Fn(&StepResult) -> f64) -> Vec<f64> {
    steps.iter().map(f).collect()
}

/// The steady-state slips and ρ of every step, one column per quantity: what the statistics,
/// the bootstrap intervals and the transfer functions share.
pub(crate) struct SteadyColumns {
    /// Body slip vx, m/s.
    pub(crate) g_vx: Vec<f64>,
    /// Body slip vy, m/s.
    pub(crate) g_vy: Vec<f64>,
    /// Body slip wz, rad/s.
    pub(crate) g_wz: Vec<f64>,
    /// Left wheel slip, rad/s.
    pub(crate) g_l: Vec<f64>,
    /// Right wheel slip, rad/s.
    pub(crate) g_r: Vec<f64>,
    /// ρ.
    pub(crate) rho: Vec<f64>,
    /// The slips signed along the command, in the order of [`AlongCommandStats`]: vx, |vy|,
    /// wz, left, right.
    pub(crate) along: [Vec<f64>; 5],
}

impl SteadyColumns {
    pub(crate) fn of(steps: &[StepResult]) -> Self {
        Self {
            g_vx: column(steps, |s| s.steady.slip_body.vx_m_s),
            g_vy: column(steps, |s| s.steady.slip_body.vy_m_s),
            g_wz: column(steps, |s| s.steady.slip_body.wz_rad_s),
            g_l: column(steps, |s| s.steady.slip_wheels.left_rad_s),
            g_r: column(steps, |s| s.steady.slip_wheels.right_rad_s),
            rho: column(steps, |s| s.steady_rho.rho),
            along: [
                column(steps, |s| {
                    along(s.steady.cmd_body.vx_m_s, s.steady.slip_body.vx_m_s)
                }),
                column(steps, |s| s.steady.slip_body.vy_m_s.abs()),
                column(steps, |s| {
                    along(s.steady.cmd_body.wz_rad_s, s.steady.slip_body.wz_rad_s)
                }),
                column(steps, |s| {
                    along(s.steady.cmd_wheels.left_rad_s, s.steady.slip_wheels.left_rad_s)
                }),
                column(steps, |s| {
                    along(s.steady.cmd_wheels.right_rad_s, s.steady.slip_wheels.right_rad_s)
                }),
            ],
        }
    }
}

/// Box-plot statistics of the steady state.
pub(crate) fn slip_stats(steps: &[StepResult], cols: &SteadyColumns) -> SlipStats {
    let [a_vx, a_vy, a_wz, a_l, a_r] = &cols.along;
    SlipStats {
        vx_m_s: BoxStats::from_values(&cols.g_vx),
        vy_m_s: BoxStats::from_values(&cols.g_vy),
        wz_rad_s: BoxStats::from_values(&cols.g_wz),
        left_rad_s: BoxStats::from_values(&cols.g_l),
        right_rad_s: BoxStats::from_values(&cols.g_r),
        rho: BoxStats::from_values(&cols.rho),
        k_x_j: BoxStats::from_values(&column(steps, |s| s.steady_rho.k_x_j)),
        along_command: AlongCommandStats {
            vx_m_s: BoxStats::from_values(a_vx),
            vy_abs_m_s: BoxStats::from_values(a_vy),
            wz_rad_s: BoxStats::from_values(a_wz),
            left_rad_s: BoxStats::from_values(a_l),
            right_rad_s: BoxStats::from_values(a_r),
        },
    }
}

/// Bootstrap-by-step intervals of the medians of `n_steps` analysed steps.
pub(crate) fn median_intervals(n_steps: usize, cols: &SteadyColumns) -> MedianIntervals {
    let boot = bootstrap::Bootstrap::default();
    MedianIntervals {
        bootstrap: boot,
        rho: boot.median_interval(&cols.rho),
        vx_m_s: boot.median_interval(&cols.g_vx),
        vy_m_s: boot.median_interval(&cols.g_vy),
        wz_rad_s: boot.median_interval(&cols.g_wz),
        left_rad_s: boot.median_interval(&cols.g_l),
        right_rad_s: boot.median_interval(&cols.g_r),
        along_command: cols.along.each_ref().map(|c| boot.median_interval(c)),
        warning: (n_steps < bootstrap::MIN_STEPS_FOR_INTERVAL).then(|| {
            format!(
                "too_few_steps: {} analysed steps (fewer than {}): the median intervals are unreliable",
                n_steps,
                bootstrap::MIN_STEPS_FOR_INTERVAL
            )
        }),
    }
}

/// One point per analysed step, for `f`.
fn points(steps: &[StepResult], f: impl Fn(&StepResult) -> (f64, f64)) -> Vec<(f64, f64)> {
    steps.iter().map(f).collect()
}

/// Commanded (vx, wz) of every step: the sampled commands S, where the transfer functions
/// are fitted.
fn commanded_body(steps: &[StepResult]) -> Vec<(f64, f64)> {
    points(steps, |s| (s.steady.cmd_body.vx_m_s, s.steady.cmd_body.wz_rad_s))
}

/// U, S and T in both frames, from the commanded and the steady-state velocities.
pub(crate) fn command_spaces(space: &CommandSpace, steps: &[StepResult]) -> spaces::Spaces {
    spaces::spaces(
        space,
        commanded_body(steps),
        points(steps, |s| {
            (s.steady.cmd_wheels.left_rad_s, s.steady.cmd_wheels.right_rad_s)
        }),
        points(steps, |s| {
            (s.steady.realized_body.vx_m_s, s.steady.realized_body.wz_rad_s)
        }),
        points(steps, |s| {
            (
                s.steady.realized_wheels.left_rad_s,
                s.steady.realized_wheels.right_rad_s,
            )
        }),
        &column(steps, |s| s.steady.realized_body.vy_m_s),
    )
}

/// Risk scenarios (translation, rotation) from the steady ρ and energies of the steps.
pub(crate) fn risk_scenarios(meta: &LogMeta, steps: &[StepResult]) -> Vec<risk::RiskScenario> {
    risk::scenarios(
        &meta.robot,
        &meta.terrain,
        &steps
            .iter()
            .map(|s| {
                (
                    s.steady_rho.rho,
                    s.steady_rho.k_x_j,
                    s.steady_rho.k_ut_j,
                    s.steady_rho.k_urot_j,
                )
            })
            .collect::<Vec<_>>(),
    )
}

/// The kernel-smoothed steady slips and ρ over a grid covering U.
pub(crate) fn transfer_functions(
    sp: &SmootherParams,
    space: &CommandSpace,
    steps: &[StepResult],
    cols: &SteadyColumns,
) -> TransferFunctions {
    let grid = Grid::over_space(space, sp.resolution_vx_m_s, sp.resolution_wz_rad_s);
    let (method, smoothed) = smoother::smooth(
        &grid,
        &sp.covariance,
        &sp.fast,
        &commanded_body(steps),
        &[
            &cols.g_vx, &cols.g_vy, &cols.g_wz, &cols.g_l, &cols.g_r, &cols.rho,
        ],
    );
    TransferFunctions {
        grid,
        covariance: sp.covariance,
        method,
        names: [
            "slip_vx_m_s",
            "slip_vy_m_s",
            "slip_wz_rad_s",
            "slip_left_rad_s",
            "slip_right_rad_s",
            "rho",
        ]
        .map(String::from)
        .to_vec(),
        smoothed,
    }
}

/// The rows of `summary.json`: every window and steady state of the analysed steps and one
/// row per excluded step, by step then window (steady state last).
pub(crate) fn summary_rows(steps: &[StepResult], exclusions: &[Exclusion]) -> Vec<SummaryRow> {
    let mut rows = Vec::new();
    for s in steps {
        for w in &s.windows {
            rows.push(SummaryRow::from_record(s.step, Some(w.window), &w.slip, &w.rho));
        }
        rows.push(SummaryRow::from_record(s.step, None, &s.steady, &s.steady_rho));
    }
    rows.extend(exclusions.iter().map(SummaryRow::excluded));
    rows.sort_by_key(|r| (r.step, r.window.map_or(u32::MAX, |w| w)));
    rows
}
