//! Kernel smoother: exact (direct summation) vs fast (binning + truncated separable Gaussian
//! convolution), s = 300, 3 000, 100 000 samples on 101² and 1001² grids over the Warthog's U.
//!
//! The exact smoother at 100 000 samples on 1001² is ~8e10 kernel evaluations (points inside U
//! only): in the criterion groups it is timed on a slab of grid rows (same spacing, same
//! samples) and reported per kernel evaluation (criterion throughput, elements = kernel
//! evaluations), which includes the slab's share of the kernel's factors (an `exp` per sample
//! and grid column or row). After the criterion groups, a side-by-side summary measures both
//! once on the whole grid in the same run and prints the ratio and the max |fast − exact|
//! relative to the slip's range.
//!
//! Run: `cargo bench --bench smoother` (or `-- fast` / `-- exact` to filter the groups).

use criterion::{BenchmarkId, Criterion, Throughput};
use drive_sim::analysis::smoother::{smooth_exact, smooth_fast, FastParams, Grid, KernelCovariance};
use drive_sim::kinematics::{BodyVelocity, CommandSpace, IdealDiffDrive};
use rand::{RngExt, SeedableRng};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn space() -> CommandSpace {
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

/// `n` commands uniform in U and a slip-like value: smooth in the command plus noise.
fn data(n: usize) -> (Vec<(f64, f64)>, Vec<f64>) {
    let s = space();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut pts = Vec::with_capacity(n);
    let mut val = Vec::with_capacity(n);
    while pts.len() < n {
        let p: (f64, f64) = (rng.random_range(-5.0..5.0), rng.random_range(-4.0..4.0));
        if s.contains_body(BodyVelocity::new(p.0, 0.0, p.1)) {
            pts.push(p);
            val.push(0.1 * p.0 * p.1.abs() + 0.2 * p.1 + rng.random_range(-0.3..0.3));
        }
    }
    (pts, val)
}

/// Rows of a 1001-wide slab so that the exact smoother does about 2e8 kernel evaluations.
fn slab_rows(s: usize, nvx: usize) -> usize {
    (2e8 / (s as f64 * nvx as f64)).ceil().max(1.0) as usize
}

fn inside(g: &Grid) -> usize {
    g.inside.iter().filter(|&&b| b).count()
}

fn benches(c: &mut Criterion) {
    let cov = KernelCovariance::default();
    let fast = FastParams::default();
    let sp = space();
    let mut group = c.benchmark_group("smoother");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for &n in &[101usize, 1001] {
        let grid = Grid::with_counts(&sp, n, n);
        for &s in &[300usize, 3_000, 100_000] {
            let (pts, val) = data(s);
            group.throughput(Throughput::Elements((inside(&grid) * s) as u64));
            group.bench_with_input(BenchmarkId::new(format!("fast/{n}x{n}"), s), &s, |b, _| {
                b.iter(|| smooth_fast(black_box(&grid), &cov, &fast, black_box(&pts), &[&val]))
            });
            // Exact: the full grid when it is at most ~2e8 evaluations, else a slab.
            let full = inside(&grid) * s;
            let g = if full as f64 <= 2.5e8 {
                grid.clone()
            } else {
                let rows = slab_rows(s, n);
                let mid = n / 2;
                grid.slab(mid - rows / 2..mid - rows / 2 + rows)
            };
            group.throughput(Throughput::Elements((inside(&g) * s) as u64));
            let label = if g.len() == grid.len() {
                format!("exact/{n}x{n}")
            } else {
                format!("exact/{n}x{}-slab-of-{n}x{n}", g.wz_rad_s.len())
            };
            group.bench_with_input(BenchmarkId::new(label, s), &s, |b, _| {
                b.iter(|| smooth_exact(black_box(&g), &cov, black_box(&pts), &[&val]))
            });
        }
    }
    group.finish();
}

/// One-shot side-by-side at the target size: s = 100 000 on 1001², both on the whole grid.
fn summary() {
    let cov = KernelCovariance::default();
    let sp = space();
    let n = 1001;
    let s = 100_000;
    let grid = Grid::with_counts(&sp, n, n);
    let (pts, val) = data(s);
    let range = val.iter().cloned().fold(f64::MIN, f64::max) - val.iter().cloned().fold(f64::MAX, f64::min);
    let t0 = Instant::now();
    let f = smooth_fast(&grid, &cov, &FastParams::default(), &pts, &[&val]);
    let t_fast = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let e = smooth_exact(&grid, &cov, &pts, &[&val]);
    let t_exact = t0.elapsed().as_secs_f64();
    let per_eval = t_exact / (inside(&grid) * s) as f64;
    let mut max_diff: f64 = 0.0;
    let mut max_bound: f64 = 0.0;
    for g in (0..grid.len()).filter(|&g| grid.inside[g]) {
        max_diff = max_diff.max((f.values[0][g] - e.values[0][g]).abs());
        max_bound = max_bound.max(f.error_bound.as_ref().unwrap()[0][g]);
    }
    println!(
        "summary s={s} grid {n}x{n} ({} points in U): fast {t_fast:.3} s; exact {t_exact:.1} s ({:.2} ns per kernel evaluation); ratio {:.0}x; max |fast-exact| {:.2e} = {:.2e} of range (bound {:.2e} of range)",
        inside(&grid),
        per_eval * 1e9,
        t_exact / t_fast,
        max_diff,
        max_diff / range,
        max_bound / range
    );
}

fn main() {
    // No plots: the machine has no fonts for criterion's plotters backend.
    let mut c = Criterion::default().without_plots().configure_from_args();
    benches(&mut c);
    c.final_summary();
    summary();
}
