//! The unpredictability metric ρ (paper eq. 11–14, with the GUIDE's errata).
//!
//! `K_t = ½ m |v|²`, `K_θ = ½ I_zz wz²`, `K_u = K_ut + K_uθ` from the command (vy = 0),
//! `K_x = α K_xt + β K_xθ` from the realized velocity, `α = ½ (û_t·x̂_t + 1)`,
//! `β = ½ (û_θ·x̂_θ + 1)`, `ρ = (4/π) |atan2(K_u, K_x) − π/4|` ∈ [0, 1].
//!
//! Zero vectors (the paper is silent; a unit vector of a zero velocity does not exist):
//! * both the commanded and the realized part are zero → alignment term = 1: "no motion asked,
//!   none produced" is perfect agreement;
//! * exactly one is zero → alignment term = ½, i.e. the dot product is taken as 0, which is the
//!   mean of `û·x̂` over a uniformly random direction: no evidence of agreement nor of opposition.
//!   (Only matters when the command part is zero: if the realized part is zero its energy is
//!   zero and the term multiplies nothing.)
//! * `K_u = K_x = 0` (zero command, robot at rest) → ρ = 0, the energies match; the bare formula
//!   would give atan2(0, 0) = 0 and ρ = 1, which contradicts the metric's own definition
//!   (ρ = 0 when energies match).
//!
//! Inertia: the paper's uniform box `I = m/12 diag(b²+c², d²+c², d²+b²)`. Planar motion only
//! needs `I_zz = m (d² + b²) / 12` (d length, b width); the height c enters only `I_xx`, `I_yy`,
//! which planar ρ never uses, so the nominal height is not required.

use drive_sim_log::Nominal;
use drive_sim_model::kinematics::BodyVelocity;
use serde::{Deserialize, Serialize};

/// Mass properties used by the kinetic energies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MassProperties {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Yaw inertia of the uniform box, kg·m².
    pub izz_kg_m2: f64,
}

impl MassProperties {
    /// Uniform box of the declared mass and footprint: `I_zz = m (d² + b²) / 12`.
    pub fn from_nominal(n: &Nominal) -> Self {
        Self {
            mass_kg: n.mass_kg,
            izz_kg_m2: n.mass_kg * (n.length_m * n.length_m + n.width_m * n.width_m) / 12.0,
        }
    }
    /// Translational kinetic energy `½ m (vx² + vy²)`, J.
    pub fn k_translation_j(&self, v: BodyVelocity) -> f64 {
        0.5 * self.mass_kg * (v.vx_m_s * v.vx_m_s + v.vy_m_s * v.vy_m_s)
    }
    /// Rotational kinetic energy `½ I_zz wz²`, J.
    pub fn k_rotation_j(&self, v: BodyVelocity) -> f64 {
        0.5 * self.izz_kg_m2 * v.wz_rad_s * v.wz_rad_s
    }
    /// Total kinetic energy, J.
    pub fn k_total_j(&self, v: BodyVelocity) -> f64 {
        self.k_translation_j(v) + self.k_rotation_j(v)
    }
}

/// Every term of ρ for one (command, realized) pair.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rho {
    /// Commanded translational energy, J.
    pub k_ut_j: f64,
    /// Commanded rotational energy, J.
    pub k_urot_j: f64,
    /// Commanded total energy `K_u`, J.
    pub k_u_j: f64,
    /// Realized translational energy, J.
    pub k_xt_j: f64,
    /// Realized rotational energy, J.
    pub k_xrot_j: f64,
    /// Translational alignment α ∈ [0, 1].
    pub alpha: f64,
    /// Rotational alignment β ∈ [0, 1].
    pub beta: f64,
    /// Weighted realized energy `K_x = α K_xt + β K_xθ`, J.
    pub k_x_j: f64,
    /// Unpredictability ρ ∈ [0, 1].
    pub rho: f64,
}

/// Alignment `½ (â·b̂ + 1)` of two vectors, with the zero-vector convention of this module.
pub fn alignment(a: &[f64], b: &[f64]) -> f64 {
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    match (na > 0.0, nb > 0.0) {
        (false, false) => 1.0,
        (true, false) | (false, true) => 0.5,
        (true, true) => {
            let dot = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / (na * nb);
            0.5 * (dot.clamp(-1.0, 1.0) + 1.0)
        }
    }
}

/// ρ from the energies: `(4/π) |atan2(K_u, K_x) − π/4|`, and 0 when both are zero.
pub fn rho_from_energies(k_u_j: f64, k_x_j: f64) -> f64 {
    if k_u_j == 0.0 && k_x_j == 0.0 {
        return 0.0;
    }
    (4.0 / std::f64::consts::PI) * (k_u_j.atan2(k_x_j) - std::f64::consts::FRAC_PI_4).abs()
}

