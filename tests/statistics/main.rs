//! The statistics tier: measurements of the methods' statistical properties (a test's level
//! over several null runs, standard errors against the spread of refits), each taking a minute
//! or more. They are measurements, not checks of a change, so they run outside the plain
//! `cargo test` and CI's budget, on a change to the judge or the calibration's covariance:
//! `cargo test --locked --test statistics -- --nocapture`. CI keeps a null case of each
//! (`tests/long/judge.rs`; the covariance by hand in `crates/calibration/src/solver/covariance.rs`).

#[path = "../common/mod.rs"]
mod common;

mod judge_level;
mod standard_errors;
