//! Where the model misses: the residual (recording minus replay) over the command space, over
//! time within a step, left versus right, and against each measured channel.

use super::metrics::{StepFeatures, SERIES_CHANNELS, STEADY_CHANNELS};
use drive_sim_analysis::smoother::{smooth_exact, Grid, KernelCovariance};
use drive_sim_model::kinematics::{CommandSpace, IdealDiffDrive};
use serde::{Deserialize, Serialize};

/// The steady residual of one step at its command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualPoint {
    /// Step index.
    pub step: u32,
    /// Commanded body velocity (declared IDD of the mean steady command).
    pub cmd: drive_sim_model::kinematics::BodyVelocity,
    /// Recording minus replay of each [`STEADY_CHANNELS`], mean over the steady windows.
    pub residual: [f64; 6],
}

/// A residual channel smoothed over the command space (body frame) with the Gaussian kernel
/// smoother of [`drive_sim_analysis::smoother`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualMap {
    /// Residual channel (one of [`STEADY_CHANNELS`]).
    pub channel: String,
    /// Grid abscissae: commanded vx, m/s.
    pub vx_m_s: Vec<f64>,
    /// Grid ordinates: commanded wz, rad/s.
    pub wz_rad_s: Vec<f64>,
    /// `values[j][i]` at (`vx[i]`, `wz[j]`); `None` outside the command space.
    pub values: Vec<Vec<Option<f64>>>,
    /// Kernel variance (same on both axes, in the units of the axes squared).
    pub kernel_var: f64,
}

/// Residual over time within a step, averaged over steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimeResidual {
    /// Time in step, s.
    pub t_s: Vec<f64>,
    /// Channel names ([`SERIES_CHANNELS`]).
    pub channels: Vec<String>,
    /// Mean residual per time and channel.
    pub mean: Vec<[f64; 4]>,
    /// RMS residual per time and channel.
    pub rms: Vec<[f64; 4]>,
}

/// Steady wheel-speed residual per side: a one-sided effect shows as an asymmetry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SideResidual {
    /// Mean left residual, rad/s.
    pub left_mean_rad_s: f64,
    /// RMS left residual, rad/s.
    pub left_rms_rad_s: f64,
    /// Mean right residual, rad/s.
    pub right_mean_rad_s: f64,
    /// RMS right residual, rad/s.
    pub right_rms_rad_s: f64,
    /// Regression slope of the left residual on the left command (a gain error shows here).
    pub left_slope: f64,
    /// Regression slope of the right residual on the right command.
    pub right_slope: f64,
}

/// Correlation of a residual channel with a measured or commanded quantity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelCorrelation {
    /// Residual channel.
    pub residual: String,
    /// Quantity it is compared with.
    pub against: String,
    /// Pearson correlation over steps.
    pub r: f64,
}

/// The whole residual picture of one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualAnalysis {
    /// Per-step steady residuals.
    pub points: Vec<ResidualPoint>,
    /// Smoothed steady residual of vx, vy and wz over the command space.
    pub maps: Vec<ResidualMap>,
    /// Residual over time in step.
    pub time: TimeResidual,
    /// Left versus right.
    pub sides: SideResidual,
    /// Residual channels against measured and commanded quantities, strongest first.
    pub correlations: Vec<ChannelCorrelation>,
}

fn pearson(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len()) as f64;
    if n < 3.0 {
        return f64::NAN;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return 0.0;
    }
    sxy / (sxx * syy).sqrt()
}

/// Least-squares slope of y on x through the origin-free line.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return 0.0;
    }
    x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum::<f64>() / sxx
}

