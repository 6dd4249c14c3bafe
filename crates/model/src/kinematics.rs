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
    /// The command's quadrant in the body frame.
    #[inline]
    pub fn quadrant(self) -> Quadrant {
        Quadrant {
            forward: self.left_rad_s + self.right_rad_s >= 0.0,
            left: self.right_rad_s - self.left_rad_s >= 0.0,
        }
    }
}

/// A command's quadrant in the body frame: forward (`vx >= 0`) or backward, turning left
/// (`wz >= 0`) or right. Wheel speeds give it without the robot's geometry: `vx` has the sign
/// of `left + right`, `wz` the sign of `right - left`. A skid-steering robot's slips change
/// sign with it, so a run's medians are its mix of quadrants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Quadrant {
    /// `vx >= 0`.
    pub forward: bool,
    /// `wz >= 0`.
    pub left: bool,
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
///
/// DRIVE draws a command uniformly in a square of wheel speeds and keeps it if its body
/// velocity is within the user's limits. Between that draw and the command the robot records,
/// something may scale the turning (a velocity controller converting the body command with a
/// wider wheel separation): the recorded commands then fill the square only once their
/// differential mode is divided by [`turn_scale`](Self::turn_scale). With a common mode
/// `s = (l + r) / 2` and a differential mode `d = (r − l) / 2`, U holds the commands with
/// `|s| + |d| / turn_scale <= max_wheel_rad_s` (the square `|l|, |r| <= max_wheel_rad_s` when
/// the scale is 1) and the body velocity within the user's limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CommandSpace {
    /// Kinematics used to move between W and B.
    pub idd: IdealDiffDrive,
    /// Wheel speed limit, `|w| <= max_wheel_rad_s` (of the draw, before the turn scale).
    pub max_wheel_rad_s: f64,
    /// User limit on `|vx|`, m/s.
    pub max_lin_m_s: f64,
    /// User limit on `|wz|`, rad/s.
    pub max_ang_rad_s: f64,
    /// How much more the commands turn than the wheel square they were drawn in, `-`: 1 when
    /// the recorded commands are the draws themselves.
    #[serde(default = "unit_turn_scale")]
    pub turn_scale: f64,
}

/// The default turn scale, 1 (serde's default for files that do not declare one).
pub(crate) fn unit_turn_scale() -> f64 {
    1.0
}

/// The turn scales a robot file or a log may declare, `-`: a factor of ten either way.
pub const TURN_SCALE: (f64, f64) = (0.1, 10.0);

impl CommandSpace {
    /// Tolerance used by membership tests, so that vertices computed in floating point count as inside.
    const EPS: f64 = 1e-9;

