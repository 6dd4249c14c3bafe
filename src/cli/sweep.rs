//! `drive-sim sweep` and `drive-sim sweep-merge`: many simulated DRIVE runs from a matrix file,
//! sharded and resumable (see [`drive_sim::harness::sweep`]; what each run does is
//! [`drive_sim::harness::sweep_run`]), and the merge of the shards' tables.

use super::sweep_args::{MergeArgs, SweepArgs};
use drive_sim::harness::sweep::{merge, run_sweep_with_progress, RunOutcome, SweepMatrix};
use drive_sim::harness::sweep_run::sweep_run_with;

/// `drive-sim sweep`.
pub fn sweep(args: &SweepArgs) -> anyhow::Result<()> {
    let matrix = SweepMatrix::load(&args.matrix)?;
    matrix.check_names(&args.matrix)?;
    drive_sim::harness::sweep_run::validate_matrix(&matrix, &args.matrix)?;
    let choice = args.shard_choice(&|name| std::env::var(name).ok())?;
    let opts = args.options(choice.shard);
    let total = matrix.shard(opts.shard).len();
    eprintln!("drive-sim sweep: {choice}");
    eprintln!(
        "drive-sim sweep: `{}`, shard {}/{}: {total} of {} runs into {}{}",
        matrix.name,
        opts.shard.index,
        opts.shard.count,
        matrix.len(),
        opts.out_dir.display(),
        if args.keep_logs {
            " (keeping each run's MCAP log)"
        } else {
            ""
        }
    );
    let keep = args.keep_logs;
    let run =
        |spec: &drive_sim::harness::sweep::RunSpec, dir: &std::path::Path| sweep_run_with(spec, dir, keep);
    let report = run_sweep_with_progress(&matrix, &opts, run, |o| match o {
        RunOutcome::Done(r) => eprintln!("  done    {}", r.spec.id),
        RunOutcome::Skipped(r) => eprintln!("  skipped {} (complete)", r.spec.id),
        RunOutcome::Failed { id, message } => eprintln!("  FAILED  {id}: {message}"),
    })?;
    println!(
        "{} done, {} skipped (already complete), {} failed",
        report.done(),
        report.skipped(),
        report.failed()
    );
    if drive_sim::interrupt::requested() {
        eprintln!(
            "drive-sim sweep: interrupted; {} runs complete are kept; rerun the same command to resume where it stopped",
            report.done() + report.skipped()
        );
        return Err(drive_sim::Error::Interrupted {
            step: (report.done() + report.skipped()) as u32,
            time_s: 0.0,
        }
        .into());
    }
    if report.failed() > 0 {
        anyhow::bail!(
            "{} runs failed; rerun the same command to retry them",
            report.failed()
        );
    }
    Ok(())
}

/// `drive-sim sweep-merge`.
pub fn sweep_merge(args: &MergeArgs) -> anyhow::Result<()> {
    let merged = merge(&args.dirs)?;
    let (json_path, csv_path) = merged.write(&args.out)?;
    println!(
        "{} runs merged into {} and {}{}{}",
        merged.rows.len(),
        json_path.display(),
        csv_path.display(),
        if merged.missing.is_empty() {
            String::new()
        } else {
            format!(
                "; {} runs missing: {}",
                merged.missing.len(),
                merged.missing.join(", ")
            )
        },
        if merged.duplicates.is_empty() {
            String::new()
        } else {
            format!(
                "; {} runs done more than once (first kept): {}",
                merged.duplicates.len(),
                merged
                    .duplicates
                    .iter()
                    .map(|d| format!(
                        "{} in {}",
                        d.id,
                        d.dirs
                            .iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(" and ")
                    ))
                    .collect::<Vec<_>>()
                    .join("; ")
            )
        }
    );
    Ok(())
}
