//! Ideal differential drive (IDD) kinematics and the command space U.
//!
//! Conventions (ROS REP 103): body frame x forward, y left, z up; yaw counter-clockwise
//! positive; positive wheel speed drives that side forward. SI units everywhere.

use crate::geometry::{clip_half_plane, ensure_ccw, polygon_area};
use serde::{Deserialize, Serialize};

/// Wheel speeds of the two sides of a skid-steering robot, in rad/s (the wheel frame W).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WheelSpeeds {
    /// Left side wheel speed, rad/s.
    pub left_rad_s: f64,
    /// Right side wheel speed, rad/s.
    pub right_rad_s: f64,
}

impl WheelSpeeds {
    /// Builds a pair from left and right wheel speeds (rad/s).
    #[inline]
    pub const fn new(left_rad_s: f64, right_rad_s: f64) -> Self {
        Self {
            left_rad_s,
            right_rad_s,
        }
    }
    /// Component-wise difference `self - other`.
    #[inline]
    pub fn minus(self, other: Self) -> Self {
        Self::new(
            self.left_rad_s - other.left_rad_s,
            self.right_rad_s - other.right_rad_s,
        )
    }
    /// True if both components are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.left_rad_s.is_finite() && self.right_rad_s.is_finite()
    }
}

/// Planar body velocity in the body frame B: longitudinal, lateral (m/s) and yaw rate (rad/s).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BodyVelocity {
    /// Longitudinal speed (x forward), m/s.
    pub vx_m_s: f64,
    /// Lateral speed (y left), m/s.
    pub vy_m_s: f64,
    /// Yaw rate (counter-clockwise positive), rad/s.
    pub wz_rad_s: f64,
}

impl BodyVelocity {
    /// Builds a body velocity from its three components.
    #[inline]
    pub const fn new(vx_m_s: f64, vy_m_s: f64, wz_rad_s: f64) -> Self {
        Self {
            vx_m_s,
            vy_m_s,
            wz_rad_s,
        }
    }
    /// Component-wise difference `self - other`.
    #[inline]
    pub fn minus(self, other: Self) -> Self {
        Self::new(
            self.vx_m_s - other.vx_m_s,
            self.vy_m_s - other.vy_m_s,
            self.wz_rad_s - other.wz_rad_s,
        )
    }
    /// True if all components are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.vx_m_s.is_finite() && self.vy_m_s.is_finite() && self.wz_rad_s.is_finite()
    }
}

/// The ideal differential-drive model: `vx = r (wl + wr) / 2`, `vy = 0`, `wz = r (wr - wl) / b`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IdealDiffDrive {
    /// Wheel radius r, m.
    pub wheel_radius_m: f64,
    /// Baseline b (distance between the left and right wheel contact lines), m.
    pub baseline_m: f64,
}

impl IdealDiffDrive {
    /// Body velocity that the IDD predicts for a wheel-speed command.
    #[inline]
    pub fn body_from_wheels(&self, w: WheelSpeeds) -> BodyVelocity {
        let r = self.wheel_radius_m;
        BodyVelocity::new(
            r * (w.left_rad_s + w.right_rad_s) / 2.0,
            0.0,
            r * (w.right_rad_s - w.left_rad_s) / self.baseline_m,
        )
    }
    /// Wheel speeds that realize `vx`, `wz` under the IDD (the inverse of M; `vy` is ignored).
    #[inline]
    pub fn wheels_from_body(&self, v: BodyVelocity) -> WheelSpeeds {
        let r = self.wheel_radius_m;
        let half = v.wz_rad_s * self.baseline_m / 2.0;
        WheelSpeeds::new((v.vx_m_s - half) / r, (v.vx_m_s + half) / r)
    }
}

/// The command space U: wheel limits (a square in W) intersected with the user's body limits
/// (a rectangle in B), mapped through the IDD.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CommandSpace {
    /// Kinematics used to move between W and B.
    pub idd: IdealDiffDrive,
    /// Wheel speed limit, `|w| <= max_wheel_rad_s`.
    pub max_wheel_rad_s: f64,
    /// User limit on `|vx|`, m/s.
    pub max_lin_m_s: f64,
    /// User limit on `|wz|`, rad/s.
    pub max_ang_rad_s: f64,
}

impl CommandSpace {
    /// Tolerance used by membership tests, so that vertices computed in floating point count as inside.
    const EPS: f64 = 1e-9;

