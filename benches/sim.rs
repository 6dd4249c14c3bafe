//! Speed of the simulator with MCAP logging, the fast physics step against the reference one in
//! the same run: a Warthog DRIVE on gravel (the workload, shortened to keep criterion's
//! samples short) written to an MCAP file, as `drive-sim run` does.
//!
//! Before criterion, a side-by-side table: each stepping timed on the same run (best of 3,
//! interleaved), with the real-time factor over productive robot time (steps × 6 s) and over
//! all simulated time, and the ratio of the two steppings.
//! Target: a 300-step Warthog DRIVE with logging ≥ 2500× real time in productive time on one core.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use drive_sim::experiments::simulate::simulated_meta;
use drive_sim::log::mcap::McapWriter;
use drive_sim::protocol::sampler::UniformWheel;
use drive_sim::protocol::{run_drive, ProtocolConfig, RunSummary};
use drive_sim::robot::Robot;
use drive_sim::sim::{SensorNoise, SimConfig, Simulator, Stepping};
use drive_sim::terrain::Terrain;
use std::time::Instant;

const STEPS: u32 = 30;

/// One logged DRIVE run; returns its summary and wall time.
fn logged_run(
    robot: &Robot,
    terrain: &Terrain,
    stepping: Stepping,
    dir: &std::path::Path,
) -> (RunSummary, f64) {
    let protocol = ProtocolConfig::for_run(robot, terrain, STEPS);
    let cfg = SimConfig {
        seed: 1,
        noise: SensorNoise::typical(),
        ..SimConfig::default()
    };
    let t0 = Instant::now();
    let mut sim = Simulator::new(robot, terrain, cfg).unwrap();
    sim.set_stepping(stepping);
    let meta = simulated_meta("bench".into(), robot, terrain, &protocol, 1, "uniform-wheel");
    let mut writer = McapWriter::create(dir.join(format!("{stepping:?}.mcap")), &meta).unwrap();
    let summary = run_drive(&mut sim, robot, &mut UniformWheel::new(1), &protocol, &mut writer).unwrap();
    writer.finish().unwrap();
    (summary, t0.elapsed().as_secs_f64())
}

fn drive(c: &mut Criterion) {
    let robot = Robot::resolve("warthog").unwrap().0;
    let terrain = Terrain::resolve("gravel").unwrap().0;
    let dir = tempfile::tempdir().unwrap();
    let mut best = [
        (RunSummary::default(), f64::INFINITY),
        (RunSummary::default(), f64::INFINITY),
    ];
    let steppings = [Stepping::Reference, Stepping::Fast];
    for _ in 0..3 {
        for (k, s) in steppings.iter().enumerate() {
            let r = logged_run(&robot, &terrain, *s, dir.path());
            if r.1 < best[k].1 {
                best[k] = r;
            }
        }
    }
    println!("warthog on gravel, {STEPS}-step DRIVE with MCAP logging, best of 3 (one core):");
    println!(
        "{:<10} {:>8} {:>12} {:>10} {:>14} {:>12}",
        "stepping", "wall_s", "simulated_s", "time_eff", "x_productive", "x_all_time"
    );
    for (k, s) in steppings.iter().enumerate() {
        let (sum, wall) = &best[k];
        let productive = sum.productive_time_s;
        println!(
            "{:<10} {:>8.3} {:>12.1} {:>10.3} {:>14.0} {:>12.0}",
            format!("{s:?}"),
            wall,
            sum.total_time_s,
            sum.time_efficiency,
            productive / wall,
            sum.total_time_s / wall
        );
    }
    // Per simulated second, so that the two runs' different interruption counts do not bias it.
    let per_sim_s = |k: usize| best[k].1 / best[k].0.total_time_s;
    println!(
        "fast / reference speed (wall per simulated second): {:.2}x",
        per_sim_s(0) / per_sim_s(1)
    );

    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    for s in steppings {
        let (sum, _) = logged_run(&robot, &terrain, s, dir.path());
        // Throughput in simulated milliseconds: criterion reports "elements/s" = sim ms per s.
        group.throughput(Throughput::Elements((sum.total_time_s * 1000.0).round() as u64));
        group.bench_function(format!("warthog_gravel_drive_{STEPS}_steps_logged_{s:?}"), |b| {
            b.iter(|| logged_run(&robot, &terrain, s, dir.path()).0.steps_completed)
        });
    }
    group.finish();
}

criterion_group!(benches, drive);
criterion_main!(benches);
