//! Random cases for the discovery benchmark (`benches/discovery_benchmark.rs`): effects drawn
//! from families of the independent generator ([`crate::common::generator`]), with random magnitudes
//! in physically plausible ranges that stand above the noise, each with its truth: where it
//! acts, which catalogue effect (if any) is its exact explanation and with which value.
//!
//! The noise is that of `tests/long/discovery.rs` (encoders 0.1 rad/s, pose 0.01 m and 0.003 rad,
//! gyro 0.02 rad/s), the robot the Warthog's geometry with the generator's lag of 0.15 s.

use crate::common::generator::{TestRobotSpec, Unmodelled};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// A family of effects the generator can carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// No effect: noise only.
    Null,
    /// The wheel target a nonlinear function of the command, `u · (1 + a · |u|)`, per side or
    /// both.
    GainCurve,
    /// A soft speed limit, `S · tanh(u / S)`, both sides.
    SoftSaturation,
    /// A deadband θ on each side's command, shifted above it.
    Deadband,
    /// A gain change above a wheel speed θ (a hinge).
    Hinge,
    /// Another gain when a side is told to turn backwards.
    ReverseGain,
    /// A pure actuation dead time on the command.
    DeadTime,
    /// The body velocity lags the wheels' (first order).
    BodyLag,
    /// The speed loop remembers the last turn's load.
    TurnMemory,
    /// Backlash between the motor and the wheel.
    Backlash,
    /// The wheels' gain drifts with the step index.
    GainDrift,
    /// The gyro's bias drifts with the step index.
    ImuBiasDrift,
    /// A side's target gets a share of the other side's command.
    CrossCoupling,
    /// Lateral slip in proportion to vx · wz.
    Centripetal,
    /// The yaw rate falls with the forward speed, `w · (1 − k · |v|)`.
    YawDamping,
    /// One encoder (or both alike) reads a multiple of its wheel's speed.
    EncoderScale,
    /// The gyro's bias or scale is off.
    ImuFault,
    /// Encoder readings lost and reported as zero.
    EncoderDropout,
    /// Counting encoders: readings quantised, zero-mean.
    EncoderQuantization,
    /// The pose reported late.
    PoseLatency,
}

impl Family {
    /// Every family with an effect, in the order [`cases`] cycles over them.
    pub const EFFECTS: [Family; 19] = [
        Family::GainCurve,
        Family::SoftSaturation,
        Family::Deadband,
        Family::Hinge,
        Family::ReverseGain,
        Family::DeadTime,
        Family::BodyLag,
        Family::TurnMemory,
        Family::Backlash,
        Family::GainDrift,
        Family::ImuBiasDrift,
        Family::CrossCoupling,
        Family::Centripetal,
        Family::YawDamping,
        Family::EncoderScale,
        Family::ImuFault,
        Family::EncoderDropout,
        Family::EncoderQuantization,
        Family::PoseLatency,
    ];

    /// Every family, [`Family::Null`] last.
    pub fn all() -> Vec<Family> {
        Self::EFFECTS.iter().copied().chain([Family::Null]).collect()
    }

