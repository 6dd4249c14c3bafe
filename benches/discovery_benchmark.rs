//! A randomized benchmark of discovery on effects nobody named: cases drawn at random from
//! the families of the independent generator (`tests/common/generator.rs`, its own 1 kHz
//! integrator; `tests/common/random_cases.rs` draws them), each calibrated with the kinematic
//! model and discovery, and scored against its truth.
//!
//! ```sh
//! cargo bench --bench discovery_benchmark -- --cases 30 --nulls 10 --seed 1 --steps 90 --out out/discovery_benchmark
//! cargo bench --bench discovery_benchmark -- --list
//! cargo bench --bench discovery_benchmark -- --family deadband --cases 4
//! ```
//!
//! Per case: within flags (every channel of the calibrated model on the test steps within its
//! flag, 2× its floor steady, 3× transient and pose: `diagnosis_after.flagged()` empty), and
//! structure recovered: the exact catalogue effect kept when there is one; else a discovered
//! term kept on a quantity the effect acts on and none elsewhere; nothing kept when nothing is
//! to be found (null cases, zero-mean quantisation). On the null cases, a false discovery is
//! any effect kept or anything discovery added. Writes `summary.json` and `table.md` into
//! `--out`. Bad arguments: a message and exit code 2.

#[path = "../tests/common/mod.rs"]
#[allow(dead_code)] // the test helpers this benchmark does not use
mod common;

use clap::{Parser, ValueEnum};
#[path = "../tests/bench_cases/mod.rs"]
mod bench_cases;

use bench_cases::benchmark::{calibrate_case, score, Record};
use bench_cases::random_cases::{cases, Case, Family};
use common::CATALOGUE_WITHOUT_STRUCTURAL;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Which candidates the calibration is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
enum Catalogue {
    /// The catalogue without the structural effects discovery points to (as
    /// `tests/long/discovery.rs`): those can only come in through an equation, so the benchmark
    /// measures discovery rather than the catalogue's selection.
    WithoutStructural,
    /// Every effect the kinematic model can run (the calibration's default).
    Full,
    /// No catalogue effect: discovery alone on the base model (what its terms and the
    /// effects its equations name explain without the catalogue's stand-ins).
    None,
}

/// The command line.
#[derive(Debug, Parser)]
#[command(
    name = "discovery_benchmark",
    about = "Randomized benchmark of equation discovery on an independent generator"
)]
struct Args {
    /// Cases with an effect, cycling over the families (with --family: of that family).
    #[arg(long, default_value_t = 30)]
    cases: usize,
    /// Null cases (noise only).
    #[arg(long, default_value_t = 10)]
    nulls: usize,
    /// Seed of the draws (magnitudes, noise, splits).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// DRIVE steps per case (at least 20: the calibration splits them 60/20/20).
    #[arg(long, default_value_t = 90, value_parser = clap::value_parser!(u32).range(20..=2000))]
    steps: u32,
    /// Where summary.json and table.md go.
    #[arg(long, default_value = "out/discovery_benchmark")]
    out: PathBuf,
    /// Only this family (`--list` names them): --cases of it, or --nulls null cases for `null`.
    #[arg(long, value_parser = parse_family)]
    family: Option<Family>,
    /// Candidates of the calibration. Default: without-structural, so that what the
    /// benchmark scores is discovery (the structural effects can only come in through an
    /// equation), as tests/long/discovery.rs does.
    #[arg(long, value_enum, default_value_t = Catalogue::WithoutStructural)]
    catalogue: Catalogue,
    /// Cases run at once (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    jobs: Option<u16>,
    /// Also write each case's calibration report as `reports/<case>.json` into --out.
    #[arg(long)]
    reports: bool,
    /// List the families with their equations and magnitude ranges, and exit.
    #[arg(long)]
    list: bool,
    /// Passed by `cargo bench`; ignored.
    #[arg(long, hide = true)]
    bench: bool,
}

fn parse_family(name: &str) -> Result<Family, String> {
    Family::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Family::all().iter().map(|f| f.name()).collect();
        format!("unknown family {name:?}; the families are {}", names.join(", "))
    })
}

