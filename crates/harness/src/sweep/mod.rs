//! Sweeps: many DRIVE runs over robots × terrains × samplers × seeds, sharded across machines,
//! resumable, run in parallel, and merged into one table.
//!
//! - [`SweepMatrix`] is read from a TOML file and expanded into [`RunSpec`]s, each with a
//!   stable id such as `warthog-ice-uniform-wheel-s3`.
//! - [`select_shard`] picks the [`Shard`] of this process: `--shard`, or the index a batch
//!   system (SLURM array, Kubernetes Indexed Job, AWS Batch array) puts in the environment.
//! - [`run_sweep`] runs the specs of one [`Shard`] (spec index mod n) on all cores; each run
//!   gets its own directory `<out>/<id>/` and is marked complete by `<id>/done.json`, so an
//!   interrupted sweep restarted with the same arguments redoes only unfinished runs.
//! - [`merge`] combines the output directories of the shards into a [`MergedReport`] (JSON and
//!   CSV), listing the runs missing and those done more than once.
//!
//! What a run does is the caller's: a callback `Fn(&RunSpec, &Path) -> Result<Value>` that
//! writes its files in the given directory and returns the figures to tabulate.

mod batch;
mod matrix;
mod merge;
mod run;

pub use batch::{select_shard, select_shard_from_env, ShardChoice, ShardSource};
pub use matrix::{ProtocolOverrides, RunSpec, Shard, SweepMatrix};
pub use merge::{merge, Duplicate, MergedReport};
pub use run::{
    run_specs, run_sweep, run_sweep_with_progress, RunOptions, RunOutcome, RunRecord, SweepReport, DONE_FILE,
    MANIFEST_FILE,
};
