//! The calibration loop of one log ([`calibrate_timed`]): the set-up every stage shares (the
//! split, the noise floor, the command reach, the candidate pool, [`Context`]), then the
//! stages of [`crate::stages`] in order, each timed.

use crate::data::{split_steps, StepSet};
use crate::error::{Error, Result};
use crate::events::CalibrationEvent;
use crate::metrics::NoiseFloor;
use crate::model::PlantFactory;
use crate::params::{Param, ParamSpec};
use crate::stages::baseline::{self, BaselineOutput};
use crate::stages::candidates::{self, Candidate};
use crate::stages::discovery::DiscoveryReport;
use crate::stages::screening::{self, ScreeningReport};
use crate::stages::selection::{self, SelectionOutput};
use crate::stages::{final_fit, report, Context, Timings};
use crate::steps::StepSlice;
use crate::{diagnosis, steps, twin, CalibrationOptions, CalibrationReport};
use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;

/// Runs the calibration loop (see the crate doc) of the plant `factory` builds, starting
/// from `robot` and `terrain`, on `log`.
pub fn calibrate(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
) -> Result<CalibrationReport> {
    calibrate_timed(log, robot, terrain, factory, opts, &|_| {}).map(|(r, _)| r)
}

/// [`calibrate`], telling `progress` what each stage found as it ends, and returning the
/// per-stage timings.
pub fn calibrate_timed(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<(CalibrationReport, Timings)> {
    let mut timings = Timings::default();
    let setup = set_up(&LoopInput {
        log,
        robot,
        terrain,
        factory,
        opts,
        progress,
    })?;
    let ctx = &setup.ctx;
    let base_specs = &setup.base_specs;
    let baseline = timings.time("baseline", || {
        baseline::run(
            ctx,
            baseline::BaselineInput {
                declared: &ctx.declared,
                specs: base_specs,
            },
        )
    })?;
    let (screening, screened) = screen(ctx, &mut timings, setup.pool, base_specs)?;
    let (selection, discovery) = select(ctx, &mut timings, &baseline, screened, base_specs)?;
    let final_fit = timings.time("final fit", || {
        final_fit::run(
            ctx,
            final_fit::FinalFitInput {
                current: &selection.current,
                current_validation: &selection.current_validation,
                selected: &selection.selected,
                base: base_specs,
                base_fit_kept: baseline.base_fit_kept,
                already_fitted: selection.refit_current,
            },
        )
    })?;
    let mut report = timings.time("report", || {
        report::run(
            ctx,
            report::ReportInput {
                baseline,
                screening,
                selection,
                final_fit,
                not_evaluated: setup.not_evaluated,
                notes: setup.notes,
            },
        )
    })?;
    timings.time("diagnosis", || diagnose(ctx, robot, &mut report))?;
    report.discovery = discovery;
    Ok((report, timings))
}

/// What the loop is given.
struct LoopInput<'a> {
    log: &'a DriveLog,
    robot: &'a Robot,
    terrain: &'a Terrain,
    factory: &'a dyn PlantFactory,
    opts: &'a CalibrationOptions,
    progress: &'a (dyn Fn(&CalibrationEvent) + Sync),
}

/// What the set-up gives the stages.
struct SetUp<'a> {
    /// What every stage reads.
    ctx: Context<'a>,
    /// The candidate effects.
    pool: Vec<Candidate>,
    /// Registered effects the plant cannot run.
    not_evaluated: Vec<String>,
    /// Notes of the set-up.
    notes: Vec<String>,
    /// The base parameters: the plant's own and those of the declared effects.
    base_specs: Vec<ParamSpec>,
}

