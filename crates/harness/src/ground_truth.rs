//! Ground-truth transfer functions of a plant, and the error of DRIVE's smoothed estimate
//! against them.
//!
//! The truth at a grid point ū of U is what the plant does when ū is held open-loop: a fresh
//! plant (from the caller's factory, so noise and seeds are the caller's choice) stands still
//! for `settle_s`, then holds the wheel command of ū (nominal IDD) for `hold_s`; the steady
//! state is the mean of the TRUE body velocity and true wheel spin over the last
//! `steady_s` (DRIVE's two steady windows: 2–6 s of a 6 s step). The slip is commanded minus
//! realized, as in the analysis. This differs from DRIVE's own steady states in one way, on
//! purpose: DRIVE starts each step from the previous command, the truth always from rest, so the
//! truth is the plant's response, not the protocol's history.

use crate::error::Result;
use drive_sim_analysis::smoother::{smooth_exact, Grid, KernelCovariance};
use drive_sim_analysis::Analysis;
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace, WheelSpeeds};
use drive_sim_sim::Plant;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How the open-loop truth is measured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthParams {
    /// Rest before the command, s.
    pub settle_s: f64,
    /// Duration the command is held, s (DRIVE: 6 s).
    pub hold_s: f64,
    /// Averaging span at the end of the hold, s (DRIVE: the two last 2 s windows).
    pub steady_s: f64,
    /// Sampling period of the averages, s.
    pub tick_s: f64,
}

impl Default for GroundTruthParams {
    fn default() -> Self {
        Self {
            settle_s: 1.0,
            hold_s: 6.0,
            steady_s: 4.0,
            tick_s: 0.05,
        }
    }
}

/// Steady-state slips at the grid points (NaN outside U). Index = `iwz * nvx + ivx`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthField {
    /// The grid.
    pub grid: Grid,
    /// Body-frame slip `u_B − x_B` at each grid point.
    pub slip_body: Vec<BodyVelocity>,
    /// Wheel-frame slip `u_W − x_W` at each grid point, rad/s.
    pub slip_wheels: Vec<WheelSpeeds>,
}

/// Holds one command open-loop on a fresh plant; returns (body slip, wheel slip).
fn hold_one<P: Plant>(
    plant: &mut P,
    space: &CommandSpace,
    cmd_body: BodyVelocity,
    p: &GroundTruthParams,
) -> Result<(BodyVelocity, WheelSpeeds)> {
    let cmd = space
        .idd
        .wheels_from_body(BodyVelocity::new(cmd_body.vx_m_s, 0.0, cmd_body.wz_rad_s));
    plant.command(WheelSpeeds::default());
    plant.advance(p.settle_s)?;
    plant.command(cmd);
    let n = (p.hold_s / p.tick_s).round() as usize;
    let first = n - ((p.steady_s / p.tick_s).round() as usize).min(n);
    let (mut v, mut w, mut k) = (BodyVelocity::default(), WheelSpeeds::default(), 0.0);
    for i in 0..n {
        plant.advance(p.tick_s)?;
        if i >= first {
            let b = plant.true_velocity();
            let m = plant.measure();
            let ws = m.truth.map(|t| t.wheels).unwrap_or(m.enc);
            v = BodyVelocity::new(v.vx_m_s + b.vx_m_s, v.vy_m_s + b.vy_m_s, v.wz_rad_s + b.wz_rad_s);
            w = WheelSpeeds::new(w.left_rad_s + ws.left_rad_s, w.right_rad_s + ws.right_rad_s);
            k += 1.0;
        }
    }
    let v = BodyVelocity::new(v.vx_m_s / k, v.vy_m_s / k, v.wz_rad_s / k);
    let w = WheelSpeeds::new(w.left_rad_s / k, w.right_rad_s / k);
    let u_b = space.idd.body_from_wheels(cmd);
    Ok((u_b.minus(v), cmd.minus(w)))
}