/// Generates the case's log and calibrates it; writes the calibration report into `reports`
/// when given.
fn run_case(case: &Case, steps: u32, catalogue: Catalogue, reports: Option<&Path>) -> Record {
    let t0 = Instant::now();
    // A generator or calibration that panics is one failed case, not a lost benchmark.
    let out = std::panic::catch_unwind(|| {
        let candidates = match catalogue {
            Catalogue::WithoutStructural => Some(
                CATALOGUE_WITHOUT_STRUCTURAL
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
            ),
            Catalogue::Full => None,
            Catalogue::None => Some(Vec::new()),
        };
        calibrate_case(case, steps, candidates)
    });
    let seconds = t0.elapsed().as_secs_f64();
    match out {
        Ok(Ok(r)) => {
            let mut rec = score(case, &r, seconds);
            if let Some(dir) = reports {
                let path = dir.join(format!("{}.json", case.name));
                if let Err(e) = drive_sim::output::write_json_atomic(&path, &r) {
                    rec.error = Some(format!("report not written: {e}"));
                }
            }
            rec
        }
        Ok(Err(e)) => Record::failed(case, seconds, e),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panicked".into());
            Record::failed(case, seconds, format!("panic: {msg}"))
        }
    }
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// Four significant digits whatever the magnitude (a drift per step is 1e-4).
fn number(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!(
            "{:.*}",
            (3 - v.abs().log10().floor().max(-1.0) as i32).max(0) as usize,
            v
        )
    } else {
        format!("{v:.3e}")
    }
}

fn magnitudes_text(rec: &Record) -> String {
    if rec.magnitudes.is_empty() {
        return "-".into();
    }
    rec.magnitudes
        .iter()
        .map(|(k, v)| format!("{k}={}", number(*v)))
        .collect::<Vec<_>>()
        .join(" ")
}

fn list_or_dash(v: &[String]) -> String {
    if v.is_empty() {
        "-".into()
    } else {
        v.join("; ")
    }
}

/// The case's line on the terminal.
fn line(rec: &Record) -> String {
    if let Some(e) = &rec.error {
        return format!(
            "{:<24} {:<32} FAILED: {e} ({:.1} s)",
            rec.name,
            magnitudes_text(rec),
            rec.seconds
        );
    }
    format!(
        "{:<24} {:<36} kept: {} | equations: {} | worst: {} {:.2}× floor (flag {}) | within flags: {} | structure: {} | {:.1} s",
        rec.name,
        magnitudes_text(rec),
        list_or_dash(&rec.kept),
        rec.equations.len(),
        rec.worst_channel,
        rec.worst_ratio,
        rec.worst_threshold,
        yes(rec.within_flags),
        yes(rec.structure),
        rec.seconds
    )
}

/// One family's figures.
#[derive(Debug, Clone, Serialize)]
struct FamilySummary {
    family: Family,
    equation: &'static str,
    cases: usize,
    within_flags: usize,
    structure: usize,
    /// Cases with an exact catalogue effect, and those whose values were within 10 % or 3 SE.
    with_exact: usize,
    values_ok: usize,
    /// Channels left flagged after calibration, with how many cases.
    left_flagged: BTreeMap<String, usize>,
    failed: usize,
    mean_seconds: f64,
    max_seconds: f64,
}

/// The whole run's figures.
#[derive(Debug, Clone, Serialize)]
struct Summary {
    cases: usize,
    nulls: usize,
    seed: u64,
    steps: u32,
    catalogue: Catalogue,
    family: Option<Family>,
    jobs: usize,
    wall_seconds: f64,
    /// Share of the effect cases with every channel within its flag.
    within_flags_share: f64,
    /// Share of the effect cases with the structure recovered.
    structure_share: f64,
    /// Null cases with a false discovery (any effect kept or anything added).
    null_false_discoveries: usize,
    /// Null cases with an equation found (tried or not).
    null_with_equations: usize,
    /// Null cases with a channel flagged after calibration.
    null_flagged: usize,
    /// Equations found over all cases, by the sparse regression validation chose for them.
    equations_by_solver: Vec<(String, usize)>,
    families: Vec<FamilySummary>,
    records: Vec<Record>,
}

/// Equations over all records, counted by the solver each used, in the solvers' order.
fn by_solver(records: &[Record]) -> Vec<(String, usize)> {
    drive_sim::calibration::discovery::SparseSolver::ALL
        .iter()
        .map(|s| {
            let name = s.name();
            let n = records
                .iter()
                .flat_map(|r| &r.solvers)
                .filter(|x| *x == name)
                .count();
            (name.to_string(), n)
        })
        .collect()
}

