//! The planar implicit solve of one physics step: backward Euler on the chassis velocity
//! (vx, vy, wz) and the wheel spins, by Newton's method with a backtracking line search.
//!
//! The Jacobian is the exact one: the tyre model's partial derivatives, chained through the
//! contact kinematics, in the same pass as the residual. The `oracle` feature adds a solve by
//! finite differences of the residual (`reference.rs`), which tests and
//! benches hold this one to; both stop at the same residual tolerance, so they agree to ~1e-10
//! of the momentum scale.

use super::tyre::{contact_force, contact_force_and_jacobian, ContactForce, TyreParams};
use super::{Contact, WheelGeom, MAX_WHEELS, TORSION_DAMPING_S};
use nalgebra::{SMatrix, SVector};

/// The motor torque of each side when it is held at its limit (N·m at the wheels, the side's
/// wheel spin then a free unknown); `None` where the controller tracks its target. A side can
/// be held at zero torque (a motor past its no-load speed), so the torque itself cannot mark it.
pub(super) type SideTorques = [Option<f64>; 2];

/// Inputs of the planar implicit solve of one physics step.
pub(super) struct SolveCtx {
    pub dt: f64,
    pub mass: f64,
    pub izz: f64,
    pub side_inertia: f64,
    pub radius: f64,
    /// External planar force and yaw moment (normal forces on slopes), heading frame.
    pub ext: [f64; 3],
    /// State at the start of the step: vx, vy, wz, omega_left, omega_right.
    pub u0: [f64; 5],
    /// Wheel spins that the unsaturated controller reaches at the end of the step.
    pub target: [f64; 2],
    /// Where [`solve`] starts its iterations: a prediction of the end of the step (the state
    /// plus the last step's change). Velocities change smoothly over a 10 ms step, so the
    /// prediction is often within Newton's final tolerance after one iteration; the reference
    /// solve starts at `u0`.
    pub guess: [f64; 5],
    /// Suspension torsion length of the tyre-deflection effect, m (0: off).
    pub torsion_m: f64,
}

pub(super) type V5 = SVector<f64, 5>;

/// Every solve stops when the residual, each row over its inertia (a velocity), is below this.
pub(super) const TOLERANCE: f64 = 1e-10;
/// Newton iterations at most.
pub(super) const MAX_ITERATIONS: usize = 12;
/// Halvings of a Newton step in the line search at most.
pub(super) const MAX_HALVINGS: usize = 6;

impl SolveCtx {
    /// The first iterate: `from`, with an unsaturated side's wheel spin at the controller's
    /// target (its residual row is linear in it and zero there).
    pub(super) fn start(&self, from: &[f64; 5], saturated: SideTorques) -> V5 {
        let mut u = V5::from_row_slice(from);
        for s in 0..2 {
            if saturated[s].is_none() {
                u[3 + s] = self.target[s];
            }
        }
        u
    }

    /// The size of a residual: each row over its inertia (a velocity change), largest.
    pub(super) fn residual_norm(&self, r: &V5) -> f64 {
        let scale = V5::new(
            self.mass,
            self.mass,
            self.izz,
            self.side_inertia,
            self.side_inertia,
        );
        r.component_div(&scale).amax()
    }
}