    /// True if the wheel command lies in U.
    #[inline]
    pub fn contains_wheels(&self, w: WheelSpeeds) -> bool {
        let b = self.idd.body_from_wheels(w);
        w.left_rad_s.abs() <= self.max_wheel_rad_s + Self::EPS
            && w.right_rad_s.abs() <= self.max_wheel_rad_s + Self::EPS
            && b.vx_m_s.abs() <= self.max_lin_m_s + Self::EPS
            && b.wz_rad_s.abs() <= self.max_ang_rad_s + Self::EPS
    }
    /// True if the body command (vx, wz) lies in U.
    #[inline]
    pub fn contains_body(&self, v: BodyVelocity) -> bool {
        self.contains_wheels(self.idd.wheels_from_body(v))
    }
    /// Vertices (counter-clockwise) of U in the body frame, as (vx, wz) pairs.
    ///
    /// U is the intersection of two convex polygons (the wheel square mapped to a diamond,
    /// and the user rectangle), computed by clipping.
    pub fn polygon_body(&self) -> Vec<(f64, f64)> {
        let r = self.idd.wheel_radius_m;
        let b = self.idd.baseline_m;
        let wm = self.max_wheel_rad_s;
        // Wheel square corners in order (l, r): (-,-), (+,-), (+,+), (-,+) mapped to (vx, wz).
        let to_b = |l: f64, rr: f64| (r * (l + rr) / 2.0, r * (rr - l) / b);
        let mut poly = vec![to_b(-wm, -wm), to_b(wm, -wm), to_b(wm, wm), to_b(-wm, wm)];
        let (vm, am) = (self.max_lin_m_s, self.max_ang_rad_s);
        // Half-planes a*vx + c*wz <= d.
        for (a, c, d) in [(1.0, 0.0, vm), (-1.0, 0.0, vm), (0.0, 1.0, am), (0.0, -1.0, am)] {
            poly = clip_half_plane(&poly, a, c, d);
        }
        ensure_ccw(poly)
    }
    /// Vertices (counter-clockwise) of U in the wheel frame, as (left, right) pairs.
    pub fn polygon_wheels(&self) -> Vec<(f64, f64)> {
        let poly = self
            .polygon_body()
            .into_iter()
            .map(|(vx, wz)| {
                let w = self.idd.wheels_from_body(BodyVelocity::new(vx, 0.0, wz));
                (w.left_rad_s, w.right_rad_s)
            })
            .collect();
        ensure_ccw(poly)
    }
    /// Area of U in the body frame, (m/s)·(rad/s).
    pub fn area_body(&self) -> f64 {
        polygon_area(&self.polygon_body())
    }
    /// Area of U in the wheel frame, (rad/s)².
    pub fn area_wheels(&self) -> f64 {
        polygon_area(&self.polygon_wheels())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warthog() -> CommandSpace {
        CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.3,
                baseline_m: 1.08,
            },
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
        }
    }

    #[test]
    fn idd_by_hand() {
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        // wl = 2, wr = 4: vx = 0.3*3 = 0.9, wz = 0.3*2/1.08 = 0.5555...
        let v = idd.body_from_wheels(WheelSpeeds::new(2.0, 4.0));
        assert!((v.vx_m_s - 0.9).abs() < 1e-12);
        assert!((v.wz_rad_s - 0.6 / 1.08).abs() < 1e-12);
        assert_eq!(v.vy_m_s, 0.0);
        let w = idd.wheels_from_body(v);
        assert!((w.left_rad_s - 2.0).abs() < 1e-12 && (w.right_rad_s - 4.0).abs() < 1e-12);
    }

    #[test]
    fn warthog_space_by_hand() {
        // Wheel limit 16.6667 rad/s * 0.3 m = 5.0 m/s: the diamond's vx vertex equals the user
        // vx limit. Its wz vertex is 2*5.0/1.08 = 9.26 rad/s, cut by |wz| <= 4. In B the space is
        // the diamond |vx|/5 + |wz|/9.259 <= 1 cut at |wz| = 4. At wz = 4: |vx| <= 5*(1-4/9.259)
        // = 2.84 m/s. Area = diamond area minus two triangles above |wz| = 4:
        // diamond = 2*5*9.259 = 92.59; each cap: base 2*2.84 = 5.68 over height 5.259 -> 14.94.
        let s = warthog();
        let wz_v = 2.0 * 16.6667 * 0.3 / 1.08;
        let vx_v = 16.6667 * 0.3;
        let diamond = 2.0 * vx_v * wz_v;
        let half_base = vx_v * (1.0 - 4.0 / wz_v);
        let cap = half_base * (wz_v - 4.0);
        let expected = diamond - 2.0 * cap;
        assert!(
            (s.area_body() - expected).abs() < 1e-6,
            "{} vs {}",
            s.area_body(),
            expected
        );
        assert!(s.contains_body(BodyVelocity::new(0.0, 0.0, 4.0)));
        assert!(!s.contains_body(BodyVelocity::new(0.0, 0.0, 4.1)));
        assert!(s.contains_body(BodyVelocity::new(2.8, 0.0, 4.0)));
        assert!(!s.contains_body(BodyVelocity::new(2.9, 0.0, 4.0)));
        // Jacobian of the map W -> B is r^2 / b: areas scale by it.
        let jac = 0.3 * 0.3 / 1.08;
        assert!((s.area_wheels() * jac - s.area_body()).abs() < 1e-6);
    }

    #[test]
    fn husky_space_is_user_limited() {
        // Husky: wheel limit 6.06 rad/s * 0.165 = 1.0 m/s; wz vertex 2*1.0/0.555 = 3.6 rad/s,
        // cut by 2 rad/s.
        let s = CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.165,
                baseline_m: 0.555,
            },
            max_wheel_rad_s: 6.06,
            max_lin_m_s: 1.0,
            max_ang_rad_s: 2.0,
        };
        let poly = s.polygon_body();
        let max_wz = poly.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert!((max_wz - 2.0).abs() < 1e-9);
        assert!(s.contains_wheels(WheelSpeeds::new(6.06, 6.06)));
        assert!(!s.contains_wheels(WheelSpeeds::new(-6.06, 6.06)));
    }
}
