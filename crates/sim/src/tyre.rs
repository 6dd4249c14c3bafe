//! The wheel-terrain force model: combined-slip friction (longitudinal slip ratio and lateral
//! slip angle on a friction ellipse, rising to a peak then falling to the sliding value),
//! rolling resistance, churning drag and bulldozing.
//!
//! The shape is Burckhardt-like but algebraic (cheap and smooth): with the normalised slip
//! `σ = |(s / s_peak, tan α / tan α_peak)|`, the coefficient is `μ_peak (2σ - σ²)` up to the peak
//! (`σ = 1`) and `μ_slide + (μ_peak - μ_slide) / (1 + ((σ - 1) / 2)²)` beyond. The force points
//! against the normalised slip vector, scaled by each direction's coefficient (friction ellipse).

use drive_sim_model::terrain::Terrain;

/// Speed below which slip ratio and slip angle are regularised, m/s. Below it the friction
/// force is proportional to the slip velocity (a stiff damper that the implicit solver
/// handles), which keeps rest at rest without a stick-slip switch. Small enough that the
/// creep on a 2 % slope stays below 0.1 mm/s (see tests).
pub const REG_SPEED_M_S: f64 = 0.01;

/// Terrain coefficients the force model uses, with the effects already applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TyreParams {
    /// Peak / sliding longitudinal friction coefficients.
    pub mu_x_peak: f64,
    /// Sliding longitudinal friction coefficient.
    pub mu_x_slide: f64,
    /// Peak lateral friction coefficient.
    pub mu_y_peak: f64,
    /// Sliding lateral friction coefficient.
    pub mu_y_slide: f64,
    /// Slip ratio at the peak.
    pub slip_ratio_peak: f64,
    /// tan of the slip angle at the peak.
    pub tan_slip_angle_peak: f64,
    /// Rolling resistance coefficient.
    pub rolling: f64,
    /// Churning drag, s/m.
    pub churning_s_m: f64,
    /// Bulldozing force of one wheel against longitudinal motion, N.
    pub bulldoze_long_n: f64,
    /// Bulldozing force of one wheel against lateral motion, N.
    pub bulldoze_lat_n: f64,
}

impl TyreParams {
    /// Coefficients of `terrain` for a wheel of `radius_m` and `width_m`, with the lateral
    /// friction scaled by `lateral_scale` (the turning-resistance effect).
    pub fn new(terrain: &Terrain, radius_m: f64, width_m: f64, lateral_scale: f64) -> Self {
        let f = &terrain.friction;
        let r = &terrain.resistance;
        let z = r.sinkage_m.min(radius_m);
        // Chord of the sunk arc: the length of the tyre's side face in the soil.
        let chord_m = 2.0 * (2.0 * radius_m * z - z * z).max(0.0).sqrt();
        Self {
            mu_x_peak: f.peak_longitudinal,
            mu_x_slide: f.sliding_longitudinal,
            mu_y_peak: f.peak_lateral * lateral_scale,
            mu_y_slide: f.sliding_lateral * lateral_scale,
            slip_ratio_peak: f.peak_slip_ratio,
            tan_slip_angle_peak: f.peak_slip_angle_rad.tan(),
            rolling: r.rolling_coefficient,
            churning_s_m: r.churning_drag_s_m,
            bulldoze_long_n: r.bulldozing_pressure_pa * width_m * z,
            bulldoze_lat_n: r.bulldozing_pressure_pa * chord_m * z,
        }
    }
}

/// Friction coefficient over normalised slip, divided by the normalised slip (finite at 0).
fn mu_over_sigma(peak: f64, slide: f64, sigma: f64) -> f64 {
    if sigma <= 1.0 {
        peak * (2.0 - sigma)
    } else {
        let d = 0.5 * (sigma - 1.0);
        (slide + (peak - slide) / (1.0 + d * d)) / sigma
    }
}

/// Saturating sign, linear below [`REG_SPEED_M_S`].
pub fn reg_sign(v: f64) -> f64 {
    (v / REG_SPEED_M_S).clamp(-1.0, 1.0)
}

/// Forces of one contact.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactForce {
    /// Force on the chassis along the heading, N.
    pub fx_n: f64,
    /// Force on the chassis across the heading (left positive), N.
    pub fy_n: f64,
    /// Torque the ground opposes to the wheel's spin (the motor must supply it), N·m.
    pub reaction_nm: f64,
}

