//! The demonstration run by `drive-sim` with no arguments: simulated DRIVE runs on contrasting
//! terrains, analysed together, so a first-time user gets the paper's figures in one command.

use super::analyze::{analyze, AnalyzeArgs};
use super::run::{describe, run, RunArgs};
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
        Self {
            steps: 150,
            seed: 7,
            out: PathBuf::from("out/demo"),
        }
    }
}

/// The scenarios of the demonstration: the Warthog on the paper's contrasting terrains, and the
/// Husky on mud, where its motors saturate.
pub const SCENARIOS: &[(&str, &str)] = &[
    ("warthog", "asphalt"),
    ("warthog", "gravel"),
    ("warthog", "ice"),
    ("husky", "mud"),
];

/// Runs the scenarios, then analyses their logs together.
pub fn demo(args: &DemoArgs) -> anyhow::Result<()> {
    eprintln!(
        "drive-sim demo: {} simulated DRIVE runs of {} steps (seed {}), then their analysis, into {}",
        SCENARIOS.len(),
        args.steps,
        args.seed,
        args.out.display()
    );
    let mut logs = Vec::new();
    for (robot, terrain) in SCENARIOS {
        eprintln!("drive-sim demo: {robot} on {terrain}");
        let r = run(&RunArgs {
            robot: robot.to_string(),
            terrain: terrain.to_string(),
            steps: args.steps,
            seed: args.seed,
            sampler: "uniform-wheel".into(),
            noise: "typical".into(),
            physics_hz: 100.0,
            inject: vec![],
            out: args.out.join("logs"),
            name: None,
            quiet: false,
        })?;
        eprintln!("  {}", describe(&r));
        logs.push(r.mcap);
    }
    analyze(&AnalyzeArgs {
        logs,
        out: args.out.clone(),
        resolution: 0.1,
        kernel_variance: None,
        input: Default::default(),
    })?;
    eprintln!(
        "drive-sim demo: open {} in a browser; the MCAP logs in {} open in Foxglove.",
        args.out.join("report.html").display(),
        args.out.join("logs").display()
    );
    Ok(())
}
