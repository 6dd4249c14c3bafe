//! The reference physics step, a test oracle (feature `oracle`): the tyre solve with a
//! finite-difference Jacobian of the residual, suspension rays cast by parry,
//! and the chassis integrated by rapier's `PhysicsPipeline::step`. Slower than the fast step
//! and independent of its shortcuts (the exact Jacobian, the predicted start, the chord
//! iterations, the ray lookup, the direct free-body integration); tests and benches hold the
//! fast step to it. No build of the binary compiles it.

use super::solve::{residual, SideTorques, SolveCtx, MAX_HALVINGS, MAX_ITERATIONS, TOLERANCE, V5};
use super::tyre::{ContactForce, TyreParams};
use super::{Contact, WheelGeom, GRAVITY_M_S2, MAX_WHEELS};
use nalgebra::SMatrix;
use rapier3d::prelude::*;

/// rapier's pipeline and the sets it steps besides the bodies and colliders.
pub(crate) struct ReferencePipeline {
    params: IntegrationParameters,
    pipeline: PhysicsPipeline,
    islands: IslandManager,
    broad_phase: DefaultBroadPhase,
    narrow_phase: NarrowPhase,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    ccd: CCDSolver,
    soft_bodies: SoftBodySet,
}

impl ReferencePipeline {
    pub(crate) fn new() -> Self {
        Self {
            params: IntegrationParameters::default(),
            pipeline: PhysicsPipeline::new(),
            islands: IslandManager::new(),
            broad_phase: DefaultBroadPhase::default(),
            narrow_phase: NarrowPhase::new(),
            impulse_joints: ImpulseJointSet::new(),
            multibody_joints: MultibodyJointSet::new(),
            ccd: CCDSolver::new(),
            soft_bodies: SoftBodySet::new(),
        }
    }

    /// The reference integration: the wheel forces handed to rapier's pipeline.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn step(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &mut ColliderSet,
        body: RigidBodyHandle,
        contacts: &[Contact],
        forces: &[ContactForce],
        dt: f64,
        ex: [f64; 2],
        ey: [f64; 2],
    ) {
        let rb = &mut bodies[body];
        // User forces and torques persist in rapier until reset; both must go.
        rb.reset_forces(false);
        rb.reset_torques(false);
        for (c, f) in contacts.iter().zip(forces) {
            if !c.in_contact {
                continue;
            }
            let fw = [
                f.fx_n * ex[0] + f.fy_n * ey[0] + c.load_n * c.normal[0],
                f.fx_n * ex[1] + f.fy_n * ey[1] + c.load_n * c.normal[1],
                c.load_n * c.normal[2],
            ];
            rb.add_force_at_point(
                Vector::new(fw[0] as f32, fw[1] as f32, fw[2] as f32),
                Vector::new(c.point[0] as f32, c.point[1] as f32, c.point[2] as f32),
                true,
            );
        }
        self.params.dt = dt as f32;
        self.pipeline.step(
            Vector::new(0.0, 0.0, -GRAVITY_M_S2 as f32),
            &self.params,
            &mut self.islands,
            &mut self.broad_phase,
            &mut self.narrow_phase,
            bodies,
            colliders,
            &mut self.impulse_joints,
            &mut self.multibody_joints,
            &mut self.soft_bodies,
            &mut self.ccd,
            &(),
            &(),
        );
    }
}

/// Newton iterations with a finite-difference Jacobian and a backtracking line search: the
/// reference solve of [`crate::Stepping::Reference`].
pub(super) fn solve_reference(
    ctx: &SolveCtx,
    tyre: &TyreParams,
    wheels: &[WheelGeom],
    contacts: &[Contact],
    deflection: &[f64],
    saturated: SideTorques,
    forces: &mut [ContactForce],
) -> [f64; 5] {
    let f = |u: &V5, forces: &mut [ContactForce]| {
        residual(ctx, tyre, wheels, contacts, deflection, saturated, u, forces)
    };
    let mut u = ctx.start(&ctx.u0, saturated);
    let mut r = f(&u, forces);
    let norm = |r: &V5| ctx.residual_norm(r);
    let mut scratch_buf = [ContactForce::default(); MAX_WHEELS];
    let scratch = &mut scratch_buf[..forces.len()];
    for _ in 0..MAX_ITERATIONS {
        if norm(&r) < TOLERANCE {
            break;
        }
        let mut jac = SMatrix::<f64, 5, 5>::zeros();
        for k in 0..5 {
            // The row of an unsaturated side is `I (w - target)`: its column is known.
            if k >= 3 && saturated[k - 3].is_none() {
                jac[(k, k)] = ctx.side_inertia;
                continue;
            }
            let h = 1e-7 * (1.0 + u[k].abs());
            let mut up = u;
            up[k] += h;
            let rp = f(&up, scratch);
            jac.set_column(k, &((rp - r) / h));
        }
        let Some(delta) = jac.lu().solve(&(-r)) else {
            break;
        };
        let mut step = 1.0;
        let n0 = norm(&r);
        let mut accepted = false;
        for _ in 0..MAX_HALVINGS {
            let trial = u + delta * step;
            let rt = f(&trial, scratch);
            if norm(&rt) < n0 || step < 0.05 {
                u = trial;
                r = rt;
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted || (delta * step).amax() < 1e-12 {
            break;
        }
    }
    // Forces consistent with the accepted state.
    f(&u, forces);
    [u[0], u[1], u[2], u[3], u[4]]
}
