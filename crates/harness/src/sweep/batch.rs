//! Which shard this process runs when a batch system starts it: the array index and size that
//! SLURM, Kubernetes and AWS Batch put in the environment, checked against each other.
//!
//! | engine | index | count |
//! |---|---|---|
//! | SLURM job array | (`SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN`) / `SLURM_ARRAY_TASK_STEP` | `SLURM_ARRAY_TASK_COUNT` |
//! | Kubernetes Indexed Job | `JOB_COMPLETION_INDEX` | `--shard-count` (the Job's `completions`) |
//! | AWS Batch array job | `AWS_BATCH_JOB_ARRAY_INDEX` | `--shard-count` (the array `size`) |
//!
//! `SLURM_ARRAY_TASK_MIN` counts as 0 and `SLURM_ARRAY_TASK_STEP` as 1 when unset. An explicit
//! `--shard i/n` wins over the environment.

use super::matrix::Shard;
use crate::error::{Error, Result};

/// Where the shard came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ShardSource {
    /// `--shard i/n` on the command line.
    CommandLine,
    /// A SLURM job array.
    Slurm,
    /// A Kubernetes Indexed Job.
    Kubernetes,
    /// An AWS Batch array job.
    AwsBatch,
    /// Nothing given and no batch system: the whole sweep.
    Whole,
}

impl ShardSource {
    /// How a user names it.
    pub fn describe(&self) -> &'static str {
        match self {
            ShardSource::CommandLine => "--shard",
            ShardSource::Slurm => "SLURM job array",
            ShardSource::Kubernetes => "Kubernetes Indexed Job",
            ShardSource::AwsBatch => "AWS Batch array job",
            ShardSource::Whole => "no --shard and no batch-system index: the whole sweep",
        }
    }
}

/// The shard of this process, where it came from, and the variables it was read from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardChoice {
    /// The shard.
    pub shard: Shard,
    /// Where it came from.
    pub source: ShardSource,
    /// The environment variables read, `NAME=value`, for the user to check.
    pub evidence: Vec<String>,
}

impl std::fmt::Display for ShardChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "shard {} from {}", self.shard, self.source.describe())?;
        if !self.evidence.is_empty() {
            write!(f, " ({})", self.evidence.join(", "))?;
        }
        Ok(())
    }
}

fn env_error(variable: &str, message: impl Into<String>) -> Error {
    Error::config("<environment>", variable, message)
}

/// A variable's value as a non-negative integer, `None` when unset or empty.
fn read_usize(env: &dyn Fn(&str) -> Option<String>, name: &str) -> Result<Option<usize>> {
    match env(name) {
        None => Ok(None),
        Some(v) if v.trim().is_empty() => Ok(None),
        Some(v) => v
            .trim()
            .parse::<usize>()
            .map(Some)
            .map_err(|_| env_error(name, format!("`{v}` is not a non-negative integer"))),
    }
}

fn checked(index: usize, count: usize, source: ShardSource, evidence: Vec<String>) -> Result<ShardChoice> {
    if count == 0 {
        return Err(env_error(
            &evidence.join(", "),
            "the shard count must be at least 1",
        ));
    }
    if index >= count {
        return Err(env_error(
            &evidence.join(", "),
            format!(
                "the {} gives shard index {index}, out of range for {count} shards (0..={})",
                source.describe(),
                count - 1
            ),
        ));
    }
    Ok(ShardChoice {
        shard: Shard { index, count },
        source,
        evidence,
    })
}

fn slurm(env: &dyn Fn(&str) -> Option<String>, shard_count: Option<usize>) -> Result<Option<ShardChoice>> {
    let Some(id) = read_usize(env, "SLURM_ARRAY_TASK_ID")? else {
        return Ok(None);
    };
    let min = read_usize(env, "SLURM_ARRAY_TASK_MIN")?;
    let step = read_usize(env, "SLURM_ARRAY_TASK_STEP")?;
    let count = read_usize(env, "SLURM_ARRAY_TASK_COUNT")?;
    let mut evidence = vec![format!("SLURM_ARRAY_TASK_ID={id}")];
    if let Some(m) = min {
        evidence.push(format!("SLURM_ARRAY_TASK_MIN={m}"));
    }
    if let Some(s) = step {
        evidence.push(format!("SLURM_ARRAY_TASK_STEP={s}"));
    }
    if let Some(c) = count {
        evidence.push(format!("SLURM_ARRAY_TASK_COUNT={c}"));
    }
    let (min, step) = (min.unwrap_or(0), step.unwrap_or(1));
    if step == 0 {
        return Err(env_error("SLURM_ARRAY_TASK_STEP", "must be at least 1"));
    }
    if id < min || (id - min) % step != 0 {
        return Err(env_error(
            "SLURM_ARRAY_TASK_ID",
            format!("{id} is not on the array's grid min {min}, step {step}"),
        ));
    }
    let count = match (count, shard_count) {
        (Some(c), Some(n)) if c != n => {
            return Err(env_error(
                "SLURM_ARRAY_TASK_COUNT",
                format!("the SLURM array has {c} tasks but --shard-count says {n}"),
            ))
        }
        (Some(c), _) => c,
        (None, Some(n)) => n,
        (None, None) => {
            return Err(env_error(
                "SLURM_ARRAY_TASK_COUNT",
                "SLURM_ARRAY_TASK_ID is set but the array size is not: give --shard-count",
            ))
        }
    };
    checked((id - min) / step, count, ShardSource::Slurm, evidence).map(Some)
}

