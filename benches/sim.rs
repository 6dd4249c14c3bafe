//! Simulated seconds per wall second: the Warthog on asphalt driven by the DRIVE protocol.
//! Project target: a 300-step Warthog DRIVE (1800 s of robot time) in under 1.8 s on one core.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use drive_sim::protocol::sampler::UniformWheel;
use drive_sim::protocol::{run_drive, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SimConfig, Simulator};
use drive_sim::terrain::Terrain;

fn drive(c: &mut Criterion) {
    let robot = Robot::resolve("warthog").unwrap().0;
    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    for terrain_name in ["asphalt", "gravel"] {
        let terrain = Terrain::resolve(terrain_name).unwrap().0;
        let cfg = ProtocolConfig {
            steps: 10,
            ..Default::default()
        };
        // Throughput in simulated milliseconds: criterion reports "elements/s" = sim ms per s.
        let mut probe = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
        let mut frames = Vec::new();
        run_drive(&mut probe, &robot, &mut UniformWheel::new(1), &cfg, &mut frames).unwrap();
        let sim_ms = (probe.time_s() * 1000.0).round() as u64;
        group.throughput(Throughput::Elements(sim_ms));
        group.bench_function(format!("warthog_{terrain_name}_drive_10_steps"), |b| {
            b.iter(|| {
                let mut sim = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
                let mut frames = Vec::with_capacity(2000);
                run_drive(&mut sim, &robot, &mut UniformWheel::new(1), &cfg, &mut frames).unwrap();
                frames.len()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, drive);
criterion_main!(benches);