/// Forces at one contact with normal load `load_n`, contact-point ground velocity (`vx`, `vy`)
/// in the heading frame, wheel spin `omega_rad_s` and effective radius `radius_m`.
/// `lateral_deflection`: `Some(tan α)` from the relaxation state when the torsion effect is on,
/// replacing the quasi-static slip angle.
pub fn contact_force(
    p: &TyreParams,
    load_n: f64,
    vx: f64,
    vy: f64,
    omega_rad_s: f64,
    radius_m: f64,
    lateral_deflection: Option<f64>,
) -> ContactForce {
    if load_n <= 0.0 {
        return ContactForce::default();
    }
    let rim = omega_rad_s * radius_m;
    // Theoretical slips with a common denominator (brush model): their ratio is the direction
    // of the slip velocity, so a sliding tyre pushes against its sliding velocity (Coulomb),
    // which is what lets a skid-steer turn: a spinning wheel's lateral grip collapses.
    let den = rim.abs().max(vx.abs()).max(REG_SPEED_M_S);
    let sx = (rim - vx) / den;
    let sy = match lateral_deflection {
        Some(tan_a) => -tan_a,
        None => -vy / den,
    };
    // sqrt of squares, not hypot: no overflow is possible here and hypot is slow.
    let s = (sx * sx + sy * sy).sqrt();
    if s < 1e-12 && p.bulldoze_long_n == 0.0 {
        return ContactForce {
            reaction_nm: p.rolling * load_n * radius_m * reg_sign(rim)
                + p.churning_s_m * load_n * radius_m * rim,
            ..Default::default()
        };
    }
    // Normalised slip: 1 on the friction ellipse's peak.
    let (nx, ny) = (sx / p.slip_ratio_peak, sy / p.tan_slip_angle_peak);
    let sigma = (nx * nx + ny * ny).sqrt();
    let (fx, fy) = if s < 1e-12 {
        (0.0, 0.0)
    } else {
        let k = load_n * sigma / s;
        (
            k * mu_over_sigma(p.mu_x_peak, p.mu_x_slide, sigma) * sx,
            k * mu_over_sigma(p.mu_y_peak, p.mu_y_slide, sigma) * sy,
        )
    };
    let bx = -p.bulldoze_long_n * reg_sign(vx);
    let by = -p.bulldoze_lat_n * reg_sign(vy);
    let reaction = radius_m * fx
        + p.rolling * load_n * radius_m * reg_sign(rim)
        + p.churning_s_m * load_n * radius_m * rim;
    ContactForce {
        fx_n: fx + bx,
        fy_n: fy + by,
        reaction_nm: reaction,
    }
}

/// Derivative of [`reg_sign`].
fn reg_sign_slope(v: f64) -> f64 {
    if v.abs() < REG_SPEED_M_S {
        1.0 / REG_SPEED_M_S
    } else {
        0.0
    }
}

/// Friction coefficient over normalised slip `sigma` and its derivative (the curve of the
/// module docs; [`mu_over_sigma`] times `sigma`).
fn mu_and_slope(peak: f64, slide: f64, sigma: f64) -> (f64, f64) {
    if sigma <= 1.0 {
        (peak * (2.0 * sigma - sigma * sigma), peak * (2.0 - 2.0 * sigma))
    } else {
        let d = 0.5 * (sigma - 1.0);
        let q = 1.0 + d * d;
        (slide + (peak - slide) / q, -(peak - slide) * d / (q * q))
    }
}

/// Partial derivatives of a [`ContactForce`]'s three components (rows: `fx_n`, `fy_n`,
/// `reaction_nm`) with respect to the contact's ground velocity and wheel spin (columns: `vx`,
/// `vy`, `omega_rad_s`).
pub type ContactJacobian = [[f64; 3]; 3];