/// An engine whose index variable needs `--shard-count` for the count.
fn indexed(
    env: &dyn Fn(&str) -> Option<String>,
    variable: &str,
    source: ShardSource,
    shard_count: Option<usize>,
) -> Result<Option<ShardChoice>> {
    let Some(index) = read_usize(env, variable)? else {
        return Ok(None);
    };
    let Some(count) = shard_count else {
        return Err(env_error(
            variable,
            format!(
                "{variable}={index} says this is task {index} of a {}, but the number of tasks is not known: give --shard-count N",
                source.describe()
            ),
        ));
    };
    checked(index, count, source, vec![format!("{variable}={index}")]).map(Some)
}

/// The shard to run: `explicit` (`--shard`) if given, else the one batch system's index in
/// `env`, else the whole sweep. Errors when a variable is malformed, when the index is out of
/// range, when a count is missing, and when two batch systems name different shards.
pub fn select_shard(
    explicit: Option<Shard>,
    shard_count: Option<usize>,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<ShardChoice> {
    if let Some(shard) = explicit {
        if shard_count.is_some_and(|n| n != shard.count) {
            return Err(Error::config(
                "--shard-count",
                "n",
                format!(
                    "--shard {shard} and --shard-count {} disagree",
                    shard_count.unwrap_or(0)
                ),
            ));
        }
        return Ok(ShardChoice {
            shard,
            source: ShardSource::CommandLine,
            evidence: vec![],
        });
    }
    let found: Vec<ShardChoice> = [
        slurm(env, shard_count)?,
        indexed(env, "JOB_COMPLETION_INDEX", ShardSource::Kubernetes, shard_count)?,
        indexed(
            env,
            "AWS_BATCH_JOB_ARRAY_INDEX",
            ShardSource::AwsBatch,
            shard_count,
        )?,
    ]
    .into_iter()
    .flatten()
    .collect();
    match found.as_slice() {
        [] => {
            if let Some(n) = shard_count {
                return Err(Error::config(
                    "--shard-count",
                    "n",
                    format!(
                        "--shard-count {n} needs a batch-system index (SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or AWS_BATCH_JOB_ARRAY_INDEX) or use --shard i/{n}"
                    ),
                ));
            }
            Ok(ShardChoice {
                shard: Shard::default(),
                source: ShardSource::Whole,
                evidence: vec![],
            })
        }
        [first, rest @ ..] => {
            if let Some(other) = rest.iter().find(|c| c.shard != first.shard) {
                return Err(env_error(
                    &format!("{}; {}", first.evidence.join(", "), other.evidence.join(", ")),
                    format!(
                        "the {} says shard {} but the {} says shard {}; unset the variables of the one not running this job",
                        first.source.describe(),
                        first.shard,
                        other.source.describe(),
                        other.shard
                    ),
                ));
            }
            let mut choice = first.clone();
            for c in rest {
                choice.evidence.extend(c.evidence.iter().cloned());
            }
            Ok(choice)
        }
    }
}

/// [`select_shard`] with the process's environment.
pub fn select_shard_from_env(explicit: Option<Shard>, shard_count: Option<usize>) -> Result<ShardChoice> {
    select_shard(explicit, shard_count, &|name| std::env::var(name).ok())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn pick(vars: &[(&str, &str)], explicit: Option<Shard>, count: Option<usize>) -> Result<ShardChoice> {
        let map: HashMap<String, String> = vars.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        select_shard(explicit, count, &|n| map.get(n).cloned())
    }

    fn shard(i: usize, n: usize) -> Shard {
        Shard::new(i, n).unwrap()
    }

    #[test]
    fn slurm_index_is_offset_by_min_and_divided_by_step() {
        let c = pick(
            &[
                ("SLURM_ARRAY_TASK_ID", "7"),
                ("SLURM_ARRAY_TASK_MIN", "1"),
                ("SLURM_ARRAY_TASK_STEP", "2"),
                ("SLURM_ARRAY_TASK_COUNT", "5"),
            ],
            None,
            None,
        )
        .unwrap();
        assert_eq!((c.shard, c.source.clone()), (shard(3, 5), ShardSource::Slurm));
        assert!(c.to_string().contains("SLURM job array") && c.to_string().contains("SLURM_ARRAY_TASK_ID=7"));
        // MIN 0 and STEP 1 when unset.
        let c = pick(
            &[("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "4")],
            None,
            None,
        )
        .unwrap();
        assert_eq!(c.shard, shard(2, 4));
        // The count may come from --shard-count when SLURM does not give it.
        let c = pick(&[("SLURM_ARRAY_TASK_ID", "2")], None, Some(3)).unwrap();
        assert_eq!(c.shard, shard(2, 3));
    }

    #[test]
    fn kubernetes_and_aws_take_the_count_from_the_option() {
        let c = pick(&[("JOB_COMPLETION_INDEX", "4")], None, Some(6)).unwrap();
        assert_eq!((c.shard, c.source), (shard(4, 6), ShardSource::Kubernetes));
        let c = pick(&[("AWS_BATCH_JOB_ARRAY_INDEX", "0")], None, Some(2)).unwrap();
        assert_eq!((c.shard, c.source), (shard(0, 2), ShardSource::AwsBatch));
        let e = pick(&[("JOB_COMPLETION_INDEX", "4")], None, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("JOB_COMPLETION_INDEX") && e.contains("--shard-count"),
            "{e}"
        );
    }

    #[test]
    fn nothing_set_is_the_whole_sweep_and_explicit_wins() {
        let c = pick(&[], None, None).unwrap();
        assert_eq!((c.shard, c.source), (Shard::default(), ShardSource::Whole));
        let c = pick(&[("JOB_COMPLETION_INDEX", "4")], Some(shard(1, 2)), None).unwrap();
        assert_eq!((c.shard, c.source), (shard(1, 2), ShardSource::CommandLine));
        let e = pick(&[], None, Some(3)).unwrap_err().to_string();
        assert!(e.contains("--shard-count 3 needs"), "{e}");
        let e = pick(&[], Some(shard(1, 2)), Some(3)).unwrap_err().to_string();
        assert!(e.contains("disagree"), "{e}");
    }

    #[test]
    fn out_of_range_and_malformed_indices_are_errors() {
        let e = pick(
            &[("SLURM_ARRAY_TASK_ID", "4"), ("SLURM_ARRAY_TASK_COUNT", "4")],
            None,
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("out of range for 4 shards"), "{e}");
        let e = pick(&[("JOB_COMPLETION_INDEX", "9")], None, Some(3))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("JOB_COMPLETION_INDEX=9") && e.contains("out of range"),
            "{e}"
        );
        let e = pick(&[("AWS_BATCH_JOB_ARRAY_INDEX", "x")], None, Some(3))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("AWS_BATCH_JOB_ARRAY_INDEX") && e.contains("`x`"),
            "{e}"
        );
        let e = pick(
            &[("SLURM_ARRAY_TASK_ID", "1"), ("SLURM_ARRAY_TASK_MIN", "2")],
            None,
            Some(3),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("not on the array's grid"), "{e}");
        let e = pick(
            &[("SLURM_ARRAY_TASK_ID", "1"), ("SLURM_ARRAY_TASK_COUNT", "4")],
            None,
            Some(3),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("4 tasks but --shard-count says 3"), "{e}");
    }

    #[test]
    fn two_engines_must_agree() {
        let e = pick(
            &[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
                ("JOB_COMPLETION_INDEX", "2"),
            ],
            None,
            None,
        )
        .unwrap_err()
        .to_string();
        // The Kubernetes index without a count is reported first; with the count, they disagree.
        assert!(e.contains("--shard-count"), "{e}");
        let e = pick(
            &[("SLURM_ARRAY_TASK_ID", "1"), ("JOB_COMPLETION_INDEX", "2")],
            None,
            Some(4),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("SLURM job array says shard 1/4") && e.contains("Indexed Job says shard 2/4"),
            "{e}"
        );
        let c = pick(
            &[("SLURM_ARRAY_TASK_ID", "2"), ("AWS_BATCH_JOB_ARRAY_INDEX", "2")],
            None,
            Some(4),
        )
        .unwrap();
        assert_eq!(c.shard, shard(2, 4));
        assert_eq!(c.evidence.len(), 2);
    }
}
