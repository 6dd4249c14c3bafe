//! The spaces of the paper's Fig. 7: U (command space, from the nominal parameters), S (sampled
//! commands) and T (reached steady-state velocities), in the wheel frame W and the body frame B.
//!
//! "Area of T as % of U" is computed as `area(hull(T) ∩ U) / area(U)`: T is a finite point set,
//! its convex hull is the simplest reproducible stand-in for the paper's hand-drawn "visual
//! approximation", and intersecting with U keeps the figure a fraction of U (on asphalt the
//! realized speeds can exceed the nominal limits slightly, e.g. with a larger true wheel
//! radius). The hull overestimates a non-convex T; the unclipped hull ratio is reported too.

use super::stats::{quantile_sorted, sorted_finite};
use drive_sim_model::geometry::polygon_area;
use drive_sim_model::kinematics::CommandSpace;
use serde::{Deserialize, Serialize};

pub use drive_sim_model::geometry::{clip_convex, convex_hull};

/// Quantiles of the steady-state lateral speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LateralSpeed {
    /// Number of steps.
    pub n: usize,
    /// 2.5, 25, 50, 75, 97.5 % quantiles of vy, m/s.
    pub quantiles_m_s: [f64; 5],
    /// Largest |vy|, m/s.
    pub max_abs_m_s: f64,
    /// Standard deviation of vy, m/s.
    pub std_m_s: f64,
}

/// U, S and T in both frames, and the area of T relative to U.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spaces {
    /// U in B, (vx, wz) vertices, counter-clockwise.
    pub u_body: Vec<(f64, f64)>,
    /// U in W, (left, right) vertices, counter-clockwise.
    pub u_wheels: Vec<(f64, f64)>,
    /// S in B: commanded (vx, wz) of each analysed step.
    pub s_body: Vec<(f64, f64)>,
    /// S in W: commanded (left, right).
    pub s_wheels: Vec<(f64, f64)>,
    /// T in B: steady-state realized (vx, wz).
    pub t_body: Vec<(f64, f64)>,
    /// T in W: steady-state encoder (left, right).
    pub t_wheels: Vec<(f64, f64)>,
    /// Convex hull of T in B.
    pub t_body_hull: Vec<(f64, f64)>,
    /// Convex hull of T in W.
    pub t_wheels_hull: Vec<(f64, f64)>,
    /// Area of U in B, (m/s)(rad/s).
    pub u_area_body: f64,
    /// Area of U in W, (rad/s)².
    pub u_area_wheels: f64,
    /// 100 · area(hull(T) ∩ U) / area(U) in B.
    pub t_area_pct_body: f64,
    /// 100 · area(hull(T) ∩ U) / area(U) in W.
    pub t_area_pct_wheels: f64,
    /// 100 · area(hull(T)) / area(U) in B (not clipped).
    pub t_hull_pct_body: f64,
    /// 100 · area(hull(T)) / area(U) in W (not clipped).
    pub t_hull_pct_wheels: f64,
    /// Lateral-speed distribution.
    pub lateral: LateralSpeed,
}

/// Builds the spaces from per-step commanded and steady-state values.
/// `lateral_m_s` is the steady-state vy of each step.
pub fn spaces(
    space: &CommandSpace,
    s_body: Vec<(f64, f64)>,
    s_wheels: Vec<(f64, f64)>,
    t_body: Vec<(f64, f64)>,
    t_wheels: Vec<(f64, f64)>,
    lateral_m_s: &[f64],
) -> Spaces {
    let u_body = space.polygon_body();
    let u_wheels = space.polygon_wheels();
    let u_area_body = polygon_area(&u_body);
    let u_area_wheels = polygon_area(&u_wheels);
    let t_body_hull = convex_hull(&t_body);
    let t_wheels_hull = convex_hull(&t_wheels);
    let area = |p: &[(f64, f64)]| if p.len() >= 3 { polygon_area(p) } else { 0.0 };
    let pct = |a: f64, u: f64| 100.0 * a / u;
    let sorted = sorted_finite(lateral_m_s);
    let n = sorted.len();
    let mean = sorted.iter().sum::<f64>() / n.max(1) as f64;
    let std = if n > 1 {
        (sorted.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        f64::NAN
    };
    let lateral = LateralSpeed {
        n,
        quantiles_m_s: [0.025, 0.25, 0.5, 0.75, 0.975].map(|q| quantile_sorted(&sorted, q)),
        max_abs_m_s: sorted.iter().map(|v| v.abs()).fold(f64::NAN, f64::max),
        std_m_s: std,
    };
    Spaces {
        t_area_pct_body: pct(area(&clip_convex(&t_body_hull, &u_body)), u_area_body),
        t_area_pct_wheels: pct(area(&clip_convex(&t_wheels_hull, &u_wheels)), u_area_wheels),
        t_hull_pct_body: pct(area(&t_body_hull), u_area_body),
        t_hull_pct_wheels: pct(area(&t_wheels_hull), u_area_wheels),
        u_body,
        u_wheels,
        s_body,
        s_wheels,
        t_body,
        t_wheels,
        t_body_hull,
        t_wheels_hull,
        u_area_body,
        u_area_wheels,
        lateral,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_and_clip_by_hand() {
        // Unit square corners plus interior points: hull is the square, area 1.
        let pts = [
            (0.0, 0.0),
            (1.0, 0.0),
            (0.5, 0.5),
            (1.0, 1.0),
            (0.0, 1.0),
            (0.2, 0.7),
            (0.5, 0.0),
        ];
        let h = convex_hull(&pts);
        assert_eq!(h.len(), 4);
        assert!((polygon_area(&h) - 1.0).abs() < 1e-12);
        // Clip by the triangle (0,0), (2,0), (0,2): the square minus nothing (x + y <= 2 holds).
        let tri = [(0.0, 0.0), (2.0, 0.0), (0.0, 2.0)];
        assert!((polygon_area(&clip_convex(&h, &tri)) - 1.0).abs() < 1e-12);
        // Clip by (0,0), (1,0), (0,1): half the square.
        let tri = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];
        assert!((polygon_area(&clip_convex(&h, &tri)) - 0.5).abs() < 1e-12);
    }
}