/// Backward-Euler residual of the planar chassis and the wheel spins; writes contact forces.
#[allow(clippy::too_many_arguments)]
pub(super) fn residual(
    ctx: &SolveCtx,
    tyre: &TyreParams,
    wheels: &[WheelGeom],
    contacts: &[Contact],
    deflection: &[f64],
    saturated: SideTorques,
    u: &V5,
    forces: &mut [ContactForce],
) -> V5 {
    let mut fx = ctx.ext[0];
    let mut fy = ctx.ext[1];
    let mut mz = ctx.ext[2];
    let mut react = [0.0; 2];
    for (i, (wg, c)) in wheels.iter().zip(contacts).enumerate() {
        if !c.in_contact {
            forces[i] = ContactForce::default();
            continue;
        }
        let vx = u[0] - u[2] * c.y_m;
        let vy = u[1] + u[2] * c.x_m;
        let lateral = (ctx.torsion_m > 0.0).then(|| {
            // Deflection after this step (explicit in the relaxation, implicit in damping).
            deflection[i] + ctx.dt * vy / ctx.torsion_m + TORSION_DAMPING_S * vy / ctx.torsion_m
        });
        let f = contact_force(tyre, c.load_n, vx, vy, u[3 + wg.side], ctx.radius, lateral);
        forces[i] = f;
        fx += f.fx_n;
        fy += f.fy_n;
        mz += c.x_m * f.fy_n - c.y_m * f.fx_n;
        react[wg.side] += f.reaction_nm;
    }
    let dt = ctx.dt;
    let mut r = V5::zeros();
    r[0] = ctx.mass * (u[0] - ctx.u0[0]) - dt * fx;
    r[1] = ctx.mass * (u[1] - ctx.u0[1]) - dt * fy;
    r[2] = ctx.izz * (u[2] - ctx.u0[2]) - dt * mz;
    for side in 0..2 {
        r[3 + side] = match saturated[side] {
            None => ctx.side_inertia * (u[3 + side] - ctx.target[side]),
            Some(torque) => ctx.side_inertia * (u[3 + side] - ctx.u0[3 + side]) - dt * (torque - react[side]),
        };
    }
    r
}

type M5 = SMatrix<f64, 5, 5>;

/// The residual of [`residual`] (same arithmetic, same rounding) and its exact Jacobian.
#[allow(clippy::too_many_arguments)]
fn residual_and_jacobian(
    ctx: &SolveCtx,
    tyre: &TyreParams,
    wheels: &[WheelGeom],
    contacts: &[Contact],
    deflection: &[f64],
    saturated: SideTorques,
    u: &V5,
    forces: &mut [ContactForce],
) -> (V5, M5) {
    let dt = ctx.dt;
    let mut fx = ctx.ext[0];
    let mut fy = ctx.ext[1];
    let mut mz = ctx.ext[2];
    let mut react = [0.0; 2];
    // Gradients over u of the summed forces, the yaw moment and each side's reaction.
    let mut g_fx = [0.0; 5];
    let mut g_fy = [0.0; 5];
    let mut g_mz = [0.0; 5];
    let mut g_react = [[0.0; 5]; 2];
    for (i, (wg, c)) in wheels.iter().zip(contacts).enumerate() {
        if !c.in_contact {
            forces[i] = ContactForce::default();
            continue;
        }
        let vx = u[0] - u[2] * c.y_m;
        let vy = u[1] + u[2] * c.x_m;
        let lateral = (ctx.torsion_m > 0.0).then(|| {
            (
                deflection[i] + ctx.dt * vy / ctx.torsion_m + TORSION_DAMPING_S * vy / ctx.torsion_m,
                (ctx.dt + TORSION_DAMPING_S) / ctx.torsion_m,
            )
        });
        let (f, j) = contact_force_and_jacobian(tyre, c.load_n, vx, vy, u[3 + wg.side], ctx.radius, lateral);
        forces[i] = f;
        fx += f.fx_n;
        fy += f.fy_n;
        mz += c.x_m * f.fy_n - c.y_m * f.fx_n;
        react[wg.side] += f.reaction_nm;
        // d(vx, vy, omega)/du: vx = u0 - u2 y, vy = u1 + u2 x, omega = u[3 + side].
        let grad = |row: &[f64; 3]| {
            let mut g = [row[0], row[1], -c.y_m * row[0] + c.x_m * row[1], 0.0, 0.0];
            g[3 + wg.side] = row[2];
            g
        };
        let (gx, gy, gr) = (grad(&j[0]), grad(&j[1]), grad(&j[2]));
        for k in 0..5 {
            g_fx[k] += gx[k];
            g_fy[k] += gy[k];
            g_mz[k] += c.x_m * gy[k] - c.y_m * gx[k];
            g_react[wg.side][k] += gr[k];
        }
    }
    let mut r = V5::zeros();
    r[0] = ctx.mass * (u[0] - ctx.u0[0]) - dt * fx;
    r[1] = ctx.mass * (u[1] - ctx.u0[1]) - dt * fy;
    r[2] = ctx.izz * (u[2] - ctx.u0[2]) - dt * mz;
    let mut jac = M5::zeros();
    for k in 0..5 {
        jac[(0, k)] = -dt * g_fx[k];
        jac[(1, k)] = -dt * g_fy[k];
        jac[(2, k)] = -dt * g_mz[k];
    }
    jac[(0, 0)] += ctx.mass;
    jac[(1, 1)] += ctx.mass;
    jac[(2, 2)] += ctx.izz;
    for side in 0..2 {
        let row = 3 + side;
        if let Some(torque) = saturated[side] {
            r[row] = ctx.side_inertia * (u[row] - ctx.u0[row]) - dt * (torque - react[side]);
            for k in 0..5 {
                jac[(row, k)] = dt * g_react[side][k];
            }
        } else {
            r[row] = ctx.side_inertia * (u[row] - ctx.target[side]);
        }
        jac[(row, row)] += ctx.side_inertia;
    }
    (r, jac)
}