    /// True if the wheel command lies in U.
    #[inline]
    pub fn contains_wheels(&self, w: WheelSpeeds) -> bool {
        let b = self.idd.body_from_wheels(w);
        self.drawn_wheel_rad_s(w) <= self.max_wheel_rad_s + Self::EPS
            && b.vx_m_s.abs() <= self.max_lin_m_s + Self::EPS
            && b.wz_rad_s.abs() <= self.max_ang_rad_s + Self::EPS
    }
    /// The larger wheel speed of the draw a command stands for, `|s| + |d| / turn_scale`
    /// (`max(|l|, |r|)` at scale 1), rad/s.
    #[inline]
    pub fn drawn_wheel_rad_s(&self, w: WheelSpeeds) -> f64 {
        // At scale 1 the square's own test: |s| + |d| is max(|l|, |r|) but for the last bit.
        if self.turn_scale == 1.0 {
            return w.left_rad_s.abs().max(w.right_rad_s.abs());
        }
        let s = (w.left_rad_s + w.right_rad_s) / 2.0;
        let d = (w.right_rad_s - w.left_rad_s) / 2.0;
        s.abs() + d.abs() / self.turn_scale
    }
    /// The largest wheel speed a command in U can have, rad/s: the bound of the square a
    /// sampler draws from by rejection (`max_wheel_rad_s` times the turn scale when above 1).
    pub fn wheel_bound_rad_s(&self) -> f64 {
        self.max_wheel_rad_s * self.turn_scale.max(1.0)
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
        // The drawn square's corners (common mode ±wm or differential mode ±wm · scale) in
        // (vx, wz): a diamond.
        let vx = r * wm;
        let wz = 2.0 * r * wm * self.turn_scale / b;
        let mut poly = vec![(-vx, 0.0), (0.0, -wz), (vx, 0.0), (0.0, wz)];
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

    /// The U most likely to have drawn `commands` among those of this one's form whose limits
    /// are none below this one's: the user's limits raised to the commands' reach, and the
    /// wheel square and turn scale that hold every command in the least area.
    ///
    /// DRIVE draws uniformly in U, so the likelihood of n commands is `area⁻ⁿ` for any U that
    /// holds them all: the smallest such U is the maximum-likelihood one. A turn scale other
    /// than this U's (1 unless declared) is an extra parameter, taken only when its gain in
    /// log-likelihood, `n ln(area at this U's scale / area)`, exceeds
    /// [`TURN_SCALE_EVIDENCE_NATS`]. Limits are rounded
    /// up to 0.1 and the scale to 0.01 (between 0.2 and 5), so the U returned holds every
    /// command. Returns `self` unchanged (`gain_nats` 0) when it already holds them all.
    pub fn fitted_to(&self, commands: &[WheelSpeeds]) -> CommandSpaceFit {
        if commands.iter().all(|c| self.contains_wheels(*c)) {
            return CommandSpaceFit {
                space: *self,
                at_declared_scale: *self,
                gain_nats: 0.0,
            };
        }
        let up = |x: f64| (x * 10.0).ceil() / 10.0;
        let mut base = *self;
        for c in commands {
            let b = self.idd.body_from_wheels(*c);
            base.max_lin_m_s = base.max_lin_m_s.max(up(b.vx_m_s.abs()));
            base.max_ang_rad_s = base.max_ang_rad_s.max(up(b.wz_rad_s.abs()));
        }
        let holding = |turn_scale: f64| {
            let mut u = CommandSpace { turn_scale, ..base };
            let reach = commands
                .iter()
                .map(|c| u.drawn_wheel_rad_s(*c))
                .fold(0.0, f64::max);
            u.max_wheel_rad_s = self.max_wheel_rad_s.max(up(reach));
            u
        };
        // The configured turn scale (1 unless declared) is the null: another is taken only on
        // strong evidence.
        let declared = holding(self.turn_scale);
        let declared_area = declared.area_body();
        let (least, least_area) = (20..=500)
            .map(|i| holding(f64::from(i) / 100.0))
            .map(|u| (u, u.area_body()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((declared, declared_area));
        let gain_nats = commands.len() as f64 * (declared_area / least_area).ln();
        let taken = gain_nats > TURN_SCALE_EVIDENCE_NATS;
        CommandSpaceFit {
            space: if taken { least } else { declared },
            at_declared_scale: declared,
            gain_nats,
        }
    }
}

/// The log-likelihood gain (nats) a turn scale other than the configured one must bring to be
/// fitted: a likelihood ratio above e¹⁰ ≈ 22,000. Commands drawn uniformly at scale 1 gain at
/// most 5.2 nats from a fitted scale over 300 runs of 100 and 201 commands in the Warthog's and
/// the Husky's U (test `fitted_to_finds_a_turn_scale`, which prints it); husky_2023's 201
/// commands gain 88 (the note `drive-sim twin` prints at its start).
pub const TURN_SCALE_EVIDENCE_NATS: f64 = 10.0;

/// What [`CommandSpace::fitted_to`] returns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandSpaceFit {
    /// The fitted U.
    pub space: CommandSpace,
    /// The least U at the configured turn scale that holds the commands (the null the
    /// fitted scale was weighed against; `space` when that scale is kept).
    pub at_declared_scale: CommandSpace,
    /// The log-likelihood gain of the least-area turn scale over the configured one, nats,
    /// whether it was taken (above [`TURN_SCALE_EVIDENCE_NATS`]) or not; 0 when the configured
    /// U already holds the commands.
    pub gain_nats: f64,
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
            turn_scale: 1.0,
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
        let s = husky_metadata();
        let poly = s.polygon_body();
        let max_wz = poly.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert!((max_wz - 2.0).abs() < 1e-9);
        assert!(s.contains_wheels(WheelSpeeds::new(6.06, 6.06)));
        assert!(!s.contains_wheels(WheelSpeeds::new(-6.06, 6.06)));
    }

    /// Uniform draws in a U by rejection, from a SplitMix64 stream written here.
    fn draws(u: &CommandSpace, n: usize, seed: u64) -> Vec<WheelSpeeds> {
        let mut state = seed;
        let mut unit = move || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let w = u.wheel_bound_rad_s();
        let mut out = Vec::new();
        while out.len() < n {
            let c = WheelSpeeds::new(w * (2.0 * unit() - 1.0), w * (2.0 * unit() - 1.0));
            if u.contains_wheels(c) {
                out.push(c);
            }
        }
        out
    }

    fn husky_metadata() -> CommandSpace {
        CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.165,
                baseline_m: 0.555,
            },
            max_wheel_rad_s: 6.06,
            max_lin_m_s: 1.0,
            max_ang_rad_s: 2.0,
            turn_scale: 1.0,
        }
    }

    /// Commands that leave the configured U because they were drawn in a wider square are
    /// held by a wider square, never by a turn scale; commands whose turning was scaled after
    /// the draw give that scale back; commands inside U leave it as it is.
    #[test]
    fn fitted_to_finds_a_turn_scale() {
        let configured = husky_metadata();
        let wide_square = CommandSpace {
            max_wheel_rad_s: 14.8,
            max_ang_rad_s: 8.7,
            ..configured
        };
        // The null: 100 runs each of 100 and 201 commands in the Husky's wide square, and of
        // 100 in the Warthog's U beyond a configured 12 rad/s.
        let warthog_wide = CommandSpace {
            turn_scale: 1.0,
            ..warthog()
        };
        let warthog_configured = CommandSpace {
            max_wheel_rad_s: 12.0,
            ..warthog_wide
        };
        let mut largest = 0.0f64;
        for seed in 0..100 {
            for (from, drawn, n) in [
                (&configured, &wide_square, 100),
                (&configured, &wide_square, 201),
                (&warthog_configured, &warthog_wide, 100),
            ] {
                let fit = from.fitted_to(&draws(drawn, n, seed));
                assert_eq!(fit.space.turn_scale, 1.0, "seed {seed}, {n} commands: {fit:?}");
                let square = fit.space.max_wheel_rad_s;
                assert!(
                    square > drawn.max_wheel_rad_s - 1.3 && square <= drawn.max_wheel_rad_s + 0.1,
                    "{fit:?}"
                );
                largest = largest.max(fit.gain_nats);
            }
        }
        eprintln!("largest gain of a fitted turn scale over 300 runs drawn at 1: {largest:.1} nats");
        assert!(largest < TURN_SCALE_EVIDENCE_NATS);
        let turned = CommandSpace {
            turn_scale: 2.5,
            max_ang_rad_s: 8.7,
            ..configured
        };
        for seed in 0..5 {
            let commands = draws(&turned, 201, seed);
            let fit = configured.fitted_to(&commands);
            assert!(
                (2.3..=2.7).contains(&fit.space.turn_scale) && fit.gain_nats > 40.0,
                "seed {seed}: {fit:?}"
            );
            assert_eq!(fit.space.max_wheel_rad_s, 6.1, "seed {seed}: {fit:?}");
            assert!(commands.iter().all(|c| fit.space.contains_wheels(*c)));
        }
        let inside = draws(&configured, 50, 7);
        assert_eq!(configured.fitted_to(&inside).space, configured);
        // A declared turn scale is the null in its turn: commands drawn at it, beyond its
        // square, widen the square and keep the scale.
        let declared = CommandSpace {
            max_wheel_rad_s: 5.0,
            turn_scale: 2.5,
            ..turned
        };
        let fit = declared.fitted_to(&draws(&turned, 201, 11));
        assert_eq!(fit.space.turn_scale, 2.5, "{fit:?}");
        assert_eq!(fit.space.max_wheel_rad_s, 6.1, "{fit:?}");
    }

    /// At a turn scale k the square's diamond reaches k times the yaw rate, and membership,
    /// the polygon and the rejection bound agree.
    #[test]
    fn a_turn_scale_stretches_the_diamond_in_yaw_rate() {
        let u = CommandSpace {
            turn_scale: 2.5,
            max_ang_rad_s: 20.0,
            ..husky_metadata()
        };
        let wz = 2.0 * 0.165 * 6.06 * 2.5 / 0.555;
        let top = u.polygon_body().iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert!((top - wz).abs() < 1e-9, "{top} vs {wz}");
        assert!(u.contains_wheels(WheelSpeeds::new(-6.06 * 2.5, 6.06 * 2.5)));
        assert!(!u.contains_wheels(WheelSpeeds::new(-6.06 * 2.6, 6.06 * 2.6)));
        assert!(u.contains_wheels(WheelSpeeds::new(6.06, 6.06)));
        assert!(!u.contains_wheels(WheelSpeeds::new(6.2, 6.0)));
        assert!((u.wheel_bound_rad_s() - 6.06 * 2.5).abs() < 1e-12);
        let body_per_wheel = 0.165 * 0.165 / 0.555;
        assert!((u.area_wheels() * body_per_wheel - u.area_body()).abs() < 1e-9);
    }
}