/// Everything that can be checked is checked here, before any replay: the split, the noise
/// floor and the command reach on the training steps, the candidate effects.
fn set_up<'a>(input: &LoopInput<'a>) -> Result<SetUp<'a>> {
    let (log, factory, opts, progress) = (input.log, input.factory, input.opts, input.progress);
    let name = &log.meta.name;
    let (slices, excluded) = steps::usable_step_slices(log);
    for e in &excluded {
        progress(&CalibrationEvent::StepExcluded {
            step: e.step,
            reason: e.reason.clone(),
        });
    }
    let split = split_steps(
        name,
        &mean_commands(&slices),
        opts.train_fraction,
        opts.validation_fraction,
        opts.seed,
    )?;
    let rate = log.meta.rate_hz;
    let train_all = StepSet::new(&slices, &split.train, rate)?;
    let floor = training_floor(name, &train_all)?;
    let reach = CommandReach::of_commands(
        train_all.steps.iter().flat_map(|s| s.samples).map(|s| s.m.cmd),
        &input.robot.idd(),
    );
    let mut notes = Vec::new();
    if !drive_sim_analysis::segment::has_imu(log) {
        notes.push("no IMU in the log: the score leaves out the imu_wz channel".into());
    }
    let train = match opts.max_fit_steps {
        Some(k) if k < split.train.len() => {
            let sub = fit_subset(&split.train, k, opts.seed);
            notes.push(format!(
                "fits on {} of {} training steps",
                sub.len(),
                split.train.len()
            ));
            StepSet::new(&slices, &sub, rate)?
        }
        _ => train_all,
    };
    // A robot or terrain file's own effects (a twin's) are the starting model's effects.
    let declared = twin::lift_effects(input.robot, input.terrain)?;
    let (pool, not_evaluated) = candidate_pool(factory, &reach, &declared, opts)?;
    let ctx = Context {
        log,
        factory,
        opts,
        validation: StepSet::after(&slices, &split.validation, &split.train, rate)?,
        test: StepSet::after(
            &slices,
            &split.test,
            &[split.train.as_slice(), &split.validation].concat(),
            rate,
        )?,
        train,
        split,
        floor,
        reach,
        declared,
        excluded,
        progress,
    };
    progress(&CalibrationEvent::Split {
        steps: slices.len(),
        train: ctx.split.train.len(),
        validation: ctx.split.validation.len(),
        test: ctx.split.test.len(),
        seed: opts.seed,
    });
    let mut base_specs = factory.base_params(&ctx.declared);
    base_specs.extend(candidates::declared_specs(&ctx.declared, &ctx.reach));
    Ok(SetUp {
        ctx,
        pool,
        not_evaluated,
        notes,
        base_specs,
    })
}

/// Each step's mean command, which the split spreads over the command space.
fn mean_commands(slices: &[StepSlice<'_>]) -> Vec<(u32, WheelSpeeds)> {
    slices
        .iter()
        .map(|s| {
            let n = s.samples.len().max(1) as f64;
            let (l, r) = s.samples.iter().fold((0.0, 0.0), |a, x| {
                (a.0 + x.m.cmd.left_rad_s, a.1 + x.m.cmd.right_rad_s)
            });
            (s.step, WheelSpeeds::new(l / n, r / n))
        })
        .collect()
}

/// The noise floor of the training steps; refused when no step has the two steady windows
/// it compares.
fn training_floor(name: &str, train: &StepSet<'_>) -> Result<NoiseFloor> {
    let floor = NoiseFloor::estimate(&train.features).map_err(|e| Error::NoNoiseFloor {
        dataset: name.to_string(),
        source: Box::new(e),
    })?;
    if floor.steps_used == 0 {
        return Err(Error::NoTwoWindowStep {
            dataset: name.to_string(),
        });
    }
    Ok(floor)
}

/// A seeded subset of `k` (at least one) of the training steps, in step order.
fn fit_subset(train: &[u32], k: usize, seed: u64) -> Vec<u32> {
    use rand::seq::SliceRandom;
    use rand::SeedableRng;
    let mut sub = train.to_vec();
    sub.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5eed));
    sub.truncate(k.max(1));
    sub.sort_unstable();
    sub
}