/// Newton iterations with the exact Jacobian, kept while it contracts (a chord method), and a
/// backtracking line search; writes the contact forces of the accepted state into `forces`.
///
/// Within one 10 ms step the Jacobian barely changes: refactoring it at every iterate costs a
/// tyre-Jacobian evaluation and an LU per iteration for a convergence that the first one's
/// already gives. The Jacobian is refreshed only when an iteration contracts the residual by
/// less than [`CHORD_CONTRACTION`] (near a friction peak, at a saturation switch), so the
/// solve keeps Newton's robustness and stops at the same tolerance.
pub(super) fn solve(
    ctx: &SolveCtx,
    tyre: &TyreParams,
    wheels: &[WheelGeom],
    contacts: &[Contact],
    deflection: &[f64],
    saturated: SideTorques,
    forces: &mut [ContactForce],
) -> [f64; 5] {
    let residual_only = |u: &V5, forces: &mut [ContactForce]| {
        residual(ctx, tyre, wheels, contacts, deflection, saturated, u, forces)
    };
    let with_jacobian = |u: &V5, forces: &mut [ContactForce]| {
        residual_and_jacobian(ctx, tyre, wheels, contacts, deflection, saturated, u, forces)
    };
    let mut u = ctx.start(&ctx.guess, saturated);
    let (mut r, jac) = with_jacobian(&u, forces);
    let mut lu = jac.lu();
    let mut fresh = true;
    let norm = |r: &V5| ctx.residual_norm(r);
    let mut scratch_buf = [ContactForce::default(); MAX_WHEELS];
    let scratch = &mut scratch_buf[..forces.len()];
    for _ in 0..MAX_ITERATIONS {
        let n0 = norm(&r);
        if n0 < TOLERANCE {
            break;
        }
        let Some(delta) = lu.solve(&(-r)) else {
            break;
        };
        let mut step = 1.0;
        let mut accepted = false;
        for _ in 0..MAX_HALVINGS {
            let trial = u + delta * step;
            let rt = residual_only(&trial, scratch);
            if norm(&rt) < n0 || step < 0.05 {
                u = trial;
                r = rt;
                forces.copy_from_slice(scratch);
                accepted = true;
                break;
            }
            if !fresh {
                // A stale Jacobian that does not descend: refresh it before backtracking.
                break;
            }
            step *= 0.5;
        }
        if accepted && (delta * step).amax() < 1e-12 {
            break;
        }
        if !accepted && fresh {
            break;
        }
        // Refresh the Jacobian when the chord step contracted too little (or failed).
        if !accepted || norm(&r) > CHORD_CONTRACTION * n0 {
            let (rj, jac) = with_jacobian(&u, scratch);
            r = rj;
            lu = jac.lu();
            fresh = true;
        } else {
            fresh = false;
        }
    }
    [u[0], u[1], u[2], u[3], u[4]]
}

/// The residual contraction an iteration must reach to keep its Jacobian for the next one.
const CHORD_CONTRACTION: f64 = 0.05;
