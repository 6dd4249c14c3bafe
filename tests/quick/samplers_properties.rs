//! Properties of the sampling strategies, checked against numbers computed independently of
//! them: areas of U from its polygons, step densities by Monte Carlo, discrepancy by exact box
//! areas, and interruptions of the protocol on the ideal plant.

use drive_sim::geometry::polygon_area;
use drive_sim::kinematics::{CommandSpace, WheelSpeeds};
use drive_sim::log::Pose;
use drive_sim::protocol::sampler::{make_sampler, Sampler, SamplingContext, StepOutcome, SAMPLERS};
use drive_sim::protocol::{run_drive, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::IdealPlant;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn space(robot: &str) -> CommandSpace {
    Robot::resolve(robot).unwrap().0.command_space()
}

/// Draws `n` commands as the protocol would if every step completed on an ideal robot: the
/// history holds each command with the IDD velocity it produces.
fn open_loop(sampler: &mut dyn Sampler, space: &CommandSpace, n: usize) -> Vec<WheelSpeeds> {
    let mut history: Vec<StepOutcome> = Vec::new();
    let mut previous = WheelSpeeds::default();
    for step in 0..n {
        let ctx = SamplingContext {
            space,
            step: step as u32,
            previous,
            history: &history,
            pose: Pose::default(),
            safe_half_extents_m: (1e3, 1e3),
        };
        let c = sampler.next(&ctx).unwrap();
        history.push(StepOutcome {
            cmd: c,
            steady_velocity: space.idd.body_from_wheels(c),
        });
        previous = c;
    }
    history.iter().map(|o| o.cmd).collect()
}

fn draws(name: &str, seed: u64, space: &CommandSpace, n: usize) -> Vec<WheelSpeeds> {
    open_loop(make_sampler(name, seed).unwrap().as_mut(), space, n)
}

#[test]
fn every_sampler_stays_in_u_and_repeats_with_its_seed() {
    for robot in ["warthog", "husky"] {
        let s = space(robot);
        for name in SAMPLERS {
            let a = draws(name, 5, &s, 300);
            assert!(
                a.iter().all(|c| s.contains_wheels(*c) && c.is_finite()),
                "{name} left U on the {robot}"
            );
            assert_eq!(a, draws(name, 5, &s, 300), "{name} is not deterministic");
            assert_ne!(a, draws(name, 6, &s, 300), "{name} ignores its seed");
        }
    }
}

#[test]
fn uniform_body_shares_equal_area_fractions_of_u() {
    // Uniform in B: the share of draws in a sub-region of U is its area over the area of U.
    // The sub-regions |wz| < a and |vx| < v are U with a tighter user limit, whose areas come
    // from the command-space polygons.
    let s = space("warthog");
    let n = 20_000;
    let d = draws("uniform-body", 2, &s, n);
    let body: Vec<_> = d.iter().map(|c| s.idd.body_from_wheels(*c)).collect();
    let share = |f: &dyn Fn(f64, f64) -> bool| {
        body.iter().filter(|b| f(b.vx_m_s, b.wz_rad_s)).count() as f64 / n as f64
    };
    for a in [0.5, 1.0, 3.0] {
        let sub = CommandSpace {
            max_ang_rad_s: a,
            turn_scale: 1.0,
            ..s
        };
        let expected = sub.area_body() / s.area_body();
        let got = share(&|_, wz| wz.abs() < a);
        // 4 standard deviations of a binomial share at n = 20000 is at most 0.0142.
        assert!((got - expected).abs() < 0.0142, "|wz|<{a}: {got} vs {expected}");
    }
    let sub = CommandSpace {
        max_lin_m_s: 2.0,
        ..s
    };
    let expected = sub.area_body() / s.area_body();
    let got = share(&|vx, _| vx.abs() < 2.0);
    assert!((got - expected).abs() < 0.0142, "|vx|<2: {got} vs {expected}");
}

/// Independent uniform draw in U (wheel frame) by rejection from the wheel square, with its own
/// generator: the reference for the distribution of steps of independent uniform commands.
fn reference_uniform(s: &CommandSpace, rng: &mut ChaCha8Rng) -> WheelSpeeds {
    let w = s.max_wheel_rad_s;
    loop {
        let c = WheelSpeeds::new(rng.random_range(-w..w), rng.random_range(-w..w));
        if s.contains_wheels(c) {
            return c;
        }
    }
}

/// Histogram (shares) of step magnitudes `f(step)` over [0, range) in `bins` bins.
fn step_histogram(
    cmds: &[WheelSpeeds],
    bins: usize,
    range: f64,
    f: &dyn Fn(WheelSpeeds, WheelSpeeds) -> f64,
) -> Vec<f64> {
    let mut h = vec![0.0; bins];
    for p in cmds.windows(2) {
        let x = f(p[0], p[1]);
        h[((x / range * bins as f64) as usize).min(bins - 1)] += 1.0;
    }
    let n = (cmds.len() - 1) as f64;
    h.iter().map(|c| c / n).collect()
}

/// Shares of |Δvx| between consecutive commands in 10 bins over [0, 2 vx_max).
fn dvx_shares(s: &CommandSpace, cmds: &[WheelSpeeds]) -> Vec<f64> {
    let vm = s.max_lin_m_s.min(s.max_wheel_rad_s * s.idd.wheel_radius_m);
    step_histogram(cmds, 10, 2.0 * vm, &|a, b| {
        (s.idd.body_from_wheels(b).vx_m_s - s.idd.body_from_wheels(a).vx_m_s).abs()
    })
}

fn total_variation(a: &[f64], b: &[f64]) -> f64 {
    0.5 * a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>()
}

#[test]
fn uniform_step_removes_the_triangular_bias_of_speed_steps() {
    let s = space("warthog");
    // Reference: steps between independent uniform commands, by Monte Carlo with its own
    // generator. Their |Δvx| density falls from 0 (the paper's triangular distribution).
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let reference: Vec<WheelSpeeds> = (0..40_000).map(|_| reference_uniform(&s, &mut rng)).collect();
    let r = dvx_shares(&s, &reference);
    assert!(r[0] > r[3] * 1.4 && r[3] > r[6] * 2.0, "reference {r:?}");
    // uniform-wheel follows it...
    let uw = dvx_shares(&s, &draws("uniform-wheel", 1, &s, 10_000));
    assert!(total_variation(&uw, &r) < 0.03, "{uw:?} vs {r:?}");
    // ...uniform-step does not: flat over the first 60 % of the range, far more large steps.
    for seed in [1, 2, 3] {
        let us = dvx_shares(&s, &draws("uniform-step", seed, &s, 10_000));
        let head = &us[..6];
        let mean = head.iter().sum::<f64>() / 6.0;
        assert!(
            head.iter().all(|x| (x / mean - 1.0).abs() < 0.15),
            "seed {seed}: {us:?}"
        );
        let top = |h: &[f64]| h[5..].iter().sum::<f64>();
        assert!(top(&us) > 1.5 * top(&r), "seed {seed}: {us:?} vs {r:?}");
        assert!(total_variation(&us, &r) > 0.1, "seed {seed}: {us:?} vs {r:?}");
    }
}

/// Sutherland–Hodgman clip of a polygon by the half-plane `x[axis] <= limit`.
fn clip_below(poly: &[(f64, f64)], axis: usize, limit: f64) -> Vec<(f64, f64)> {
    let coord = |p: (f64, f64)| if axis == 0 { p.0 } else { p.1 };
    let mut out = Vec::new();
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fp, fq) = (coord(p) - limit, coord(q) - limit);
        if fp <= 0.0 {
            out.push(p);
        }
        if (fp < 0.0 && fq > 0.0) || (fp > 0.0 && fq < 0.0) {
            let t = fp / (fp - fq);
            out.push((p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1)));
        }
    }
    out
}

