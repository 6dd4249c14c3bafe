//! The randomized discovery benchmark's cases (`benches/discovery_benchmark.rs`, and one case
//! per family in `tests/long/discovery_families.rs`): effects drawn at random from families of the
//! independent generator (`tests/common/generator.rs`), and how a case is calibrated and
//! scored. Kept apart from `tests/common` so that only the crates that draw cases compile them;
//! an including crate declares `mod common;` beside `mod bench_cases;`.

pub mod benchmark;
pub mod random_cases;
