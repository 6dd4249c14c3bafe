//! `drive-sim demo` (and `drive-sim` with no arguments): runs
//! [`drive_sim::harness::demo`] and says what it is doing.

use drive_sim::harness::demo::{run_demo, DemoEvent, DemoOptions, SCENARIOS};
use drive_sim::harness::run::{describe, RunEvent};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// Options of `drive-sim demo`.
#[derive(Debug, Clone, clap::Args)]
pub struct DemoArgs {
    /// Steps per run (paper: at least 150).
    #[arg(long, default_value_t = 150)]
    pub steps: u32,
    /// Seed of the runs.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
}

impl Default for DemoArgs {
    fn default() -> Self {
        let d = DemoOptions::default();
        Self {
            steps: d.steps,
            seed: d.seed,
            out: d.out,
        }
    }
}

/// Runs the scenarios, then analyses their logs together.
pub fn demo(args: &DemoArgs) -> anyhow::Result<()> {
    eprintln!(
        "drive-sim demo: {} simulated DRIVE runs of {} steps (seed {}), then their analysis, into {}",
        SCENARIOS.len(),
        args.steps,
        args.seed,
        args.out.display()
    );
    let opts = DemoOptions {
        steps: args.steps,
        seed: args.seed,
        out: args.out.clone(),
    };
    let style =
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} steps, {elapsed} elapsed, eta {eta}")?
            .progress_chars("=> ");
    let mut bar = ProgressBar::hidden();
    run_demo(&opts, &mut |e| match e {
        DemoEvent::Running { robot, terrain } => {
            eprintln!("drive-sim demo: {robot} on {terrain}");
            bar = ProgressBar::new(args.steps as u64).with_style(style.clone());
            bar.set_prefix(format!("{robot} on {terrain}"));
        }
        DemoEvent::Run(RunEvent::Started { .. }) => {}
        DemoEvent::Run(RunEvent::StepDone(n)) => bar.set_position(n as u64),
        DemoEvent::Run(RunEvent::Failed { partial }) => {
            bar.abandon();
            eprintln!(
                "drive-sim demo: run failed; what was simulated is kept in {} (not a complete log)",
                partial.display()
            )
        }
        DemoEvent::Run(RunEvent::Interrupted { log }) => {
            bar.abandon();
            eprintln!("drive-sim demo: interrupted; closed {}", log.display())
        }
        DemoEvent::RunDone(r) => {
            bar.finish_and_clear();
            eprintln!("  {}", describe(r))
        }
        DemoEvent::Analysis(a) => super::analyze::print_progress(a),
    })?;
    eprintln!(
        "drive-sim demo: open {} in a browser; the MCAP logs in {} open in Foxglove.",
        args.out.join("report.html").display(),
        args.out.join("logs").display()
    );
    Ok(())
}