/// The candidate effects the plant can run (a declared effect is refit as a base parameter and
/// judged, not proposed again), and the registered ones it cannot; an unknown name among
/// `opts.candidates` is refused.
fn candidate_pool(
    factory: &dyn PlantFactory,
    reach: &CommandReach,
    declared: &crate::ModelParams,
    opts: &CalibrationOptions,
) -> Result<(Vec<Candidate>, Vec<String>)> {
    let (mut pool, not_evaluated) = candidates::candidates_for(factory, reach, opts.candidates.as_deref());
    let declared_on = candidates::declared_effects(declared);
    pool.retain(|c| !c.effects.iter().any(|e| declared_on.contains(e)));
    if let Some(only) = &opts.candidates {
        for n in only {
            if drive_sim_model::effects::effect(n).is_none() {
                return Err(Error::from(drive_sim_model::Error::Unknown {
                    kind: "candidate effect",
                    name: n.clone(),
                    available: drive_sim_model::effects::REGISTRY
                        .iter()
                        .map(|e| e.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                }));
            }
        }
    }
    Ok((pool, not_evaluated))
}

/// The candidates the simulator or the kinematic model goes on with, and the base parameters
/// refit beside each.
struct Screened {
    /// The candidates selection tries.
    pool: Vec<Candidate>,
    /// The pairs the first round tries, when screening chose them.
    pairs: Option<Vec<Candidate>>,
    /// Base parameters refit beside each candidate.
    refit: Vec<ParamSpec>,
}

/// The kinematic model is cheap enough to refit the base parameters beside every candidate;
/// the simulator screens with it and fits effects with the time constant only, then refits
/// jointly. Returns what screening found, when it ran.
fn screen(
    ctx: &Context<'_>,
    timings: &mut Timings,
    pool: Vec<Candidate>,
    base_specs: &[ParamSpec],
) -> Result<(Option<ScreeningReport>, Screened)> {
    if !(ctx.factory.name() == "simulator" && ctx.opts.screen_keep > 0) {
        let all = Screened {
            pool,
            pairs: None,
            refit: base_specs.to_vec(),
        };
        return Ok((None, all));
    }
    let out = timings.time("screening", || {
        screening::run(
            ctx,
            screening::ScreeningInput {
                candidates: &pool,
                declared: &ctx.declared,
            },
        )
    })?;
    // Beside each effect the simulator refits the wheel loop's time constant only: the base
    // parameter that stands in for powertrain effects (a slower loop for a dead time); the
    // terrain's are refit jointly once an effect is added.
    let refit: Vec<ParamSpec> = base_specs
        .iter()
        .filter(|p| p.param == Param::TimeConstant)
        .copied()
        .collect();
    let shortlisted = Screened {
        pool: out.shortlist,
        pairs: Some(out.pairs),
        refit,
    };
    Ok((Some(out.report), shortlisted))
}

/// Forward selection, pairs and the backward pass, then (with `discover`) discovery on top;
/// what discovery adds replaces the selection's model. Returns the selection with discovery's
/// additions, and discovery's report.
fn select(
    ctx: &Context<'_>,
    timings: &mut Timings,
    baseline: &BaselineOutput,
    screened: Screened,
    base_specs: &[ParamSpec],
) -> Result<(SelectionOutput, Option<DiscoveryReport>)> {
    let Screened { pool, pairs, refit } = screened;
    let refit_for_discovery = refit.clone();
    let mut selection = timings.time("selection", || {
        selection::run(
            ctx,
            selection::SelectionInput {
                current: baseline.current.clone(),
                current_validation: baseline.current_validation.clone(),
                pool,
                refit,
                pairs,
                base: if baseline.base_fit_kept {
                    base_specs.to_vec()
                } else {
                    Vec::new()
                },
            },
        )
    })?;
    let discovery = if ctx.opts.discover {
        let out = timings.time("discovery", || {
            crate::stages::discovery::run(
                ctx,
                crate::stages::discovery::DiscoveryInput {
                    current: selection.current.clone(),
                    current_validation: selection.current_validation.clone(),
                    selected: selection.selected.clone(),
                    refit: refit_for_discovery.clone(),
                },
            )
        })?;
        if out.added {
            selection.current = out.current;
            selection.current_validation = out.current_validation;
            selection.selected = out.selected;
            selection.refit_current = false;
        }
        let mut report = out.report;
        // One competition: when the catalogue's order leaves a channel flagged, discovery
        // also starts from the base model, and the better of the two orders is kept.
        if !report.flagged_after.is_empty() {
            let from_base = timings.time("competition", || {
                crate::stages::discovery::run(
                    ctx,
                    crate::stages::discovery::DiscoveryInput {
                        current: baseline.current.clone(),
                        current_validation: baseline.current_validation.clone(),
                        selected: Vec::new(),
                        refit: refit_for_discovery,
                    },
                )
            })?;
            if from_base.added {
                let (mut competition, discovery_wins) = crate::stages::competition::compete(
                    ctx,
                    &crate::stages::competition::Order {
                        validation: &selection.current_validation,
                        selected: &selection.selected,
                    },
                    &crate::stages::competition::Order {
                        validation: &from_base.current_validation,
                        selected: &from_base.selected,
                    },
                );
                (ctx.progress)(&CalibrationEvent::Competition {
                    kept: competition.kept.clone(),
                    why: competition.why.clone(),
                });
                competition.rounds = from_base.report.rounds;
                competition.backward = from_base.report.backward;
                if discovery_wins {
                    selection.current = from_base.current;
                    selection.current_validation = from_base.current_validation;
                    selection.selected = from_base.selected;
                    selection.refit_current = false;
                    report.flagged_after = from_base.report.flagged_after;
                }
                report.competition = Some(Box::new(competition));
            }
        }
        Some(report)
    } else {
        None
    };
    Ok((selection, discovery))
}

/// The declared and the calibrated model's diagnosis on the test steps.
fn diagnose(ctx: &Context<'_>, robot: &Robot, report: &mut CalibrationReport) -> Result<()> {
    let idd = robot.idd();
    for (model, slot) in [
        (&report.model_before, &mut report.diagnosis_before),
        (&report.model_after, &mut report.diagnosis_after),
    ] {
        let r = ctx.test.residuals(ctx.factory, model)?;
        *slot = Some(diagnosis::diagnose(&r, &ctx.test.features, &ctx.floor, &idd));
    }
    Ok(())
}