/// The open-loop truth of the plants `make_plant` builds, at every grid point inside U (one
/// fresh plant per point, in parallel).
pub fn ground_truth<P, F>(
    make_plant: F,
    space: &CommandSpace,
    grid: &Grid,
    params: &GroundTruthParams,
) -> Result<TruthField>
where
    P: Plant,
    F: Fn() -> Result<P> + Sync,
{
    let nv = grid.vx_m_s.len();
    let nan_b = BodyVelocity::new(f64::NAN, f64::NAN, f64::NAN);
    let nan_w = WheelSpeeds::new(f64::NAN, f64::NAN);
    let out: Vec<(BodyVelocity, WheelSpeeds)> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            if !grid.inside[i] {
                return Ok((nan_b, nan_w));
            }
            let u = BodyVelocity::new(grid.vx_m_s[i % nv], 0.0, grid.wz_rad_s[i / nv]);
            let mut plant = make_plant()?;
            hold_one(&mut plant, space, u, params)
        })
        .collect::<Result<_>>()?;
    Ok(TruthField {
        grid: grid.clone(),
        slip_body: out.iter().map(|o| o.0).collect(),
        slip_wheels: out.iter().map(|o| o.1).collect(),
    })
}

/// RMS over the grid points inside U of (smoothed DRIVE estimate − truth), per body slip
/// component. NaN components mean no grid point had both values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TransferError {
    /// Longitudinal slip error, m/s.
    pub vx_m_s: f64,
    /// Lateral slip error, m/s.
    pub vy_m_s: f64,
    /// Angular slip error, rad/s.
    pub wz_rad_s: f64,
    /// Grid points compared.
    pub points: usize,
}

/// Smooths the steady-state body slips of the first `steps` analysed steps of `analysis` on the
/// truth's grid (Gaussian kernel `cov`, exact smoother) and returns the RMS error against the
/// truth.
pub fn transfer_error(
    analysis: &Analysis,
    steps: usize,
    truth: &TruthField,
    cov: &KernelCovariance,
) -> TransferError {
    let used = &analysis.steps[..steps.min(analysis.steps.len())];
    let pts: Vec<(f64, f64)> = used
        .iter()
        .map(|s| (s.steady.cmd_body.vx_m_s, s.steady.cmd_body.wz_rad_s))
        .collect();
    let gx: Vec<f64> = used.iter().map(|s| s.steady.slip_body.vx_m_s).collect();
    let gy: Vec<f64> = used.iter().map(|s| s.steady.slip_body.vy_m_s).collect();
    let gz: Vec<f64> = used.iter().map(|s| s.steady.slip_body.wz_rad_s).collect();
    let est = smooth_exact(&truth.grid, cov, &pts, &[&gx, &gy, &gz]);
    let mut sums = [0.0; 3];
    let mut n = 0usize;
    for (i, t) in truth.slip_body.iter().enumerate() {
        let e = [est.values[0][i], est.values[1][i], est.values[2][i]];
        let tv = [t.vx_m_s, t.vy_m_s, t.wz_rad_s];
        if !truth.grid.inside[i] || e.iter().chain(tv.iter()).any(|x| !x.is_finite()) {
            continue;
        }
        for c in 0..3 {
            sums[c] += (e[c] - tv[c]).powi(2);
        }
        n += 1;
    }
    let r = |s: f64| if n == 0 { f64::NAN } else { (s / n as f64).sqrt() };
    TransferError {
        vx_m_s: r(sums[0]),
        vy_m_s: r(sums[1]),
        wz_rad_s: r(sums[2]),
        points: n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::IdealDiffDrive;
    use drive_sim_sim::IdealPlant;

    #[test]
    fn ideal_plant_has_zero_slip_everywhere() {
        // The IDD plant follows the command exactly after its lag: the truth must be ~0 slip.
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        let space = CommandSpace {
            idd,
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
            turn_scale: 1.0,
        };
        let grid = Grid::with_counts(&space, 5, 5);
        let t = ground_truth(
            || Ok(IdealPlant::new(idd, 0.2)),
            &space,
            &grid,
            &GroundTruthParams::default(),
        )
        .unwrap();
        let inside = grid.inside.iter().filter(|b| **b).count();
        assert!(inside > 0);
        for (i, s) in t.slip_body.iter().enumerate() {
            if grid.inside[i] {
                assert!(
                    s.vx_m_s.abs() < 1e-3 && s.vy_m_s.abs() < 1e-3 && s.wz_rad_s.abs() < 1e-3,
                    "{s:?}"
                );
            } else {
                assert!(s.vx_m_s.is_nan());
            }
        }
    }
}