fn summarize(records: &[Record]) -> Vec<FamilySummary> {
    let mut families: Vec<Family> = records.iter().map(|r| r.family).collect();
    families.sort();
    families.dedup();
    // Effect families in the order of the list, the null last.
    families.sort_by_key(|f| Family::all().iter().position(|g| g == f));
    families
        .into_iter()
        .map(|family| {
            let rs: Vec<&Record> = records.iter().filter(|r| r.family == family).collect();
            let mut left_flagged = BTreeMap::new();
            for c in rs.iter().flat_map(|r| &r.flagged_after) {
                *left_flagged.entry(c.clone()).or_insert(0) += 1;
            }
            let secs: Vec<f64> = rs.iter().map(|r| r.seconds).collect();
            FamilySummary {
                family,
                equation: family.doc(),
                cases: rs.len(),
                within_flags: rs.iter().filter(|r| r.within_flags).count(),
                structure: rs.iter().filter(|r| r.structure).count(),
                with_exact: rs.iter().filter(|r| r.exact.is_some()).count(),
                values_ok: rs
                    .iter()
                    .filter(|r| r.exact.is_some() && !r.values.is_empty() && r.values.iter().all(|v| v.ok))
                    .count(),
                left_flagged,
                failed: rs.iter().filter(|r| r.error.is_some()).count(),
                mean_seconds: secs.iter().sum::<f64>() / secs.len().max(1) as f64,
                max_seconds: secs.iter().copied().fold(0.0, f64::max),
            }
        })
        .collect()
}

/// `k/n (p %)`.
fn share(k: usize, n: usize) -> String {
    if n == 0 {
        "-".into()
    } else {
        format!("{k}/{n} ({:.0} %)", 100.0 * k as f64 / n as f64)
    }
}

/// `text` as one markdown table cell (a `|` inside, as in `|u|`, would end it).
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

fn table_md(s: &Summary) -> String {
    let mut t = String::new();
    let effect_cases = s.records.iter().filter(|r| r.family != Family::Null).count();
    t.push_str("# Discovery benchmark\n\n");
    t.push_str(&format!(
        "`cargo bench --bench discovery_benchmark -- --cases {} --nulls {} --seed {} --steps {} --catalogue {}{}`: \
         kinematic model with discovery, {} jobs, {:.0} s wall.\n\n",
        s.cases,
        s.nulls,
        s.seed,
        s.steps,
        match s.catalogue {
            Catalogue::WithoutStructural => "without-structural",
            Catalogue::Full => "full",
            Catalogue::None => "none",
        },
        s.family.map(|f| format!(" --family {}", f.name())).unwrap_or_default(),
        s.jobs,
        s.wall_seconds
    ));
    t.push_str(&format!(
        "Effect cases: within flags {}, structure recovered {}. Null cases: false discoveries {}, \
         with an equation found {}, flagged after {}.\n\n",
        share(
            s.records
                .iter()
                .filter(|r| r.family != Family::Null && r.within_flags)
                .count(),
            effect_cases
        ),
        share(
            s.records
                .iter()
                .filter(|r| r.family != Family::Null && r.structure)
                .count(),
            effect_cases
        ),
        share(s.null_false_discoveries, s.nulls_run()),
        share(s.null_with_equations, s.nulls_run()),
        share(s.null_flagged, s.nulls_run()),
    ));
    t.push_str("| family | equation (ranges) | cases | within flags | structure | exact value ok | left flagged (cases) | s / case (max) |\n");
    t.push_str("|---|---|---|---|---|---|---|---|\n");
    for f in &s.families {
        let flagged: Vec<String> = f.left_flagged.iter().map(|(c, n)| format!("{c} ({n})")).collect();
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} ({:.1}) |\n",
            f.family.name(),
            cell(f.equation),
            f.cases,
            share(f.within_flags, f.cases),
            share(f.structure, f.cases),
            if f.with_exact == 0 {
                "-".into()
            } else {
                share(f.values_ok, f.with_exact)
            },
            list_or_dash(&flagged),
            f.mean_seconds,
            f.max_seconds
        ));
    }
    t.push_str("\n## Cases\n\n");
    t.push_str("| case | magnitudes | exact | kept | equations | worst channel after (RMSE/floor, flag) | within flags | structure | s |\n");
    t.push_str("|---|---|---|---|---|---|---|---|---|\n");
    for r in &s.records {
        let worst = match &r.error {
            Some(e) => format!("failed: {e}"),
            None => format!("{} {:.2} ({})", r.worst_channel, r.worst_ratio, r.worst_threshold),
        };
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.1} |\n",
            r.name,
            magnitudes_text(r),
            r.exact.as_deref().unwrap_or("-"),
            cell(&list_or_dash(&r.kept)),
            cell(&list_or_dash(&r.equations)),
            worst,
            yes(r.within_flags),
            yes(r.structure),
            r.seconds
        ));
    }
    t
}