/// Star discrepancy of commands over U in the wheel frame, on a grid of anchored boxes
/// `[-w, a] x [-w, b]`: the largest gap between the share of commands in a box and the share of
/// U's area in it (exact, by clipping U's polygon).
fn discrepancy(s: &CommandSpace, cmds: &[WheelSpeeds], grid: usize) -> f64 {
    let poly = s.polygon_wheels();
    let area = polygon_area(&poly);
    let w = s.max_wheel_rad_s;
    let n = cmds.len() as f64;
    let mut worst: f64 = 0.0;
    for i in 1..=grid {
        for j in 1..=grid {
            let a = -w + 2.0 * w * i as f64 / grid as f64;
            let b = -w + 2.0 * w * j as f64 / grid as f64;
            let boxed = clip_below(&clip_below(&poly, 0, a), 1, b);
            let expected = if boxed.len() < 3 {
                0.0
            } else {
                polygon_area(&boxed) / area
            };
            let got = cmds
                .iter()
                .filter(|c| c.left_rad_s <= a && c.right_rad_s <= b)
                .count() as f64
                / n;
            worst = worst.max((got - expected).abs());
        }
    }
    worst
}

#[test]
fn halton_has_lower_discrepancy_than_uniform_draws() {
    for robot in ["warthog", "husky"] {
        let s = space(robot);
        let n = 256;
        let (mut dh, mut du) = (0.0, 0.0);
        for seed in 1..=4 {
            let h = discrepancy(&s, &draws("halton", seed, &s, n), 32);
            let u = discrepancy(&s, &draws("uniform-wheel", seed, &s, n), 32);
            println!("{robot} seed {seed}: halton {h:.4}, uniform-wheel {u:.4}");
            assert!(h < u, "{robot} seed {seed}: halton {h} vs uniform {u}");
            dh += h;
            du += u;
        }
        // Independent draws: about 1/sqrt(N) = 0.06; Halton: a few times smaller.
        assert!(dh < 0.5 * du, "{robot}: mean halton {dh} vs uniform {du}");
    }
}

