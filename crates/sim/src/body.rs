//! The chassis's rigid-body integration when the simulator steps it itself
//! ([`super::Stepping::Fast`]): rapier's scheme for a free body (symplectic Euler over the same
//! substeps, explicit gyroscopic term with the angular momentum kept), in f64, without the
//! island, broad-phase and constraint-solver machinery that `PhysicsPipeline::step` runs around
//! it. The chassis has no collider and no joint: the wheel forces are the only interaction, so
//! that machinery had nothing to solve.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rapier3d::prelude::*;

/// Substeps of one physics step: rapier's default `num_solver_iterations`, which it uses as
/// substeps.
pub(crate) const SUBSTEPS: usize = 4;

/// The net load on the chassis over one physics step (world frame, about the centre of mass).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Wrench {
    /// Force, N (gravity included).
    pub force_n: [f64; 3],
    /// Torque about the centre of mass, N·m.
    pub torque_nm: [f64; 3],
}

impl Wrench {
    /// Adds the force `f` applied at `point`, with the centre of mass at `com`.
    pub(crate) fn add_at_point(&mut self, f: [f64; 3], point: [f64; 3], com: [f64; 3]) {
        let r = [point[0] - com[0], point[1] - com[1], point[2] - com[2]];
        for (sum, fk) in self.force_n.iter_mut().zip(f) {
            *sum += fk;
        }
        self.torque_nm[0] += r[1] * f[2] - r[2] * f[1];
        self.torque_nm[1] += r[2] * f[0] - r[0] * f[2];
        self.torque_nm[2] += r[0] * f[1] - r[1] * f[0];
    }
}

fn v64(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn v32(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x as f32, v.y as f32, v.z as f32)
}

/// Advances `rb` (centre of mass at its origin, principal inertia `inertia_kg_m2` along its
/// axes) by `dt` under the constant wrench `w`.
pub(crate) fn integrate(rb: &mut RigidBody, mass_kg: f64, inertia_kg_m2: [f64; 3], w: &Wrench, dt: f64) {
    let pose = *rb.position();
    let r = pose.rotation;
    let mut q =
        UnitQuaternion::from_quaternion(Quaternion::new(r.w as f64, r.x as f64, r.y as f64, r.z as f64));
    let mut x = v64(pose.translation);
    let mut v = v64(rb.linvel());
    let mut om = v64(rb.angvel());
    let inertia = Vector3::from(inertia_kg_m2);
    let inv_inertia = inertia.map(|i| 1.0 / i);
    // Accelerations from the wrench, with the world inertia of the step's start (as rapier).
    let acc = Vector3::from(w.force_n) / mass_kg;
    let torque_body = q.inverse_transform_vector(&Vector3::from(w.torque_nm));
    let alpha = q.transform_vector(&torque_body.component_mul(&inv_inertia));
    let h = dt / SUBSTEPS as f64;
    for _ in 0..SUBSTEPS {
        v += acc * h;
        om += alpha * h;
        // Explicit gyroscopic term, rescaled to keep |L| (rapier's `gyroscopic_corrected_angvel`).
        let wb = q.inverse_transform_vector(&om);
        let l = inertia.component_mul(&wb);
        let total = l - wb.cross(&l) * h;
        let n2 = total.norm_squared();
        if n2 != 0.0 {
            let capped = total * (l.norm_squared() / n2).sqrt();
            om = q.transform_vector(&capped.component_mul(&inv_inertia));
        }
        x += v * h;
        q = UnitQuaternion::from_scaled_axis(om * h) * q;
    }
    let qn = q.into_inner();
    let rot = Rotation::from_xyzw(qn.i as f32, qn.j as f32, qn.k as f32, qn.w as f32).normalize();
    rb.set_position(rapier3d::math::Pose::from_parts(v32(&x), rot), false);
    rb.set_linvel(v32(&v), false);
    rb.set_angvel(v32(&om), false);
}
