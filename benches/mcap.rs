//! MCAP log throughput: writing and reading 36000 frames (30 min of DRIVE at 20 Hz) of the
//! ideal Husky, and the file size per simulated second (printed once). Encoding is measured
//! with both container writers side by side: ours (`Container::Chunked`, what logs use) and the
//! `mcap` crate's (`Container::Crate`), same frames, same records.
//!
//! `cargo bench --bench mcap`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use drive_sim::log::mcap::{encode_mcap_with, read_mcap, write_mcap, Container};
use drive_sim::log::{Frame, LogMeta, Nominal, Origin};
use drive_sim::protocol::{run_drive, sampler::UniformWheel, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::IdealPlant;
use std::hint::black_box;

const FRAMES: usize = 36_000;

fn frames() -> (Vec<Frame>, LogMeta) {
    let (robot, _) = Robot::resolve("husky").unwrap();
    let mut plant = IdealPlant::new(robot.idd(), 0.1);
    let mut sampler = UniformWheel::new(1);
    // 300 steps of 6 s plus interruptions and re-orientations: more than 36000 ticks.
    let cfg = ProtocolConfig {
        steps: 300,
        ..Default::default()
    };
    let mut frames = Vec::new();
    run_drive(&mut plant, &robot, &mut sampler, &cfg, &mut frames).unwrap();
    assert!(frames.len() >= FRAMES, "only {} frames", frames.len());
    frames.truncate(FRAMES);
    let meta = LogMeta {
        name: "bench".into(),
        robot: "husky".into(),
        terrain: "ideal".into(),
        rate_hz: cfg.rate_hz,
        window_s: cfg.window_s,
        windows_per_step: cfg.windows_per_step,
        samples_per_window: cfg.samples_per_window(),
        nominal: Nominal::from_robot(&robot),
        origin: Origin::Simulated {
            seed: 1,
            robot_file: String::new(),
            terrain_file: String::new(),
            sampler: "uniform-wheel".into(),
            injected: vec![],
        },
    };
    (frames, meta)
}

fn bench(c: &mut Criterion) {
    let (frames, meta) = frames();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.mcap");
    let s = write_mcap(&path, &meta, &frames).unwrap();
    let sim_s = frames[FRAMES - 1].stamp_s - frames[0].stamp_s + 1.0 / meta.rate_hz;
    let messages: u64 = s.messages_per_topic.values().sum();
    eprintln!(
        "mcap: {FRAMES} frames, {messages} messages, {:.1} simulated s: {} bytes, \
         {:.0} bytes per simulated s, {:.0} bytes per frame",
        sim_s,
        s.bytes,
        s.bytes as f64 / sim_s,
        s.bytes as f64 / FRAMES as f64
    );

    let mut g = c.benchmark_group("mcap");
    g.sample_size(10);
    g.throughput(Throughput::Elements(FRAMES as u64));
    g.bench_function("write_36000_frames", |b| {
        b.iter(|| write_mcap(&path, &meta, black_box(&frames)).unwrap())
    });
    write_mcap(&path, &meta, &frames).unwrap();
    for (name, container) in [("chunked", Container::Chunked), ("crate", Container::Crate)] {
        g.bench_function(format!("encode_36000_frames_{name}"), |b| {
            b.iter(|| encode_mcap_with(container, &meta, black_box(&frames), &path).unwrap())
        });
    }
    g.bench_function("read_36000_frames", |b| {
        b.iter(|| read_mcap(black_box(&path)).unwrap())
    });
    g.finish();
}

criterion_group! {
    name = benches;
    // criterion's plots need system fonts that headless machines (CI) lack: it panics there.
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