    /// Name on the command line and in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Null => "null",
            Self::GainCurve => "gain_curve",
            Self::SoftSaturation => "soft_saturation",
            Self::Deadband => "deadband",
            Self::Hinge => "hinge",
            Self::ReverseGain => "reverse_gain",
            Self::DeadTime => "dead_time",
            Self::BodyLag => "body_lag",
            Self::TurnMemory => "turn_memory",
            Self::Backlash => "backlash",
            Self::GainDrift => "gain_drift",
            Self::ImuBiasDrift => "imu_bias_drift",
            Self::CrossCoupling => "cross_coupling",
            Self::Centripetal => "centripetal",
            Self::YawDamping => "yaw_damping",
            Self::EncoderScale => "encoder_scale",
            Self::ImuFault => "imu_fault",
            Self::EncoderDropout => "encoder_dropout",
            Self::EncoderQuantization => "encoder_quantization",
            Self::PoseLatency => "pose_latency",
        }
    }

    /// The family named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::all().into_iter().find(|f| f.name() == name)
    }

    /// Its equation and the ranges [`draw`] takes its magnitudes from, in words.
    pub fn doc(self) -> &'static str {
        match self {
            Self::Null => "no effect, noise only",
            Self::GainCurve => "target u·(1 + a·|u|), a ∈ ±[0.005, 0.02] s/rad, one side or both",
            Self::SoftSaturation => "target S·tanh(u/S), S ∈ [10, 20] rad/s (commands reach 16.7)",
            Self::Deadband => "|u| ≤ θ → 0, else sign(u)(|u| − θ), θ ∈ [0.3, 1.2] rad/s",
            Self::Hinge => "|u| > θ → sign(u)(θ + (1 + k)(|u| − θ)), θ ∈ [5, 10] rad/s, k ∈ ±[0.15, 0.4]",
            Self::ReverseGain => "u < 0 → (1 + δ)·u, δ ∈ ±[0.08, 0.25]",
            Self::DeadTime => "the command of τ ago, τ ∈ [0.05, 0.25] s (whole ms)",
            Self::BodyLag => "body velocity lags the wheels', τ ∈ [0.1, 0.5] s",
            Self::TurnMemory => "wheels give way by m·(s − learnt s), s = tanh((u_l − u_r)/2) learnt over τ, m ∈ [0.5, 1.5] rad/s, τ ∈ [2, 8] s",
            Self::Backlash => "gap b between motor and wheel, b ∈ [0.1, 0.4] rad",
            Self::GainDrift => "gain 1 + d·k at step k, d ∈ ±[0.001, 0.003]",
            Self::ImuBiasDrift => "gyro reads d·k more at step k, d ∈ ±[2e-4, 8e-4] rad/s",
            Self::CrossCoupling => "u_l += c·u_r (and/or u_r += c·u_l), c ∈ ±[0.04, 0.12], one side or both",
            Self::Centripetal => "vy = k·v·w, k ∈ ±[0.05, 0.2] s",
            Self::YawDamping => "w·max(0, 1 − k·|v|), k ∈ [0.03, 0.1] s/m",
            Self::EncoderScale => "encoder reads (1 + e)·ω, e ∈ ±[0.04, 0.12], one side or both",
            Self::ImuFault => "gyro reads wz + b, b ∈ ±[0.01, 0.05] rad/s, or (1 + e)·wz, e ∈ ±[0.04, 0.15]",
            Self::EncoderDropout => "an encoder reading is 0 with probability p ∈ [0.03, 0.15]",
            Self::EncoderQuantization => "counting encoders of N ∈ [48, 200] counts/rev at 20 Hz (zero-mean)",
            Self::PoseLatency => "the pose of τ ago, τ ∈ [0.05, 0.25] s",
        }
    }
}

/// A quantity an effect acts on (what shows it first; downstream quantities follow).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Channel {
    /// The left wheel's speed (its target or its encoder).
    WheelLeft,
    /// The right wheel's speed.
    WheelRight,
    /// Body forward velocity.
    BodyVx,
    /// Body lateral velocity.
    BodyVy,
    /// Body yaw rate.
    BodyWz,
    /// The IMU's yaw-rate reading.
    Imu,
    /// The reported pose.
    Pose,
}

impl Channel {
    /// Name in tables; for the quantities a discovered term can act on, its target's name
    /// (`wheel_left`, `body_vy`, `imu_wz`).
    pub fn name(self) -> &'static str {
        match self {
            Self::WheelLeft => "wheel_left",
            Self::WheelRight => "wheel_right",
            Self::BodyVx => "body_vx",
            Self::BodyVy => "body_vy",
            Self::BodyWz => "body_wz",
            Self::Imu => "imu_wz",
            Self::Pose => "pose",
        }
    }
}

/// A catalogue effect that explains a case exactly, with the true values of its parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Exact {
    /// The effect's registry name.
    pub effect: &'static str,
    /// Its parameters' keys and true values.
    pub params: Vec<(&'static str, f64)>,
}

/// What a case is, for scoring the calibration on it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// Where the effect acts.
    pub channels: Vec<Channel>,
    /// The discovered-term targets that can carry it (empty: no term acts where it does, as
    /// for an encoder fault: a wheel term would move the body too).
    pub targets: Vec<Channel>,
    /// The catalogue effect that is its exact explanation, if any.
    pub exact: Option<Exact>,
    /// Catalogue effects that approximate it.
    pub near: Vec<&'static str>,
    /// Nothing should be found: noise only, or an effect with no mean (quantisation).
    pub expect_nothing: bool,
}

