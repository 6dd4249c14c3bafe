//! The two sides of a comparison analysed once: the real run ([`PreparedReal`], with its
//! bootstrap statistics and maps) and a simulated run ([`PreparedSim`]), so that a closed-loop
//! search or the judge compares many runs without analysing any of them twice.

use crate::error::Result;
use crate::metrics::{resampled, rows, StepRow};
use crate::options::check_options;
use crate::{analysis_of, records_time, tf, CompareOptions, Input, Warning};
use drive_sim_analysis::bootstrap::MIN_STEPS_FOR_INTERVAL;
use drive_sim_analysis::command_mix::CommandMix;
use drive_sim_analysis::smoother::Smoothed;
use drive_sim_analysis::Analysis;
use drive_sim_model::kinematics::{CommandSpace, WheelSpeeds};

/// The real side of a comparison, computed once: its analysis, its steps' bootstrap
/// statistics, its transfer-function maps and its halves' (the yardstick). A closed-loop
/// search (`tune`) compares hundreds of simulated runs with one real log; preparing it once
/// cut the asphalt tune of the README from 27.4-27.7 s to 25.2-25.6 s.
pub struct PreparedReal<'a> {
    pub(crate) input: Input<'a>,
    pub(crate) opts: CompareOptions,
    pub(crate) analysis: Analysis,
    pub(crate) rows: Vec<StepRow>,
    pub(crate) space: CommandSpace,
    pub(crate) stats: Vec<Vec<f64>>,
    pub(crate) tf_grid: tf::TfSetup,
    pub(crate) fields: Smoothed,
    pub(crate) halves: (Smoothed, Smoothed),
    pub(crate) splits: tf::SplitHalves,
    pub(crate) warnings: Vec<Warning>,
    /// The command of each real step, in order: a twin's run compared with these steps draws
    /// in their quadrants ([`crate::tune::twin_run_matched`]).
    commands: Vec<WheelSpeeds>,
}

impl<'a> PreparedReal<'a> {
    /// The command of each real step, in order.
    pub fn commands(&self) -> &[WheelSpeeds] {
        &self.commands
    }

    /// The real run's analysis (its steps as compared).
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// Analyses `real` for comparisons with `opts` (bad options are refused here).
    pub fn new(real: Input<'a>, opts: &CompareOptions) -> Result<Self> {
        check_options(opts)?;
        let analysis = analysis_of(real.log)?;
        let rows = rows(&analysis);
        let space = real.log.meta.nominal.command_space();
        let mut warnings = Vec::new();
        too_few(&real.log.meta.name, rows.len(), &mut warnings);
        if !records_time(real.log) {
            warnings.push(Warning {
                name: "time_not_recorded".into(),
                message: format!(
                    "`{}` does not record interruptions or protocol time (a CSV export): time efficiency is not compared",
                    real.log.meta.name
                ),
            });
        }
        lopsided(&real.log.meta.name, &analysis.command_mix, &mut warnings);
        let stats = resampled(&rows, &opts.bootstrap.draws(rows.len(), 1), &space);
        let tf_grid = tf::TfSetup::new(real.log, opts);
        let all: Vec<&StepRow> = rows.iter().collect();
        let fields = tf_grid.fields(&all);
        // Halves by alternating position (not step number: a log may already hold only the
        // odd or the even steps, `--real-steps`).
        let odd: Vec<&StepRow> = rows.iter().skip(1).step_by(2).collect();
        let even: Vec<&StepRow> = rows.iter().step_by(2).collect();
        let halves = (tf_grid.fields(&odd), tf_grid.fields(&even));
        let splits = tf::SplitHalves::new(
            &tf_grid,
            &all,
            &halves,
            opts.tf_yardstick_splits,
            opts.bootstrap.seed ^ 0x5917,
        );
        Ok(Self {
            commands: real.log.held_commands(),
            input: real,
            opts: *opts,
            analysis,
            rows,
            space,
            stats,
            tf_grid,
            fields,
            halves,
            splits,
            warnings,
        })
    }
}

/// A named warning when the real run drew its commands' quadrants unevenly
/// ([`CommandMix::is_lopsided`]): its medians are its draw's, and
/// simulated runs drawn uniformly meet other ones.
fn lopsided(name: &str, mix: &CommandMix, warnings: &mut Vec<Warning>) {
    if mix.is_lopsided() {
        warnings.push(Warning {
            name: "lopsided_draw".into(),
            message: format!(
                "`{name}` drew {} left turns and {} forward commands in {} steps (fair-coin p {:.4} and {:.4}): \
                 its medians are its draw's; simulated runs drawn uniformly meet other ones \
                 (`drive-sim run --draw-like` draws in this run's quadrants, as `tune`, `twin` and `judge` do)",
                mix.left_turns(),
                mix.forward(),
                mix.steps(),
                mix.left_turns_p,
                mix.forward_p
            ),
        });
    }
}

/// A named warning when a run has too few analysed steps for its intervals.
pub(crate) fn too_few(name: &str, n: usize, warnings: &mut Vec<Warning>) {
    if n < MIN_STEPS_FOR_INTERVAL {
        warnings.push(Warning {
            name: "too_few_steps".into(),
            message: format!(
                "`{name}` has {n} analysed steps (fewer than {MIN_STEPS_FOR_INTERVAL}): its intervals are unreliable"
            ),
        });
    }
}

/// A simulated log analysed once, for comparisons with several real sides (`judge` compares
/// the same runs with the real log and with each of its reference runs).
pub struct PreparedSim<'a> {
    pub(crate) input: Input<'a>,
    pub(crate) analysis: Analysis,
    pub(crate) rows: Vec<StepRow>,
}

impl<'a> PreparedSim<'a> {
    /// Analyses `sim` as [`crate::compare`] does.
    pub fn new(sim: Input<'a>) -> Result<Self> {
        let analysis = analysis_of(sim.log)?;
        let rows = rows(&analysis);
        Ok(Self {
            input: sim,
            analysis,
            rows,
        })
    }
}