/// [`contact_force`] and its exact partial derivatives, for the Newton solve of a physics step
/// (one evaluation instead of a finite-difference column per unknown). `lateral_deflection` is
/// `Some((tan α, d tan α / d vy))` when the torsion effect is on.
pub fn contact_force_and_jacobian(
    p: &TyreParams,
    load_n: f64,
    vx: f64,
    vy: f64,
    omega_rad_s: f64,
    radius_m: f64,
    lateral_deflection: Option<(f64, f64)>,
) -> (ContactForce, ContactJacobian) {
    let mut jac = [[0.0; 3]; 3];
    if load_n <= 0.0 {
        return (ContactForce::default(), jac);
    }
    let rim = omega_rad_s * radius_m;
    // Same expressions as `contact_force`, each followed by its gradient over (vx, vy, omega).
    let (a_rim, a_vx) = (rim.abs(), vx.abs());
    let den = a_rim.max(a_vx).max(REG_SPEED_M_S);
    let d_den = if den == a_rim && a_rim >= a_vx && a_rim > REG_SPEED_M_S {
        [0.0, 0.0, rim.signum() * radius_m]
    } else if den == a_vx && a_vx > REG_SPEED_M_S {
        [vx.signum(), 0.0, 0.0]
    } else {
        [0.0; 3]
    };
    let sx = (rim - vx) / den;
    let d_sx = [
        (-1.0 - sx * d_den[0]) / den,
        -sx * d_den[1] / den,
        (radius_m - sx * d_den[2]) / den,
    ];
    let (sy, d_sy) = match lateral_deflection {
        Some((tan_a, d_tan_a_d_vy)) => (-tan_a, [0.0, -d_tan_a_d_vy, 0.0]),
        None => {
            let sy = -vy / den;
            (
                sy,
                [
                    -sy * d_den[0] / den,
                    (-1.0 - sy * d_den[1]) / den,
                    -sy * d_den[2] / den,
                ],
            )
        }
    };
    let roll_slope = p.rolling * load_n * radius_m * reg_sign_slope(rim) * radius_m
        + p.churning_s_m * load_n * radius_m * radius_m;
    let s = (sx * sx + sy * sy).sqrt();
    if s < 1e-12 && p.bulldoze_long_n == 0.0 {
        jac[2][2] = roll_slope;
        return (
            ContactForce {
                reaction_nm: p.rolling * load_n * radius_m * reg_sign(rim)
                    + p.churning_s_m * load_n * radius_m * rim,
                ..Default::default()
            },
            jac,
        );
    }
    let (nx, ny) = (sx / p.slip_ratio_peak, sy / p.tan_slip_angle_peak);
    let sigma = (nx * nx + ny * ny).sqrt();
    let (fx, fy) = if s < 1e-12 {
        (0.0, 0.0)
    } else {
        // fx = N μx(σ) sx / s, fy = N μy(σ) sy / s.
        let (mux, dmux) = mu_and_slope(p.mu_x_peak, p.mu_x_slide, sigma);
        let (muy, dmuy) = mu_and_slope(p.mu_y_peak, p.mu_y_slide, sigma);
        let (ux, uy) = (sx / s, sy / s);
        for k in 0..3 {
            let ds = ux * d_sx[k] + uy * d_sy[k];
            let dsigma = (nx * d_sx[k] / p.slip_ratio_peak + ny * d_sy[k] / p.tan_slip_angle_peak) / sigma;
            let dux = (d_sx[k] - ux * ds) / s;
            let duy = (d_sy[k] - uy * ds) / s;
            jac[0][k] = load_n * (dmux * dsigma * ux + mux * dux);
            jac[1][k] = load_n * (dmuy * dsigma * uy + muy * duy);
        }
        // Same association as `contact_force`, for the same rounding.
        let k = load_n * sigma / s;
        (
            k * mu_over_sigma(p.mu_x_peak, p.mu_x_slide, sigma) * sx,
            k * mu_over_sigma(p.mu_y_peak, p.mu_y_slide, sigma) * sy,
        )
    };
    let bx = -p.bulldoze_long_n * reg_sign(vx);
    let by = -p.bulldoze_lat_n * reg_sign(vy);
    let reaction = radius_m * fx
        + p.rolling * load_n * radius_m * reg_sign(rim)
        + p.churning_s_m * load_n * radius_m * rim;
    jac[2] = jac[0].map(|d| radius_m * d);
    jac[2][2] += roll_slope;
    jac[0][0] -= p.bulldoze_long_n * reg_sign_slope(vx);
    jac[1][1] -= p.bulldoze_lat_n * reg_sign_slope(vy);
    (
        ContactForce {
            fx_n: fx + bx,
            fy_n: fy + by,
            reaction_nm: reaction,
        },
        jac,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> TyreParams {
        let (t, _) = Terrain::resolve("asphalt").unwrap();
        TyreParams::new(&t, 0.3, 0.3, 1.0)
    }

    #[test]
    fn curve_peaks_at_the_peak_slip_and_falls_to_sliding() {
        let p = params();
        let n = 1000.0;
        // Free body at 2 m/s, wheel slipping at the peak ratio: rim = v / (1 - s).
        let v = 2.0;
        let at = |s: f64| contact_force(&p, n, v, 0.0, v / (1.0 - s) / 0.3, 0.3, None).fx_n;
        let peak = at(p.slip_ratio_peak);
        assert!((peak - p.mu_x_peak * n).abs() < 1e-6, "{peak}");
        assert!(at(0.5 * p.slip_ratio_peak) < peak && at(2.0 * p.slip_ratio_peak) < peak);
        // Locked wheel sliding: s = -1 -> sigma = 1/0.15 = 6.67, far beyond the peak.
        let locked = contact_force(&p, n, v, 0.0, 0.0, 0.3, None).fx_n;
        let d = 0.5 * (1.0 / p.slip_ratio_peak - 1.0);
        let expect = -n * (p.mu_x_slide + (p.mu_x_peak - p.mu_x_slide) / (1.0 + d * d));
        assert!((locked - expect).abs() < 1e-9, "{locked} vs {expect}");
        // Pure rolling: no friction force, rolling resistance on the wheel only.
        let roll = contact_force(&p, n, v, 0.0, v / 0.3, 0.3, None);
        assert_eq!(roll.fx_n, 0.0);
        assert!((roll.reaction_nm - p.rolling * n * 0.3).abs() < 1e-12);
    }

    #[test]
    fn combined_slip_stays_inside_the_friction_circle() {
        let p = params();
        for (rim, vy) in [(3.0, 0.5), (0.0, 2.0), (5.0, -5.0), (-1.0, 0.1)] {
            let f = contact_force(&p, 1000.0, 1.0, vy, rim / 0.3, 0.3, None);
            let mu = f.fx_n.hypot(f.fy_n) / 1000.0;
            assert!(mu <= p.mu_x_peak + 1e-9, "{mu} at {rim} {vy}");
            assert!(f.fy_n * vy <= 0.0, "lateral force must oppose lateral slip");
        }
        assert_eq!(
            contact_force(&p, 0.0, 1.0, 1.0, 9.0, 0.3, None),
            ContactForce::default()
        );
    }

    #[test]
    fn jacobian_matches_central_differences_and_forces_match_exactly() {
        let mut rng_state = 12345u64;
        let mut rnd = |lo: f64, hi: f64| {
            // A small LCG: the test needs spread, not quality.
            rng_state = rng_state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((rng_state >> 11) as f64 / (1u64 << 53) as f64)
        };
        for terrain in ["asphalt", "ice", "mud", "sand"] {
            let (t, _) = Terrain::resolve(terrain).unwrap();
            let p = TyreParams::new(&t, 0.3, 0.3, 0.8);
            let mut checked = 0;
            for _ in 0..400 {
                let (n, vx, vy, w) = (rnd(0.0, 3000.0), rnd(-4.0, 4.0), rnd(-2.0, 2.0), rnd(-15.0, 15.0));
                let torsion = (rnd(0.0, 1.0) < 0.3).then(|| (rnd(-0.3, 0.3), rnd(0.0, 2.0)));
                let lateral = torsion.map(|(t, _)| t);
                let (f, j) = contact_force_and_jacobian(&p, n, vx, vy, w, 0.3, torsion);
                assert_eq!(f, contact_force(&p, n, vx, vy, w, 0.3, lateral));
                // Central differences, skipping points near a kink (max, clamp, peak).
                let rim = w * 0.3;
                let near_kink = (rim.abs() - vx.abs()).abs() < 1e-3
                    || rim.abs() < 0.02
                    || vx.abs() < 0.02
                    || vy.abs() < 0.02;
                if near_kink {
                    continue;
                }
                let h = 1e-6;
                for (k, bump) in [[h, 0.0, 0.0], [0.0, h, 0.0], [0.0, 0.0, h]].iter().enumerate() {
                    let eval = |sign: f64| {
                        let lat = torsion.map(|(t, d)| t + sign * d * bump[1]);
                        contact_force(
                            &p,
                            n,
                            vx + sign * bump[0],
                            vy + sign * bump[1],
                            w + sign * bump[2],
                            0.3,
                            lat,
                        )
                    };
                    let (fp, fm) = (eval(1.0), eval(-1.0));
                    let fd = [
                        (fp.fx_n - fm.fx_n) / (2.0 * h),
                        (fp.fy_n - fm.fy_n) / (2.0 * h),
                        (fp.reaction_nm - fm.reaction_nm) / (2.0 * h),
                    ];
                    for row in 0..3 {
                        let scale = 1.0 + fd[row].abs().max(j[row][k].abs());
                        assert!(
                            (fd[row] - j[row][k]).abs() < 1e-4 * scale,
                            "{terrain}: d[{row}]/d[{k}] analytic {} vs {} at n {n} vx {vx} vy {vy} w {w} {torsion:?}",
                            j[row][k],
                            fd[row]
                        );
                    }
                }
                checked += 1;
            }
            assert!(checked > 200, "{terrain}: {checked}");
        }
    }
}