/// One benchmark case.
#[derive(Debug, Clone, Serialize)]
pub struct Case {
    /// Family and index (`deadband-3`).
    pub name: String,
    /// Its family.
    pub family: Family,
    /// Seed of the generator's noise and sampler, and of the calibration's split.
    pub seed: u64,
    /// The generator's effects.
    #[serde(skip)]
    pub extra: Unmodelled,
    /// The drawn magnitudes, named with their units.
    pub magnitudes: Vec<(&'static str, f64)>,
    /// The truth.
    pub truth: Truth,
}

impl Case {
    /// The generator's physics and sensors for this case.
    pub fn spec(&self) -> TestRobotSpec {
        TestRobotSpec::discovery(self.seed)
    }
}

/// Uniform in `[lo, hi]`.
fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// Uniform in `[lo, hi]` with a random sign.
fn signed(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    let m = uniform(rng, lo, hi);
    if rng.random_bool(0.5) {
        m
    } else {
        -m
    }
}

/// Which sides a per-side effect acts on: both (alike) half the time, else one of the two.
#[derive(Clone, Copy, PartialEq)]
enum Sides {
    Left,
    Right,
    Both,
}

fn sides(rng: &mut ChaCha8Rng) -> Sides {
    if rng.random_bool(0.5) {
        Sides::Both
    } else if rng.random_bool(0.5) {
        Sides::Left
    } else {
        Sides::Right
    }
}

impl Sides {
    /// `[left, right]` with `x` on the sides acted on.
    fn pair(self, x: f64) -> [f64; 2] {
        match self {
            Self::Left => [x, 0.0],
            Self::Right => [0.0, x],
            Self::Both => [x, x],
        }
    }

    /// The wheel channels acted on.
    fn channels(self) -> Vec<Channel> {
        match self {
            Self::Left => vec![Channel::WheelLeft],
            Self::Right => vec![Channel::WheelRight],
            Self::Both => vec![Channel::WheelLeft, Channel::WheelRight],
        }
    }