impl Summary {
    fn nulls_run(&self) -> usize {
        self.records.iter().filter(|r| r.family == Family::Null).count()
    }
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        // clap prints the message; usage errors exit with 2, --help with 0.
        Err(e) => e.exit(),
    };
    if args.list {
        for f in Family::all() {
            println!("{:<22} {}", f.name(), f.doc());
        }
        return ExitCode::SUCCESS;
    }
    let (n, nulls, families): (usize, usize, Vec<Family>) = match args.family {
        Some(Family::Null) => (0, args.nulls, vec![]),
        Some(f) => (args.cases, 0, vec![f]),
        None => (args.cases, args.nulls, Family::EFFECTS.to_vec()),
    };
    if n + nulls == 0 {
        eprintln!("error: nothing to run: --cases and --nulls are both 0 (for --family null, --nulls must be positive)");
        return ExitCode::from(2);
    }
    let reports = args.out.join("reports");
    for dir in std::iter::once(&args.out).chain(args.reports.then_some(&reports)) {
        if let Err(e) = drive_sim::output::ensure_dir(dir, "--out") {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    }
    let jobs = args
        .jobs
        .map(usize::from)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(jobs).build() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: cannot start {jobs} threads: {e}");
            return ExitCode::FAILURE;
        }
    };
    let all = cases(&families, n, nulls, args.seed);
    println!(
        "discovery benchmark: {} cases ({} null), {} steps each, catalogue {:?}, {} jobs",
        all.len(),
        all.iter().filter(|c| c.family == Family::Null).count(),
        args.steps,
        args.catalogue,
        jobs
    );
    let t0 = Instant::now();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let total = all.len();
    let records: Vec<Record> = pool.install(|| {
        all.par_iter()
            .map(|case| {
                let rec = run_case(
                    case,
                    args.steps,
                    args.catalogue,
                    args.reports.then_some(&*reports),
                );
                let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                println!("[{k:>3}/{total}] {}", line(&rec));
                rec
            })
            .collect()
    });
    let wall_seconds = t0.elapsed().as_secs_f64();
    let (effect, nulls_run): (Vec<Record>, Vec<Record>) =
        records.iter().cloned().partition(|r| r.family != Family::Null);
    let frac = |k: usize, n: usize| if n == 0 { f64::NAN } else { k as f64 / n as f64 };
    let summary = Summary {
        cases: n,
        nulls,
        seed: args.seed,
        steps: args.steps,
        catalogue: args.catalogue,
        family: args.family,
        jobs,
        wall_seconds,
        within_flags_share: frac(effect.iter().filter(|r| r.within_flags).count(), effect.len()),
        structure_share: frac(effect.iter().filter(|r| r.structure).count(), effect.len()),
        null_false_discoveries: nulls_run.iter().filter(|r| r.false_discovery()).count(),
        null_with_equations: nulls_run.iter().filter(|r| !r.equations.is_empty()).count(),
        null_flagged: nulls_run.iter().filter(|r| !r.within_flags).count(),
        equations_by_solver: by_solver(&records),
        families: summarize(&records),
        records,
    };
    println!();
    println!(
        "{:<22} {:>5} {:>16} {:>16} {:>12} {:>10}  left flagged",
        "family", "cases", "within flags", "structure", "exact value", "s/case"
    );
    for f in &summary.families {
        let flagged: Vec<String> = f.left_flagged.iter().map(|(c, n)| format!("{c} ({n})")).collect();
        println!(
            "{:<22} {:>5} {:>16} {:>16} {:>12} {:>10.1}  {}",
            f.family.name(),
            f.cases,
            share(f.within_flags, f.cases),
            share(f.structure, f.cases),
            if f.with_exact == 0 {
                "-".into()
            } else {
                share(f.values_ok, f.with_exact)
            },
            f.mean_seconds,
            list_or_dash(&flagged)
        );
    }
    println!(
        "\neffect cases: within flags {}, structure recovered {}; null cases: false discoveries {}, \
         equations found {}, flagged after {}; {:.0} s wall",
        share(effect.iter().filter(|r| r.within_flags).count(), effect.len()),
        share(effect.iter().filter(|r| r.structure).count(), effect.len()),
        share(summary.null_false_discoveries, nulls_run.len()),
        share(summary.null_with_equations, nulls_run.len()),
        share(summary.null_flagged, nulls_run.len()),
        wall_seconds
    );
    let solvers: Vec<String> = summary
        .equations_by_solver
        .iter()
        .map(|(s, n)| format!("{s} {n}"))
        .collect();
    println!(
        "equations by the solver validation chose: {}",
        list_or_dash(&solvers)
    );
    let json = args.out.join("summary.json");
    let md = args.out.join("table.md");
    let written = drive_sim::output::write_json_atomic(&json, &summary)
        .and_then(|_| drive_sim::output::write_atomic(&md, table_md(&summary).as_bytes()));
    if let Err(e) = written {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    println!("wrote {} and {}", json.display(), md.display());
    ExitCode::SUCCESS
}
