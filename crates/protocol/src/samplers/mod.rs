//! The sampling strategies, one file each, and their registry.
//!
//! To add a strategy: write `my_strategy.rs` here with a type implementing
//! [`Sampler`] and a `pub const ENTRY: SamplerEntry`, then add
//! `my_strategy` to the `register!` list below. That one line declares the module and puts
//! the entry in [`REGISTRY`], which `make_sampler` and `SAMPLERS` read.

use super::sampler::Sampler;
use super::ProtocolConfig;

pub mod geometry;
/// Not a registered strategy: draws in the quadrants of a run's commands (a twin judged or
/// tuned against that run).
pub mod matched;
pub mod metrics;

/// A strategy the command line and sweeps can name.
#[derive(Debug, Clone, Copy)]
pub struct SamplerEntry {
    /// Name used on the command line, in sweep files and in reports (kebab-case).
    pub name: &'static str,
    /// One-line description for `--help` and reports.
    pub summary: &'static str,
    /// Builds the strategy with its default parameters, seeded with the run's seed, for a run
    /// with the given protocol parameters (strategies that predict steps read them).
    pub build: fn(u64, &ProtocolConfig) -> Box<dyn Sampler>,
}

/// Declares each strategy module and lists its `ENTRY` in [`REGISTRY`], in order.
macro_rules! register {
    ($($module:ident),* $(,)?) => {
        $(pub mod $module;)*
        /// Every known strategy, in the order they are listed to users.
        pub const REGISTRY: &[SamplerEntry] = &[$($module::ENTRY),*];
    };
}

register! {
    uniform_wheel,
    uniform_body,
    halton,
    uniform_step,
    spread_accel,
    active,
    boundary_aware,
}

/// The Warthog's command space, for the strategies' tests: its robot file's.
#[cfg(test)]
pub(crate) fn warthog_space() -> drive_sim_model::kinematics::CommandSpace {
    let (robot, _) = drive_sim_model::robot::Robot::resolve("warthog").expect("the built-in Warthog");
    robot.command_space()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{make_sampler, SAMPLERS};

    #[test]
    fn registry_names_are_unique_and_match_the_built_samplers() {
        let mut names: Vec<&str> = REGISTRY.iter().map(|e| e.name).collect();
        assert_eq!(names, SAMPLERS);
        for e in REGISTRY {
            assert_eq!((e.build)(1, &ProtocolConfig::default()).name(), e.name);
            assert_eq!(make_sampler(e.name, 1).unwrap().name(), e.name);
            assert!(!e.summary.is_empty());
        }
        names.sort();
        names.dedup();
        assert_eq!(names.len(), REGISTRY.len());
        assert!(make_sampler("no-such-sampler", 1).is_none());
    }
}
