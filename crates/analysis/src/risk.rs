//! Risk: severity = realized kinetic energy, likelihood = ρ (paper Fig. 11).
//!
//! Maximum kinetic energy over U: `K(vx, wz) = ½ m vx² + ½ I_zz wz²` is a convex function
//! (a positive semi-definite quadratic form), and U is a convex polygon. A convex function on a
//! compact convex polygon attains its maximum at an extreme point: any point of U is a convex
//! combination Σ λ_j v_j of the vertices and, by convexity, K(Σ λ_j v_j) ≤ Σ λ_j K(v_j) ≤
//! max_j K(v_j). So the maximum is the largest K over U's vertices.
//!
//! Scenario = (robot, terrain, motion class). Motion classes classify each step by its
//! commanded energy: `translation` when the translational part `K_ut` is at least half of `K_u`
//! (the paper's "motion 1", driving forward), `rotation` otherwise ("motion 2", turning).
//! The paper ran dedicated forward/turning runs; on DRIVE data this split is the closest
//! reproducible equivalent. Steps with `K_u = 0` are left out of both classes.
//!
//! Each scenario gets its median point (ρ, K_x) and the 95 % ellipse of a bivariate normal fit
//! (mean, sample covariance, Mahalanobis radius² = χ²₂(0.95) = 5.991).

use super::rho::MassProperties;
use super::stats::median;
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace};
use serde::{Deserialize, Serialize};

/// χ² quantile with 2 degrees of freedom at 95 %: `−2 ln 0.05`.
pub const CHI2_2DOF_95: f64 = 5.991464547107979;

/// Largest kinetic energy over U and the vertex where it is reached.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MaxKineticEnergy {
    /// Maximum K over U, J.
    pub k_max_j: f64,
    /// The vertex (vx m/s, wz rad/s) where it is reached.
    pub at_vx_m_s: f64,
    /// Yaw rate at that vertex, rad/s.
    pub at_wz_rad_s: f64,
}

/// Maximum kinetic energy over U (at a vertex, see the module doc).
pub fn max_kinetic_energy(space: &CommandSpace, mp: &MassProperties) -> MaxKineticEnergy {
    space
        .polygon_body()
        .into_iter()
        .map(|(vx, wz)| MaxKineticEnergy {
            k_max_j: mp.k_total_j(BodyVelocity::new(vx, 0.0, wz)),
            at_vx_m_s: vx,
            at_wz_rad_s: wz,
        })
        .fold(
            MaxKineticEnergy {
                k_max_j: 0.0,
                at_vx_m_s: 0.0,
                at_wz_rad_s: 0.0,
            },
            |a, b| if b.k_max_j > a.k_max_j { b } else { a },
        )
}

/// Motion class of a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionClass {
    /// Translational command energy ≥ half of the total.
    Translation,
    /// Rotational command energy > half of the total.
    Rotation,
}

impl MotionClass {
    /// Class of a command from its energies; `None` for a zero command.
    pub fn of(k_ut_j: f64, k_urot_j: f64) -> Option<Self> {
        let k = k_ut_j + k_urot_j;
        if k.is_nan() || k <= 0.0 {
            None
        } else if k_ut_j >= 0.5 * k {
            Some(Self::Translation)
        } else {
            Some(Self::Rotation)
        }
    }
}

/// 95 % ellipse of a bivariate normal fit in the (ρ, K_x) plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Ellipse95 {
    /// Centre (mean ρ, mean K_x J).
    pub center: (f64, f64),
    /// Sample covariance [[ρρ, ρK], [ρK, KK]].
    pub covariance: [[f64; 2]; 2],
    /// Semi-axes, major first (in the plot's units: ρ and J mixed).
    pub semi_axes: (f64, f64),
    /// Angle of the major axis from the ρ axis, rad.
    pub angle_rad: f64,
}

/// Ellipse of `points` (ρ, K_x); `None` with fewer than 3 points.
pub fn ellipse95(points: &[(f64, f64)]) -> Option<Ellipse95> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    let m = (
        points.iter().map(|p| p.0).sum::<f64>() / nf,
        points.iter().map(|p| p.1).sum::<f64>() / nf,
    );
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for p in points {
        a += (p.0 - m.0).powi(2);
        b += (p.0 - m.0) * (p.1 - m.1);
        c += (p.1 - m.1).powi(2);
    }
    let (a, b, c) = (a / (nf - 1.0), b / (nf - 1.0), c / (nf - 1.0));
    let eig = nalgebra::Matrix2::new(a, b, b, c).symmetric_eigen();
    let (i_max, i_min) = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    let v = eig.eigenvectors.column(i_max);
    Some(Ellipse95 {
        center: m,
        covariance: [[a, b], [b, c]],
        semi_axes: (
            (CHI2_2DOF_95 * eig.eigenvalues[i_max].max(0.0)).sqrt(),
            (CHI2_2DOF_95 * eig.eigenvalues[i_min].max(0.0)).sqrt(),
        ),
        angle_rad: v[1].atan2(v[0]),
    })
}