/// Analyses the residual of `sim` (replayed features) against `meas` (recorded, same steps in
/// the same order). `idd` and `space` are the declared ones (the axes of the maps); the maps
/// use a grid of `grid_step` in both axes and kernel variance `kernel_var`.
pub fn analyse(
    sim: &[StepFeatures],
    meas: &[StepFeatures],
    idd: IdealDiffDrive,
    space: &CommandSpace,
    grid_step: f64,
    kernel_var: f64,
) -> ResidualAnalysis {
    let pairs: Vec<(&StepFeatures, &StepFeatures)> = sim
        .iter()
        .zip(meas)
        .filter(|(s, m)| s.step == m.step && !m.steady.is_empty())
        .collect();
    let points: Vec<ResidualPoint> = pairs
        .iter()
        .map(|(s, m)| {
            let mut r = [0.0; 6];
            let n = m.steady.len().min(s.steady.len()).max(1) as f64;
            for (ws, wm) in s.steady.iter().zip(&m.steady) {
                for c in 0..6 {
                    r[c] += (wm[c] - ws[c]) / n;
                }
            }
            ResidualPoint {
                step: m.step,
                cmd: idd.body_from_wheels(m.cmd),
                residual: r,
            }
        })
        .collect();

    // Maps over the command space: the analysis module's exact Gaussian kernel smoother.
    let grid = Grid::over_space(space, grid_step, grid_step);
    let cov = KernelCovariance {
        var_vx: kernel_var,
        var_wz: kernel_var,
    };
    let cmd_points: Vec<(f64, f64)> = points.iter().map(|p| (p.cmd.vx_m_s, p.cmd.wz_rad_s)).collect();
    let channels: Vec<Vec<f64>> = (0..3)
        .map(|c| points.iter().map(|p| p.residual[c]).collect())
        .collect();
    let channel_refs: Vec<&[f64]> = channels.iter().map(|c| c.as_slice()).collect();
    let smoothed = smooth_exact(&grid, &cov, &cmd_points, &channel_refs);
    let nvx = grid.vx_m_s.len();
    let maps = (0..3)
        .map(|c| ResidualMap {
            channel: STEADY_CHANNELS[c].to_string(),
            vx_m_s: grid.vx_m_s.clone(),
            wz_rad_s: grid.wz_rad_s.clone(),
            values: (0..grid.wz_rad_s.len())
                .map(|j| {
                    (0..nvx)
                        .map(|i| Some(smoothed.values[c][j * nvx + i]).filter(|v| v.is_finite()))
                        .collect()
                })
                .collect(),
            kernel_var,
        })
        .collect();

    // Over time in step: samples are aligned by index (same sampling in replay and recording).
    let n_t = pairs.iter().map(|(_, m)| m.t_s.len()).max().unwrap_or(0);
    let mut sum = vec![[0.0; 4]; n_t];
    let mut sq = vec![[0.0; 4]; n_t];
    let mut cnt = vec![0usize; n_t];
    let mut t_s = vec![0.0; n_t];
    for (s, m) in &pairs {
        for i in 0..m.series.len().min(s.series.len()) {
            t_s[i] = m.t_s[i];
            cnt[i] += 1;
            for c in 0..4 {
                let r = m.series[i][c] - s.series[i][c];
                sum[i][c] += r;
                sq[i][c] += r * r;
            }
        }
    }
    let time = TimeResidual {
        t_s,
        channels: SERIES_CHANNELS.iter().map(|s| s.to_string()).collect(),
        mean: sum
            .iter()
            .zip(&cnt)
            .map(|(s, &n)| s.map(|v| v / n.max(1) as f64))
            .collect(),
        rms: sq
            .iter()
            .zip(&cnt)
            .map(|(s, &n)| s.map(|v| (v / n.max(1) as f64).sqrt()))
            .collect(),
    };

    // Left versus right.
    let col = |c: usize| points.iter().map(|p| p.residual[c]).collect::<Vec<f64>>();
    let (rl, rr) = (col(3), col(4));
    let n = points.len().max(1) as f64;
    let cl: Vec<f64> = pairs.iter().map(|(_, m)| m.cmd.left_rad_s).collect();
    let cr: Vec<f64> = pairs.iter().map(|(_, m)| m.cmd.right_rad_s).collect();
    let sides = SideResidual {
        left_mean_rad_s: rl.iter().sum::<f64>() / n,
        left_rms_rad_s: (rl.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        right_mean_rad_s: rr.iter().sum::<f64>() / n,
        right_rms_rad_s: (rr.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        left_slope: slope(&cl, &rl),
        right_slope: slope(&cr, &rr),
    };

    // Against the measured and commanded channels.
    let mut against: Vec<(String, Vec<f64>)> = vec![
        ("cmd_left".into(), cl.clone()),
        ("cmd_right".into(), cr.clone()),
        ("cmd_vx".into(), points.iter().map(|p| p.cmd.vx_m_s).collect()),
        ("cmd_wz".into(), points.iter().map(|p| p.cmd.wz_rad_s).collect()),
        (
            "|cmd_wz|".into(),
            points.iter().map(|p| p.cmd.wz_rad_s.abs()).collect(),
        ),
    ];
    for (c, name) in STEADY_CHANNELS.iter().enumerate() {
        against.push((
            format!("measured {name}"),
            pairs
                .iter()
                .map(|(_, m)| m.steady.iter().map(|w| w[c]).sum::<f64>() / m.steady.len() as f64)
                .collect(),
        ));
    }
    let mut correlations = Vec::new();
    for (c, name) in STEADY_CHANNELS.iter().enumerate() {
        let r = col(c);
        for (a, x) in &against {
            correlations.push(ChannelCorrelation {
                residual: name.to_string(),
                against: a.clone(),
                r: pearson(x, &r),
            });
        }
    }
    correlations.retain(|c| c.r.is_finite());
    correlations.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    ResidualAnalysis {
        points,
        maps,
        time,
        sides,
        correlations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::WheelSpeeds;

    fn feat(step: u32, cmd: (f64, f64), steady: [f64; 6]) -> StepFeatures {
        StepFeatures {
            step,
            cmd: WheelSpeeds::new(cmd.0, cmd.1),
            steady: vec![steady, steady],
            t_s: vec![0.0, 0.05],
            window: vec![0, 0],
            series: vec![[steady[0], steady[2], steady[3], steady[4]]; 2],
            displacement: vec![[0.0; 3]; 3],
        }
    }

    #[test]
    fn a_weak_left_motor_shows_on_the_left() {
        // Recording: left wheel reaches 0.8 of the command; replay: the full command.
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        let space = CommandSpace {
            idd,
            max_wheel_rad_s: 10.0,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
            turn_scale: 1.0,
        };
        let cmds = [(1.0, 2.0), (-3.0, 4.0), (5.0, 5.0), (2.0, -6.0), (-4.0, -1.0)];
        let meas: Vec<StepFeatures> = cmds
            .iter()
            .enumerate()
            .map(|(i, &(l, r))| feat(i as u32, (l, r), [0.0, 0.0, 0.0, 0.8 * l, r, 0.0]))
            .collect();
        let sim: Vec<StepFeatures> = cmds
            .iter()
            .enumerate()
            .map(|(i, &(l, r))| feat(i as u32, (l, r), [0.0, 0.0, 0.0, l, r, 0.0]))
            .collect();
        let a = analyse(&sim, &meas, idd, &space, 0.5, 0.64);
        // Left residual = -0.2 * cmd_left: slope -0.2; right residual zero.
        assert!((a.sides.left_slope + 0.2).abs() < 1e-12, "{:?}", a.sides);
        assert_eq!(a.sides.right_rms_rad_s, 0.0);
        // Mean left residual: -0.2 * mean(1, -3, 5, 2, -4) = -0.04.
        assert!((a.sides.left_mean_rad_s + 0.04).abs() < 1e-12);
        // The strongest correlation is the left residual against the left command, r = -1.
        let top = &a.correlations[0];
        assert_eq!(top.residual, "enc_left");
        assert!((top.r + 1.0).abs() < 1e-9, "{top:?}");
        // Maps have the grid shape and are empty outside U (|vx| = 5 with wz = 4 is outside).
        let m = &a.maps[0];
        assert_eq!(m.values.len(), m.wz_rad_s.len());
        assert!(m.values.iter().all(|row| row.len() == m.vx_m_s.len()));
        let (i, j) = (m.vx_m_s.len() - 1, m.wz_rad_s.len() - 1);
        assert!(m.values[j][i].is_none());
        // Inside U the smoothed vx residual is a weighted mean of zeros.
        assert!(a.maps[0].values.iter().flatten().flatten().count() > 0);
        assert!(a.maps[0]
            .values
            .iter()
            .flatten()
            .flatten()
            .all(|v| v.abs() < 1e-12));
    }
}