#[test]
fn boundary_aware_interrupts_less_than_uniform_wheel_on_the_ideal_husky() {
    let (robot, _) = Robot::resolve("husky").unwrap();
    let cfg = ProtocolConfig {
        steps: 40,
        ..Default::default()
    };
    let interruptions = |name: &str| -> u32 {
        (1..=3)
            .map(|seed| {
                let mut plant = IdealPlant::new(robot.idd(), robot.powertrain.time_constant_s);
                let mut sampler = make_sampler(name, seed).unwrap();
                let mut frames = Vec::new();
                let sum = run_drive(&mut plant, &robot, sampler.as_mut(), &cfg, &mut frames).unwrap();
                assert_eq!(sum.steps_completed, 40);
                sum.interruptions
            })
            .sum()
    };
    let uw = interruptions("uniform-wheel");
    let ba = interruptions("boundary-aware");
    println!("interruptions over 3 x 40 steps: uniform-wheel {uw}, boundary-aware {ba}");
    assert!(uw >= 10, "the 9 x 6 m area must interrupt uniform sampling: {uw}");
    assert!(ba * 4 <= uw, "boundary-aware {ba} vs uniform-wheel {uw}");
}

#[test]
fn spread_accel_covers_accelerations_more_evenly_than_uniform_wheel() {
    use drive_sim::protocol::samplers::metrics::acceleration_coverage;
    let s = space("warthog");
    for seed in [1, 2, 3] {
        let a = acceleration_coverage(&s, &draws("spread-accel", seed, &s, 300), 10);
        let u = acceleration_coverage(&s, &draws("uniform-wheel", seed, &s, 300), 10);
        println!(
            "seed {seed}: normalized entropy of |dvx| spread-accel {:.3}, uniform-wheel {:.3}",
            a.linear.normalized_entropy(),
            u.linear.normalized_entropy()
        );
        assert!(a.linear.normalized_entropy() > u.linear.normalized_entropy() + 0.03);
        assert!(a.angular.normalized_entropy() > u.angular.normalized_entropy());
    }
}

/// A context over `s` with the given history.
fn ctx<'a>(s: &'a CommandSpace, history: &'a [StepOutcome]) -> SamplingContext<'a> {
    SamplingContext {
        space: s,
        step: history.len() as u32,
        previous: WheelSpeeds::default(),
        history,
        pose: Pose::default(),
        safe_half_extents_m: (1e3, 1e3),
    }
}

