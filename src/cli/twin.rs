//! `drive-sim twin LOG... --out DIR`: a judged twin of the robot from its runs
//! ([`drive_sim::twin`]).

use drive_sim::twin::{make_twin, TwinOptions, TwinRequest};
use std::io::Write;
use std::path::PathBuf;

/// Options of `drive-sim twin`.
#[derive(Debug, Clone, clap::Args)]
pub struct TwinArgs {
    /// The robot's runs (measured `.csv`, `.mcap` or bags), all of one robot; runs on the same
    /// ground share a terrain.
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// First seed (the calibration's split, the closed-loop runs, the judgements).
    #[arg(long, default_value_t = TwinOptions::default().seed)]
    pub seed: u64,
    /// Factor on the search's budget: larger for a longer search.
    #[arg(long, default_value_t = TwinOptions::default().budget)]
    pub budget: f64,
    /// With several runs, do not make a twin without each run to judge it on that run.
    #[arg(long)]
    pub no_leave_one_out: bool,
    /// Only these knobs may be tuned (effect names or base parameter names, comma-separated;
    /// default every knob of the model: the screening measures which matter).
    #[arg(long, value_delimiter = ',')]
    pub knobs: Option<Vec<String>>,
    /// Runs of the twin in each judgement.
    #[arg(long, default_value_t = TwinOptions::default().judge_sims)]
    pub sims: u32,
    /// Reference runs in each judgement (the smallest p-value is 1 / (references + 1)).
    #[arg(long, default_value_t = TwinOptions::default().judge_references)]
    pub references: u32,
    /// Output directory.
    #[arg(long, default_value = "out/twin")]
    pub out: PathBuf,
    /// The model to start from (`--robot`, `--terrain`: names or files; default each log's
    /// robot and terrain), and how to read a bag.
    #[command(flatten)]
    pub input: super::input::InputArgs,
}

/// Makes the twin, printing each stage as it ends, then the answer.
pub fn twin(args: &TwinArgs) -> anyhow::Result<()> {
    let req = TwinRequest {
        logs: args.logs.clone(),
        out: args.out.clone(),
        input: args.input.options(),
        options: TwinOptions {
            seed: args.seed,
            budget: args.budget,
            leave_one_out: !args.no_leave_one_out,
            judge_sims: args.sims,
            judge_references: args.references,
        },
        knobs: args.knobs.clone(),
    };
    let t0 = std::time::Instant::now();
    let twin = make_twin(&req, &|event| {
        eprintln!("drive-sim: [{:>6.1} s] {event}", t0.elapsed().as_secs_f64())
    })?;
    // As a write, not `print!`: a closed pipe is an error the caller handles, not a panic.
    std::io::stdout().write_all(
        format!(
            "Can compare tell the twin from the robot?\n{}",
            twin.report.answer
        )
        .as_bytes(),
    )?;
    let robot = args.out.join("twin/robot.toml");
    for g in &twin.report.grounds {
        eprintln!(
            "drive-sim: run it: drive-sim run --robot {} --terrain {}",
            robot.display(),
            args.out.join("twin").join(&g.terrain_file).display()
        );
    }
    eprintln!(
        "drive-sim: wrote {} files into {} ({:.0} s); the report: {}",
        twin.files.len(),
        args.out.display(),
        t0.elapsed().as_secs_f64(),
        args.out.join("twin.md").display()
    );
    Ok(())
}