    /// The magnitude's name for these sides.
    fn key(self, left: &'static str, right: &'static str, both: &'static str) -> &'static str {
        match self {
            Self::Left => left,
            Self::Right => right,
            Self::Both => both,
        }
    }
}

/// A seeded random case of `family`: its magnitudes drawn from the family's ranges
/// ([`Family::doc`]) by a generator seeded with `seed`, which is also the case's noise seed.
pub fn draw(family: Family, seed: u64) -> Case {
    use Channel::*;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_d15c_0e77);
    let base = Unmodelled {
        // A lidar pose has some yaw noise (as in tests/long/discovery.rs): without it the transient
        // yaw-rate floor is round-off and any lag mismatch flags.
        pose_yaw_noise_rad: 0.003,
        ..Unmodelled::default()
    };
    let wheels = vec![WheelLeft, WheelRight];
    let spec = TestRobotSpec::discovery(seed);
    let turn_saturation = 2.0 * spec.radius_m / spec.track_m;
    let truth = |channels: Vec<Channel>, targets: Vec<Channel>| Truth {
        channels,
        targets,
        exact: None,
        near: Vec::new(),
        expect_nothing: false,
    };
    let exact = |effect, params| Some(Exact { effect, params });
    let (extra, magnitudes, truth) = match family {
        Family::Null => (
            base,
            vec![],
            Truth {
                expect_nothing: true,
                ..truth(vec![], vec![])
            },
        ),
        Family::GainCurve => {
            let s = sides(&mut rng);
            let a = signed(&mut rng, 0.005, 0.02);
            (
                Unmodelled {
                    gain_curve_s_rad: s.pair(a),
                    ..base
                },
                vec![(s.key("a_left_s_rad", "a_right_s_rad", "a_s_rad"), a)],
                Truth {
                    near: vec!["motor_gain", "wheel_speed_saturation_rad_s"],
                    ..truth(s.channels(), s.channels())
                },
            )
        }
        Family::SoftSaturation => {
            let limit = uniform(&mut rng, 10.0, 20.0);
            (
                Unmodelled {
                    soft_limit_rad_s: limit,
                    ..base
                },
                vec![("limit_rad_s", limit)],
                Truth {
                    exact: exact(
                        "wheel_speed_soft_limit_rad_s",
                        vec![("wheel_speed_soft_limit_rad_s", limit)],
                    ),
                    near: vec!["wheel_speed_saturation_rad_s", "controller_wheel_limit_rad_s"],
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::Deadband => {
            let theta = uniform(&mut rng, 0.3, 1.2);
            (
                Unmodelled {
                    deadband_rad_s: theta,
                    ..base
                },
                vec![("theta_rad_s", theta)],
                Truth {
                    exact: exact("wheel_deadband_rad_s", vec![("wheel_deadband_rad_s", theta)]),
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::Hinge => {
            let theta = uniform(&mut rng, 5.0, 10.0);
            let k = signed(&mut rng, 0.15, 0.4);
            (
                Unmodelled {
                    hinge_rad_s: theta,
                    hinge_gain_change: k,
                    ..base
                },
                vec![("theta_rad_s", theta), ("k", k)],
                Truth {
                    exact: exact(
                        "wheel_gain_knee",
                        vec![("wheel_knee_rad_s", theta), ("wheel_gain_above_knee", 1.0 + k)],
                    ),
                    near: vec!["wheel_speed_saturation_rad_s", "motor_gain"],
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::ReverseGain => {
            let d = signed(&mut rng, 0.08, 0.25);
            (
                Unmodelled {
                    reverse_gain_change: d,
                    ..base
                },
                vec![("delta", d)],
                Truth {
                    exact: exact("wheel_reverse_gain", vec![("wheel_reverse_gain", 1.0 + d)]),
                    near: vec!["motor_gain"],
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::DeadTime => {
            // Whole milliseconds: the generator's FIFO holds 1 kHz steps.
            let tau = (uniform(&mut rng, 0.05, 0.25) * 1000.0).round() / 1000.0;
            (
                Unmodelled {
                    dead_time_s: tau,
                    ..base
                },
                vec![("tau_s", tau)],
                Truth {
                    exact: exact("dead_time_s", vec![("dead_time_s", tau)]),
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::BodyLag => {
            let tau = uniform(&mut rng, 0.1, 0.5);
            (
                Unmodelled {
                    body_lag_s: tau,
                    ..base
                },
                vec![("tau_s", tau)],
                Truth {
                    exact: exact("body_lag", vec![("body_time_constant_s", tau)]),
                    ..truth(vec![BodyVx, BodyWz], vec![BodyVx, BodyWz])
                },
            )
        }
        Family::TurnMemory => {
            let m = uniform(&mut rng, 0.5, 1.5);
            let tau = uniform(&mut rng, 2.0, 8.0);
            (
                Unmodelled {
                    turn_memory_rad_s: m,
                    turn_memory_s: tau,
                    ..base
                },
                vec![("m_rad_s", m), ("tau_s", tau)],
                Truth {
                    // The generator's turn, tanh((u_l − u_r)/2), is the named effect's load
                    // tanh(wz/w_s) at w_s = 2r/b of its nominal geometry.
                    exact: exact(
                        "turn_memory",
                        vec![
                            ("turn_memory_give_rad_s", m),
                            ("turn_memory_s", tau),
                            ("turn_memory_saturation_rad_s", turn_saturation),
                        ],
                    ),
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::Backlash => {
            let b = uniform(&mut rng, 0.1, 0.4);
            (
                Unmodelled {
                    backlash_rad: b,
                    ..base
                },
                vec![("gap_rad", b)],
                // The encoders read the motors: only the body (and the pose) see the slack.
                Truth {
                    near: vec!["dead_time_s", "body_lag"],
                    ..truth(vec![BodyVx, BodyWz, Pose], vec![BodyVx, BodyWz])
                },
            )
        }
        Family::GainDrift => {
            let d = signed(&mut rng, 0.001, 0.003);
            (
                Unmodelled {
                    gain_drift_per_step: d,
                    ..base
                },
                vec![("d_per_step", d)],
                Truth {
                    exact: exact("motor_gain_drift", vec![("motor_gain_drift_per_step", d)]),
                    ..truth(wheels.clone(), wheels)
                },
            )
        }
        Family::ImuBiasDrift => {
            let d = signed(&mut rng, 2e-4, 8e-4);
            (
                Unmodelled {
                    imu_bias_drift_rad_s_per_step: d,
                    ..base
                },
                vec![("d_rad_s_per_step", d)],
                Truth {
                    near: vec!["imu_yaw_rate_bias_rad_s"],
                    ..truth(vec![Imu], vec![Imu])
                },
            )
        }
        Family::CrossCoupling => {
            let s = sides(&mut rng);
            let c = signed(&mut rng, 0.04, 0.12);
            // The other side's command leaks into the side acted on: the left target moves
            // with the right command.
            let exact_of = if s == Sides::Both {
                // u_l + c·u_r and u_r + c·u_l is a controller converting through the nominal
                // body space with radius r/(1 + c) and baseline b·(1 − c)/(1 + c).
                exact(
                    "controller_kinematics",
                    vec![
                        ("controller_radius_scale", 1.0 / (1.0 + c)),
                        ("controller_baseline_scale", (1.0 - c) / (1.0 + c)),
                    ],
                )
            } else {
                None
            };
            (
                Unmodelled {
                    cross_coupling: s.pair(c),
                    ..base
                },
                vec![(s.key("c_left", "c_right", "c"), c)],
                Truth {
                    exact: exact_of,
                    near: vec!["controller_kinematics", "motor_gain"],
                    ..truth(s.channels(), s.channels())
                },
            )
        }
        Family::Centripetal => {
            let k = signed(&mut rng, 0.05, 0.2);
            (
                Unmodelled {
                    centripetal_s: k,
                    ..base
                },
                vec![("k_s", k)],
                Truth {
                    exact: exact("centripetal_slip", vec![("centripetal_slip_s", k)]),
                    ..truth(vec![BodyVy], vec![BodyVy])
                },
            )
        }
        Family::YawDamping => {
            let k = uniform(&mut rng, 0.03, 0.1);
            (
                Unmodelled {
                    yaw_damping_s_m: k,
                    ..base
                },
                vec![("k_s_m", k)],
                truth(vec![BodyWz], vec![BodyWz]),
            )
        }
        Family::EncoderScale => {
            let s = sides(&mut rng);
            let e = signed(&mut rng, 0.04, 0.12);
            let [l, r] = s.pair(e);
            let exact_of = if s == Sides::Both {
                exact("encoder_scale", vec![("encoder_scale", 1.0 + e)])
            } else {
                exact(
                    "encoder_side_scale",
                    vec![("encoder_scale_left", 1.0 + l), ("encoder_scale_right", 1.0 + r)],
                )
            };
            (
                Unmodelled {
                    encoder_scale_error: s.pair(e),
                    ..base
                },
                vec![(s.key("e_left", "e_right", "e"), e)],
                Truth {
                    exact: exact_of,
                    near: vec!["encoder_scale"],
                    ..truth(s.channels(), vec![])
                },
            )
        }
        Family::ImuFault => {
            if rng.random_bool(0.5) {
                let b = signed(&mut rng, 0.01, 0.05);
                (
                    Unmodelled {
                        imu_bias_rad_s: b,
                        ..base
                    },
                    vec![("bias_rad_s", b)],
                    Truth {
                        exact: exact("imu_yaw_rate_bias_rad_s", vec![("imu_yaw_rate_bias_rad_s", b)]),
                        ..truth(vec![Imu], vec![Imu])
                    },
                )
            } else {
                let e = signed(&mut rng, 0.04, 0.15);
                (
                    Unmodelled {
                        imu_scale_error: e,
                        ..base
                    },
                    vec![("scale_error", e)],
                    Truth {
                        exact: exact("imu_yaw_rate_scale", vec![("imu_yaw_rate_scale", 1.0 + e)]),
                        ..truth(vec![Imu], vec![Imu])
                    },
                )
            }
        }
        Family::EncoderDropout => {
            let p = uniform(&mut rng, 0.03, 0.15);
            (
                Unmodelled {
                    encoder_dropout: p,
                    ..base
                },
                vec![("p", p)],
                // On average an encoder scale of 1 − p, with a heavy-tailed noise.
                Truth {
                    near: vec!["encoder_scale"],
                    ..truth(wheels, vec![])
                },
            )
        }
        Family::EncoderQuantization => {
            let n = rng.random_range(48..=200u32);
            (
                Unmodelled {
                    encoder_counts_per_rev: n,
                    ..base
                },
                vec![("counts_per_rev", n as f64)],
                Truth {
                    expect_nothing: true,
                    ..truth(wheels, vec![])
                },
            )
        }
        Family::PoseLatency => {
            let tau = uniform(&mut rng, 0.05, 0.25);
            (
                Unmodelled {
                    pose_latency_s: tau,
                    ..base
                },
                vec![("tau_s", tau)],
                Truth {
                    exact: exact("pose_latency_s", vec![("pose_latency_s", tau)]),
                    ..truth(vec![Pose], vec![])
                },
            )
        }
    };
    Case {
        name: family.name().to_string(),
        family,
        seed,
        extra,
        magnitudes,
        truth,
    }
}

/// `n` cases cycling over `families` (in their order, so `n` = a multiple of their number
/// gives each the same count) and `nulls` null cases, each with its own seed drawn from `seed`;
/// named `<family>-<k>` (k-th of its family).
pub fn cases(families: &[Family], n: usize, nulls: usize, seed: u64) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n + nulls);
    let picks = (0..n)
        .filter_map(|i| families.get(i % families.len().max(1)).copied())
        .chain(std::iter::repeat_n(Family::Null, nulls));
    for (i, family) in picks.enumerate() {
        // Seeds kept small and distinct: they name the case's log and split.
        let case_seed = rng.random_range(0..1_000_000u64) * 1000 + i as u64;
        let mut case = draw(family, case_seed);
        let k = out.iter().filter(|c: &&Case| c.family == family).count() + 1;
        case.name = format!("{}-{k}", family.name());
        out.push(case);
    }
    out
}