#[test]
fn active_samples_where_data_is_missing_or_noisy() {
    let s = space("husky");
    let ideal = |c: WheelSpeeds| StepOutcome {
        cmd: c,
        steady_velocity: s.idd.body_from_wheels(c),
    };
    // 200 forward commands (vx > 0) and none backward: new draws go backward.
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut forward = Vec::new();
    while forward.len() < 200 {
        let c = reference_uniform(&s, &mut rng);
        if s.idd.body_from_wheels(c).vx_m_s > 0.0 {
            forward.push(ideal(c));
        }
    }
    let mut sampler = make_sampler("active", 1).unwrap();
    let backward = (0..100)
        .filter(|_| {
            s.idd
                .body_from_wheels(sampler.next(&ctx(&s, &forward)).unwrap())
                .vx_m_s
                < 0.0
        })
        .count();
    assert!(backward >= 95, "{backward} of 100 backward");
    // Equal density everywhere, but the slip is noisy for left turns (wz > 0) and constant for
    // right turns: new draws go to the left turns.
    let mut noisy = Vec::new();
    for i in 0..400 {
        let c = reference_uniform(&s, &mut rng);
        let b = s.idd.body_from_wheels(c);
        let mut o = ideal(c);
        if b.wz_rad_s > 0.0 {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            o.steady_velocity.vx_m_s -= sign * 0.3;
        }
        noisy.push(o);
    }
    let left = (0..100)
        .filter(|_| {
            s.idd
                .body_from_wheels(sampler.next(&ctx(&s, &noisy)).unwrap())
                .wz_rad_s
                > 0.0
        })
        .count();
    assert!(left >= 90, "{left} of 100 left turns");
    // Without history it is a uniform draw: about half forward.
    let fwd = (0..400)
        .filter(|_| {
            s.idd
                .body_from_wheels(sampler.next(&ctx(&s, &[])).unwrap())
                .vx_m_s
                > 0.0
        })
        .count();
    assert!((160..=240).contains(&fwd), "{fwd} of 400 forward");
}

/// Wraps a sampler and records what it returns.
struct Recorder(Box<dyn Sampler>, Vec<WheelSpeeds>);

impl Sampler for Recorder {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> drive_sim::Result<WheelSpeeds> {
        let c = self.0.next(ctx)?;
        self.1.push(c);
        Ok(c)
    }
}

#[test]
fn log_metrics_agree_with_the_commands_drawn() {
    use drive_sim::log::{DriveLog, LogMeta, Nominal, Origin};
    use drive_sim::protocol::samplers::metrics::{
        commanded_energy_j_s, log_commanded_energy_j_s, step_commands, time_use,
    };
    let (robot, _) = Robot::resolve("husky").unwrap();
    let cfg = ProtocolConfig {
        steps: 12,
        ..Default::default()
    };
    let mut plant = IdealPlant::new(robot.idd(), 0.1);
    let mut rec = Recorder(make_sampler("boundary-aware", 2).unwrap(), Vec::new());
    let mut frames = Vec::new();
    let sum = run_drive(&mut plant, &robot, &mut rec, &cfg, &mut frames).unwrap();
    let meta = LogMeta {
        name: "t".into(),
        robot: "husky".into(),
        terrain: "ideal".into(),
        rate_hz: 20.0,
        window_s: 2.0,
        windows_per_step: 3,
        samples_per_window: 40,
        nominal: Nominal::from_robot(&robot),
        origin: Origin::Simulated {
            seed: 2,
            robot_file: String::new(),
            terrain_file: String::new(),
            sampler: "boundary-aware".into(),
            injected: vec![],
        },
    };
    let log = DriveLog::from_frames(meta, &frames);
    assert_eq!(sum.abandoned_commands, 0);
    assert_eq!(step_commands(&log), rec.1);
    let e_log = log_commanded_energy_j_s(&robot, &log);
    let e_cmd = commanded_energy_j_s(&robot, &rec.1, 6.0);
    assert!(
        (e_log - e_cmd).abs() < 1e-9 * e_cmd.max(1.0),
        "{e_log} vs {e_cmd}"
    );
    let tu = time_use(&sum);
    assert_eq!(tu.interruptions_per_step, sum.interruptions as f64 / 12.0);
}