/// One point of the risk map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RiskScenario {
    /// Robot name.
    pub robot: String,
    /// Terrain name.
    pub terrain: String,
    /// Motion class.
    pub motion: MotionClass,
    /// Number of steps.
    pub n: usize,
    /// Median ρ.
    pub median_rho: f64,
    /// Median K_x, J.
    pub median_k_x_j: f64,
    /// 95 % ellipse (None with fewer than 3 steps).
    pub ellipse: Option<Ellipse95>,
}

/// Scenarios of one dataset from per-step (ρ, K_x, K_ut, K_uθ).
pub fn scenarios(robot: &str, terrain: &str, steps: &[(f64, f64, f64, f64)]) -> Vec<RiskScenario> {
    [MotionClass::Translation, MotionClass::Rotation]
        .into_iter()
        .map(|class| {
            let pts: Vec<(f64, f64)> = steps
                .iter()
                .filter(|s| MotionClass::of(s.2, s.3) == Some(class) && s.0.is_finite() && s.1.is_finite())
                .map(|s| (s.0, s.1))
                .collect();
            RiskScenario {
                robot: robot.to_string(),
                terrain: terrain.to_string(),
                motion: class,
                n: pts.len(),
                median_rho: median(&pts.iter().map(|p| p.0).collect::<Vec<_>>()),
                median_k_x_j: median(&pts.iter().map(|p| p.1).collect::<Vec<_>>()),
                ellipse: ellipse95(&pts),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::IdealDiffDrive;

    #[test]
    fn max_energy_at_a_vertex_by_hand() {
        // Warthog U in B: diamond |vx|/5 + |wz|/9.259 <= 1 cut at |wz| = 4. Vertices: (±5, 0),
        // (±2.84, ±4). K(5, 0) = 0.5 * 470 * 25 = 5875 J; K(2.84, 4) = 0.5*470*2.84^2 +
        // 0.5 * 268.19 * 16 = 1895 + 2145.5 = 4041 J. Max = 5875 J at (±5, 0).
        let space = CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.3,
                baseline_m: 1.08,
            },
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
            turn_scale: 1.0,
        };
        let mp = MassProperties {
            mass_kg: 470.0,
            izz_kg_m2: 470.0 * (2.13f64.powi(2) + 1.52f64.powi(2)) / 12.0,
        };
        let m = max_kinetic_energy(&space, &mp);
        assert!((m.k_max_j - 0.5 * 470.0 * 25.0).abs() < 1e-3, "{m:?}");
        assert!((m.at_vx_m_s.abs() - 5.0).abs() < 1e-3 && m.at_wz_rad_s.abs() < 1e-3);
        // (The wheel limit 16.6667 * 0.3 = 5.00001 m/s pokes past the 5 m/s user limit, so the
        // tip is clipped into two vertices at wz = ±3.7e-5 rad/s.)
        // Brute force over a dense grid inside U never exceeds it.
        for i in 0..=100 {
            for j in 0..=80 {
                let (vx, wz) = (-5.0 + 0.1 * i as f64, -4.0 + 0.1 * j as f64);
                if space.contains_body(BodyVelocity::new(vx, 0.0, wz)) {
                    assert!(mp.k_total_j(BodyVelocity::new(vx, 0.0, wz)) <= m.k_max_j + 1e-9);
                }
            }
        }
    }

    #[test]
    fn ellipse_of_axis_aligned_points() {
        // Points (±1, 0), (0, ±2): mean 0, covariance diag(2/3, 8/3); major axis along K.
        let e = ellipse95(&[(1.0, 0.0), (-1.0, 0.0), (0.0, 2.0), (0.0, -2.0)]).unwrap();
        assert!((e.semi_axes.0 - (CHI2_2DOF_95 * 8.0 / 3.0).sqrt()).abs() < 1e-9);
        assert!((e.semi_axes.1 - (CHI2_2DOF_95 * 2.0 / 3.0).sqrt()).abs() < 1e-9);
        assert!((e.angle_rad.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!((CHI2_2DOF_95 - (-2.0 * 0.05f64.ln())).abs() < 1e-12);
    }

    #[test]
    fn motion_classes() {
        assert_eq!(MotionClass::of(3.0, 1.0), Some(MotionClass::Translation));
        assert_eq!(MotionClass::of(1.0, 3.0), Some(MotionClass::Rotation));
        assert_eq!(MotionClass::of(0.0, 0.0), None);
    }
}
