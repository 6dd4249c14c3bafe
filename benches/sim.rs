//! Speed of the simulator with MCAP logging: a Warthog DRIVE on gravel written to an MCAP file,
//! as `drive-sim run` does, in three configurations: the reference physics step with the `mcap`
//! crate's container writer (the oracles of the `oracle` features), the fast step with the
//! crate's writer, and the fast step with drive-sim's writer at zstd level -1 (what `drive-sim
//! run` does).
//!
//! Before criterion, a side-by-side table on the 300-step workload: each configuration timed on
//! the same run (best of 3, interleaved), with the real-time factor over productive robot time
//! (steps × 6 s) and over all simulated time, and the ratios. Criterion then times 30-step runs
//! (short samples).
//! Target: a 300-step Warthog DRIVE with logging ≥ 2500× real time in productive time on one core.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use drive_sim::harness::simulate::simulated_meta;
use drive_sim::log::mcap::{Container, McapWriter};
use drive_sim::protocol::sampler::UniformWheel;
use drive_sim::protocol::{run_drive, ProtocolConfig, RunSummary};
use drive_sim::robot::Robot;
use drive_sim::sim::{SensorNoise, SimConfig, Simulator, Stepping};
use drive_sim::terrain::Terrain;
use std::time::Instant;

/// Steps of the side-by-side table and of criterion's samples.
const TABLE_STEPS: u32 = 300;
const STEPS: u32 = 30;

/// A configuration timed: physics stepping and MCAP container writer.
type Config = (Stepping, Container);

/// One logged DRIVE run; returns its summary and wall time.
fn logged_run(
    robot: &Robot,
    terrain: &Terrain,
    (stepping, container): Config,
    steps: u32,
    dir: &std::path::Path,
) -> (RunSummary, f64) {
    let protocol = ProtocolConfig::for_run(robot, terrain, steps);
    let cfg = SimConfig {
        seed: 1,
        noise: SensorNoise::typical(),
        ..SimConfig::default()
    };
    let t0 = Instant::now();
    let mut sim = Simulator::new(robot, terrain, cfg).unwrap();
    sim.set_stepping(stepping);
    let meta = simulated_meta("bench".into(), robot, terrain, &protocol, 1, "uniform-wheel");
    let path = dir.join(format!("{stepping:?}_{container:?}.mcap"));
    let mut writer = McapWriter::create_with_container(path, &meta, None, container).unwrap();
    let summary = run_drive(&mut sim, robot, &mut UniformWheel::new(1), &protocol, &mut writer).unwrap();
    writer.finish().unwrap();
    (summary, t0.elapsed().as_secs_f64())
}

fn drive(c: &mut Criterion) {
    let robot = Robot::resolve("warthog").unwrap().0;
    let terrain = Terrain::resolve("gravel").unwrap().0;
    let dir = tempfile::tempdir().unwrap();
    let configs: [Config; 3] = [
        (Stepping::Reference, Container::Crate),
        (Stepping::Fast, Container::Crate),
        (Stepping::Fast, Container::Chunked),
    ];
    let mut best = [(); 3].map(|_| (RunSummary::default(), f64::INFINITY));
    for _ in 0..3 {
        for (k, c) in configs.iter().enumerate() {
            let r = logged_run(&robot, &terrain, *c, TABLE_STEPS, dir.path());
            if r.1 < best[k].1 {
                best[k] = r;
            }
        }
    }
    println!("warthog on gravel, {TABLE_STEPS}-step DRIVE with MCAP logging, best of 3 (one core):");
    println!(
        "{:<10} {:<15} {:>8} {:>12} {:>10} {:>14} {:>12}",
        "stepping", "container", "wall_s", "simulated_s", "time_eff", "x_productive", "x_all_time"
    );
    for (k, (s, c)) in configs.iter().enumerate() {
        let (sum, wall) = &best[k];
        println!(
            "{:<10} {:<15} {:>8.3} {:>12.1} {:>10.3} {:>14.0} {:>12.0}",
            format!("{s:?}"),
            format!("{c:?}"),
            wall,
            sum.total_time_s,
            sum.time_efficiency,
            sum.productive_time_s / wall,
            sum.total_time_s / wall
        );
    }
    // Per simulated second, so that different interruption counts (the reference stepping's
    // runs diverge from the fast one's after the first steps) do not bias the ratios.
    let per_sim_s = |k: usize| best[k].1 / best[k].0.total_time_s;
    println!(
        "speed per simulated second: fast step / reference step {:.2}x; drive-sim's container / the crate's {:.2}x; \
         drive-sim run / reference with the crate's writer {:.2}x",
        per_sim_s(0) / per_sim_s(1),
        per_sim_s(1) / per_sim_s(2),
        per_sim_s(0) / per_sim_s(2)
    );

    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    for c in configs {
        let (sum, _) = logged_run(&robot, &terrain, c, STEPS, dir.path());
        // Throughput in simulated milliseconds: criterion reports "elements/s" = sim ms per s.
        group.throughput(Throughput::Elements((sum.total_time_s * 1000.0).round() as u64));
        let name = format!("warthog_gravel_drive_{STEPS}_steps_logged_{:?}_{:?}", c.0, c.1);
        group.bench_function(name, |b| {
            b.iter(|| {
                logged_run(&robot, &terrain, c, STEPS, dir.path())
                    .0
                    .steps_completed
            })
        });
    }
    group.finish();
}

criterion_group!(benches, drive);
criterion_main!(benches);