/// ρ and its terms for a commanded body velocity (its vy is ignored: a skid-steer command has
/// none) and a realized one.
pub fn rho(mp: &MassProperties, cmd: BodyVelocity, realized: BodyVelocity) -> Rho {
    let cmd = BodyVelocity::new(cmd.vx_m_s, 0.0, cmd.wz_rad_s);
    let k_ut_j = mp.k_translation_j(cmd);
    let k_urot_j = mp.k_rotation_j(cmd);
    let k_xt_j = mp.k_translation_j(realized);
    let k_xrot_j = mp.k_rotation_j(realized);
    let alpha = alignment(&[cmd.vx_m_s, 0.0], &[realized.vx_m_s, realized.vy_m_s]);
    let beta = alignment(&[cmd.wz_rad_s], &[realized.wz_rad_s]);
    let k_u_j = k_ut_j + k_urot_j;
    let k_x_j = alpha * k_xt_j + beta * k_xrot_j;
    Rho {
        k_ut_j,
        k_urot_j,
        k_u_j,
        k_xt_j,
        k_xrot_j,
        alpha,
        beta,
        k_x_j,
        rho: rho_from_energies(k_u_j, k_x_j),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warthog() -> MassProperties {
        MassProperties {
            mass_kg: 470.0,
            izz_kg_m2: 470.0 * (2.13 * 2.13 + 1.52 * 1.52) / 12.0,
        }
    }

    #[test]
    fn hand_computed_cases() {
        let mp = warthog();
        // I_zz = 470 (4.5369 + 2.3104) / 12 = 268.1859... kg m².
        assert!((mp.izz_kg_m2 - 470.0 * 6.8473 / 12.0).abs() < 1e-9);
        let v = BodyVelocity::new(2.0, 0.0, 0.5);
        // Perfect tracking: K_u = K_x -> atan2 = pi/4 -> rho = 0.
        assert!(rho(&mp, v, v).rho.abs() < 1e-12);
        // Immobilized: K_x = 0 -> atan2(K_u, 0) = pi/2 -> rho = 1.
        let r = rho(&mp, v, BodyVelocity::default());
        assert!((r.rho - 1.0).abs() < 1e-12);
        // Moving with no command: atan2(0, K_x) = 0 -> rho = 1.
        assert!((rho(&mp, BodyVelocity::default(), v).rho - 1.0).abs() < 1e-12);
        // Zero command and rest: defined as 0.
        assert_eq!(
            rho(&mp, BodyVelocity::default(), BodyVelocity::default()).rho,
            0.0
        );
        // Reversed motion: alpha = beta = 0 -> K_x = 0 -> rho = 1.
        let r = rho(&mp, v, BodyVelocity::new(-2.0, 0.0, -0.5));
        assert_eq!((r.alpha, r.beta), (0.0, 0.0));
        assert!((r.rho - 1.0).abs() < 1e-12);
        // Pure rotation at half the commanded rate: K_x = K_u / 4.
        // rho = (4/pi)(atan(4) - pi/4) = (4/pi)(1.3258177 - 0.7853982) = 0.688083.
        let r = rho(
            &mp,
            BodyVelocity::new(0.0, 0.0, 1.0),
            BodyVelocity::new(0.0, 0.0, 0.5),
        );
        assert!((r.k_u_j - 0.5 * mp.izz_kg_m2).abs() < 1e-9);
        assert!((r.rho - 0.688083).abs() < 1e-6, "{}", r.rho);
        // Lateral drift at 90 degrees: alpha = 1/2. Command vx = 1, realized vy = 1 only:
        // K_u = 235, K_x = 0.5 * 235 -> rho = (4/pi)(atan(2) - pi/4) = 0.409666.
        let r = rho(
            &mp,
            BodyVelocity::new(1.0, 0.0, 0.0),
            BodyVelocity::new(0.0, 1.0, 0.0),
        );
        assert!((r.alpha - 0.5).abs() < 1e-12);
        assert!((r.rho - 0.409666).abs() < 1e-6, "{}", r.rho);
        // Pure rotation commanded, robot also drifts: command translation zero -> alpha = 1/2.
        let r = rho(
            &mp,
            BodyVelocity::new(0.0, 0.0, 1.0),
            BodyVelocity::new(0.2, 0.0, 1.0),
        );
        assert_eq!(r.alpha, 0.5);
        assert_eq!(r.beta, 1.0);
    }

    #[test]
    fn energy_ratio_symmetry() {
        // rho depends on the ratio only, and K_x = 2 K_u gives the same rho as K_x = K_u / 2.
        assert!((rho_from_energies(1.0, 2.0) - rho_from_energies(2.0, 1.0)).abs() < 1e-12);
        assert!((rho_from_energies(10.0, 20.0) - rho_from_energies(1.0, 2.0)).abs() < 1e-12);
    }
}
