//! Compares every registered sampler on the ideal plant with the comparison metrics, prints
//! the table (`cargo test --test quick samplers_compare:: -- --nocapture`), and checks the relations
//! each strategy is designed for.

use drive_sim::kinematics::WheelSpeeds;
use drive_sim::log::Pose;
use drive_sim::protocol::sampler::{make_sampler, make_sampler_for, SamplingContext, SAMPLERS};
use drive_sim::protocol::samplers::metrics::{
    acceleration_coverage, command_coverage, commanded_energy_j_s, time_use,
};
use drive_sim::protocol::{run_drive, FrameSink, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::IdealPlant;
use std::collections::BTreeMap;

/// Discards frames: only the summary and the commands matter here.
struct Discard;
impl FrameSink for Discard {
    fn frame(&mut self, _: &drive_sim::log::Frame) -> drive_sim::Result<()> {
        Ok(())
    }
}

/// Records the commands a sampler returns.
struct Recorder(Box<dyn drive_sim::protocol::sampler::Sampler>, Vec<WheelSpeeds>);
impl drive_sim::protocol::sampler::Sampler for Recorder {
    fn name(&self) -> &str {
        self.0.name()
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> drive_sim::Result<WheelSpeeds> {
        let c = self.0.next(ctx)?;
        self.1.push(c);
        Ok(c)
    }
}

#[derive(Debug, Default, Clone, Copy)]
struct Row {
    interruptions_per_step: f64,
    time_efficiency: f64,
    accel_entropy: f64,
    coverage: f64,
    energy_j_s: f64,
}

fn compare(robot_name: &str, steps: u32, seeds: &[u64]) -> BTreeMap<&'static str, Row> {
    let (robot, _) = Robot::resolve(robot_name).unwrap();
    let space = robot.command_space();
    let cfg = ProtocolConfig {
        steps,
        ..Default::default()
    };
    let mut table = BTreeMap::new();
    for name in SAMPLERS {
        let mut row = Row::default();
        for &seed in seeds {
            let mut plant = IdealPlant::new(robot.idd(), robot.powertrain.time_constant_s);
            let mut rec = Recorder(make_sampler(name, seed).unwrap(), Vec::new());
            let sum = run_drive(&mut plant, &robot, &mut rec, &cfg, &mut Discard).unwrap();
            let tu = time_use(&sum);
            let acc = acceleration_coverage(&space, &rec.1, 10);
            row.interruptions_per_step += tu.interruptions_per_step;
            row.time_efficiency += tu.time_efficiency;
            row.accel_entropy += acc.linear.normalized_entropy();
            row.coverage += command_coverage(&space, &rec.1, 20, 0.1);
            row.energy_j_s += commanded_energy_j_s(&robot, &rec.1, 6.0) / steps as f64;
        }
        let n = seeds.len() as f64;
        row.interruptions_per_step /= n;
        row.time_efficiency /= n;
        row.accel_entropy /= n;
        row.coverage /= n;
        row.energy_j_s /= n;
        table.insert(*name, row);
    }
    println!("{robot_name}, {steps} steps, seeds {seeds:?} (means):");
    println!(
        "{:<16} {:>10} {:>10} {:>10} {:>10} {:>14}",
        "sampler", "interr/st", "time eff", "H(|dvx|)", "coverage", "E/step (J s)"
    );
    for (name, r) in &table {
        println!(
            "{:<16} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>14.1}",
            name, r.interruptions_per_step, r.time_efficiency, r.accel_entropy, r.coverage, r.energy_j_s
        );
    }
    table
}

#[test]
fn samplers_compared_on_the_ideal_husky() {
    let t = compare("husky", 60, &[1, 2, 3]);
    let uw = t["uniform-wheel"];
    // Boundary-aware trades nothing in time: it is never interrupted on an ideal robot.
    assert!(t["boundary-aware"].interruptions_per_step < 0.25 * uw.interruptions_per_step);
    assert!(t["boundary-aware"].time_efficiency > uw.time_efficiency);
    // Spread-accel and uniform-step flatten the linear acceleration histogram.
    assert!(t["spread-accel"].accel_entropy > uw.accel_entropy);
    assert!(t["uniform-step"].accel_entropy > uw.accel_entropy);
    // Halton covers U better than independent draws with the same number of commands.
    assert!(t["halton"].coverage > uw.coverage);
}

#[test]
fn samplers_compared_on_the_ideal_warthog() {
    let t = compare("warthog", 60, &[1, 2, 3]);
    let uw = t["uniform-wheel"];
    assert!(t["boundary-aware"].interruptions_per_step < uw.interruptions_per_step);
    assert!(t["halton"].coverage > uw.coverage);
}

#[test]
fn boundary_aware_reads_the_protocol_it_runs_in() {
    // Husky 2.5 m from the +x border of its 9 x 6 m area, facing it: at 1 m/s for 6 s it
    // would cross the border, for 1 s it would not. With a 1 s step (2 windows of 0.5 s) the
    // sampler accepts fast forward commands; with the default 6 s step it never does.
    let (robot, _) = Robot::resolve("husky").unwrap();
    let space = robot.command_space();
    let ctx = SamplingContext {
        space: &space,
        step: 0,
        previous: WheelSpeeds::default(),
        history: &[],
        pose: Pose {
            x_m: 2.0,
            ..Pose::default()
        },
        safe_half_extents_m: (4.5, 3.0),
    };
    let short = ProtocolConfig {
        window_s: 0.5,
        windows_per_step: 2,
        ..Default::default()
    };
    let fast_forward = |cfg: &ProtocolConfig| {
        let mut s = make_sampler_for("boundary-aware", 7, cfg).unwrap();
        (0..200)
            .map(|_| s.next(&ctx).unwrap())
            .filter(|c| {
                let b = space.idd.body_from_wheels(*c);
                b.vx_m_s > 0.7 && b.wz_rad_s.abs() < 0.3
            })
            .count()
    };
    let (long_n, short_n) = (fast_forward(&ProtocolConfig::default()), fast_forward(&short));
    assert_eq!(long_n, 0);
    assert!(short_n >= 3, "{short_n}");
}

#[test]
fn boundary_aware_wraps_another_strategy() {
    use drive_sim::protocol::samplers::boundary_aware::BoundaryAware;
    use drive_sim::protocol::samplers::metrics::acceleration_coverage;
    let (robot, _) = Robot::resolve("husky").unwrap();
    let space = robot.command_space();
    let cfg = ProtocolConfig {
        steps: 60,
        ..Default::default()
    };
    let (mut plain_h, mut wrapped_h, mut wrapped_int) = (0.0, 0.0, 0);
    for seed in 1..=3 {
        let run = |sampler: Box<dyn drive_sim::protocol::sampler::Sampler>| {
            let mut plant = IdealPlant::new(robot.idd(), robot.powertrain.time_constant_s);
            let mut rec = Recorder(sampler, Vec::new());
            let sum = run_drive(&mut plant, &robot, &mut rec, &cfg, &mut Discard).unwrap();
            (
                sum,
                acceleration_coverage(&space, &rec.1, 10)
                    .linear
                    .normalized_entropy(),
            )
        };
        let inner = make_sampler("spread-accel", seed).unwrap();
        let wrapped = BoundaryAware::wrapping(inner, &cfg);
        assert_eq!(
            drive_sim::protocol::sampler::Sampler::name(&wrapped),
            "boundary-aware(spread-accel)"
        );
        let (sw, hw) = run(Box::new(wrapped));
        let (_, hp) = run(make_sampler("boundary-aware", seed).unwrap());
        wrapped_int += sw.interruptions;
        wrapped_h += hw;
        plain_h += hp;
    }
    println!(
        "boundary-aware H(|dvx|) {:.3}, wrapping spread-accel {:.3}",
        plain_h / 3.0,
        wrapped_h / 3.0
    );
    assert!(wrapped_int <= 2, "{wrapped_int}");
    assert!(wrapped_h > plain_h + 0.15, "{wrapped_h} vs {plain_h}");
}
