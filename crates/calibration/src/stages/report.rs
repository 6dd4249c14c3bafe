//! Stage 6: the scores reported, on the test steps only, and the report.

use super::baseline::BaselineOutput;
use super::candidates::bootstrap_reduction_se;
use super::final_fit::FinalFitOutput;
use super::screening::ScreeningReport;
use super::selection::SelectionOutput;
use super::Context;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::fit::FittedParam;
use crate::metrics::{step_features, ErrorSummary, StepFeatures};
use crate::model::ModelParams;
use crate::replay::replay_map;
use crate::residual::{self, ResidualAnalysis};
use crate::{CalibrationReport, CalibrationStatus, DeclaredEffectCheck, StepScores, TableRow};
use drive_sim_log::Origin;

/// Input of [`run`].
pub struct ReportInput {
    /// Stage 1.
    pub baseline: BaselineOutput,
    /// Stage 2, when it ran.
    pub screening: Option<ScreeningReport>,
    /// Stage 4.
    pub selection: SelectionOutput,
    /// Stage 5.
    pub final_fit: FinalFitOutput,
    /// Registered effects the model cannot run.
    pub not_evaluated: Vec<String>,
    /// Notes of the set-up.
    pub notes: Vec<String>,
}

fn table(
    idd: &ErrorSummary,
    before: &ErrorSummary,
    after: &ErrorSummary,
    floor: &ErrorSummary,
) -> Vec<TableRow> {
    idd.rows()
        .into_iter()
        .zip(before.rows())
        .zip(after.rows())
        .zip(floor.rows())
        .map(|(((i, b), a), f)| TableRow {
            metric: i.metric,
            unit: i.unit,
            idd: i.value,
            sim_before: b.value,
            sim_after: a.value,
            floor: f.value,
        })
        .collect()
}

fn replayed_features(ctx: &Context<'_>, m: &ModelParams) -> Result<Vec<StepFeatures>> {
    let t = &ctx.test;
    replay_map(&t.steps, &t.starts, ctx.factory, m, t.rate_hz, |i, sim| {
        step_features(t.steps[i].step, &sim)
    })
}

/// Judges each effect the starting model declared, on the validation steps (a model choice,
/// like the backward pass; the test steps stay for the report): the final model's errors
/// against those of the final model with that effect switched off, with a paired bootstrap
/// standard error over the steps. Confirmed: switching it off costs more than `k_se` standard
/// errors, or costs at all while the log constrains it (every refit parameter identifiable,
/// its interval excluding the neutral value: the selection's own identifiability rule; a limit
/// that clips only a few fast steps has a tight interval and a noisy score change).
/// Contradicted: switching it off helps by more than that, or a limit's refit rose to
/// the top of its box (the largest training command: it clips nothing the log commanded); the
/// effect is then switched off in the returned model (a twin of this log must not carry it).
/// Otherwise it is kept as declared (refit). `fits` are the fits that refit its parameters, latest first.
fn judge_declared(
    ctx: &Context<'_>,
    model: ModelParams,
    fits: &[Option<&crate::FitResult>],
) -> Result<(ModelParams, Vec<DeclaredEffectCheck>)> {
    let floor = &ctx.floor;
    let k = ctx.opts.rule.k_se;
    let mut model = model;
    let mut out = Vec::new();
    // The model's validation errors, replayed again only when a contradicted effect changes it.
    let mut with_val = ctx.validation.errors(ctx.factory, &model)?;
    for i in super::candidates::declared_effects(&ctx.declared) {
        let e = drive_sim_model::effects::REGISTRY[i];
        let mut without = model.clone();
        for d in e.params() {
            without.effects.set(d.key, d.neutral)?;
        }
        let without_val = ctx.validation.errors(ctx.factory, &without)?;
        let increase = crate::metrics::score(&without_val, floor) - crate::metrics::score(&with_val, floor);
        let se = bootstrap_reduction_se(
            &without_val,
            &with_val,
            floor,
            ctx.opts.rule.bootstrap_samples,
            ctx.opts.seed,
        );
        // Each refit parameter with its kind (a limit's refit is read below).
        let (params, kinds): (Vec<FittedParam>, Vec<drive_sim_model::effects::ParamKind>) = e
            .params()
            .iter()
            .enumerate()
            .filter_map(|(j, d)| {
                let name = format!("effect.{}", d.key);
                let declared = ctx.declared.effects.get(d.key)?;
                if d.is_neutral(declared) {
                    return None;
                }
                let value = model.effects.get(d.key)?;
                // The interval of a fit at the model's value, or within half a standard error
                // of it (the final fit's covariance is computed where that fit ended, a hair
                // from the selected model it did not replace); a discarded fit that ended
                // farther away (a base fit that did not lower the validation score) has an
                // interval of its own point, not of this model's.
                let fitted = fits
                    .iter()
                    .flatten()
                    .filter_map(|f| f.param(&name))
                    .find(|p| {
                        let d = (p.value - value).abs();
                        d <= 1e-9 * value.abs().max(1.0) || p.se.is_some_and(|se| d <= 0.5 * se)
                    })
                    .cloned();
                let param = match fitted {
                    Some(mut p) => {
                        p.initial = Some(declared);
                        p
                    }
                    None => {
                        let spec = crate::params::ParamSpec::for_effect(i, j, &ctx.reach);
                        FittedParam::of(&spec, Some(declared), value)
                    }
                };
                Some((param, d.kind))
            })
            .unzip();
        let values = params
            .iter()
            .map(|p| {
                let ci = match (p.ci95, p.at_bound) {
                    (Some([a, b]), _) => format!(" [{a:.4}, {b:.4}]"),
                    (None, true) => " (at a bound of its box, no interval)".into(),
                    (None, false) => " (no interval)".into(),
                };
                format!(
                    "{} declared {} → refit {:.4}{ci} {}",
                    p.name,
                    p.initial.unwrap_or(f64::NAN),
                    p.value,
                    p.unit
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        // A limit refit to the top of its box (the largest training command) clips nothing
        // the training steps commanded: the log shows no limit where it was declared.
        let risen = params.iter().zip(&kinds).any(|(p, kind)| {
            *kind == drive_sim_model::effects::ParamKind::Limit
                && p.at_bound
                && p.value > 0.5 * (p.lower + p.upper)
        });
        // The log constrains it: every refit parameter identifiable, with an interval that
        // excludes its neutral value (for a limit: below the largest training command).
        let constrained = !params.is_empty()
            && params
                .iter()
                .all(|p| p.identifiable == Some(true) && p.neutral_in_interval == Some(false));
        let contradicted = risen || increase < -k * se;
        let confirmed = !contradicted && (increase > k * se || (constrained && increase > 0.0));
        let verdict = format!(
            "{}: switching it off changes the validation score by {increase:+.3} ± {se:.3} (bootstrap SE by step); {values}",
            if confirmed && increase > k * se {
                format!("confirmed (switching it off costs beyond {k} SE)")
            } else if confirmed {
                format!("confirmed (its refit interval excludes the neutral value; switching it off costs, within {k} SE)")
            } else if risen {
                "contradicted (its limit rose to the largest training command: no limit below the commands): switched off in this log's model".to_string()
            } else if contradicted {
                format!("contradicted (switching it off helps beyond {k} SE): switched off in this log's model")
            } else {
                format!("not confirmed by this log (within {k} SE), kept as declared")
            }
        );
        if contradicted {
            model = without;
            with_val = without_val;
        }
        out.push(DeclaredEffectCheck {
            effect: e.name().to_string(),
            params,
            removal_increase: increase,
            removal_increase_se: se,
            confirmed,
            contradicted,
            verdict,
        });
    }
    Ok((model, out))
}

/// Scores every model on the test steps and assembles the report.
pub fn run(ctx: &Context<'_>, input: ReportInput) -> Result<CalibrationReport> {
    let ReportInput {
        baseline,
        screening,
        selection,
        final_fit,
        not_evaluated,
        mut notes,
    } = input;
    let floor = &ctx.floor;
    let (model_after, declared_effects) = judge_declared(
        ctx,
        final_fit.model.clone(),
        &[final_fit.fit.as_ref(), baseline.base_fit.as_ref()],
    )?;
    for d in &declared_effects {
        (ctx.progress)(&CalibrationEvent::Declared {
            effect: d.effect.clone(),
            verdict: d.verdict.clone(),
        });
        if d.contradicted {
            notes.push(format!("declared {}: {}", d.effect, d.verdict));
        }
    }
    let after_base_test = ctx.test.errors(ctx.factory, &baseline.current)?;
    let after_test = ctx.test.errors(ctx.factory, &model_after)?;
    let idd = ErrorSummary::pool(&baseline.idd_test, floor);
    let before = ErrorSummary::pool(&baseline.before_test, floor);
    let after_terrain = ErrorSummary::pool(&after_base_test, floor);
    let after = ErrorSummary::pool(&after_test, floor);
    let residual_before = residual_of(ctx, &baseline.current)?;
    let residual_after = residual_of(ctx, &model_after)?;
    let total_reduction = before.score - after.score;
    let total_reduction_se = bootstrap_reduction_se(
        &baseline.before_test,
        &after_test,
        floor,
        ctx.opts.rule.bootstrap_samples,
        ctx.opts.seed,
    );
    let effects = effect_params(&model_after, &selection, final_fit.fit.as_ref());
    let converged = all_converged(&baseline, &selection, &final_fit);
    add_stage_notes(ctx, &mut notes, &baseline, &selection, &final_fit);
    let (source_file, reproduce) = source_and_reproduce(ctx);
    let score_of =
        |e: &[crate::metrics::StepErrors]| -> Vec<f64> { e.iter().map(|s| s.score(floor)).collect() };
    Ok(CalibrationReport {
        dataset: ctx.log.meta.name.clone(),
        source_file,
        model_kind: ctx.factory.name(),
        options: ctx.opts.clone(),
        status: CalibrationStatus { converged, notes },
        train_steps: ctx.split.train.clone(),
        validation_steps: ctx.split.validation.clone(),
        heldout_steps: ctx.split.test.clone(),
        excluded_steps: ctx.excluded.clone(),
        table: table(&idd, &before, &after, &ErrorSummary::floor(floor)),
        floor: floor.clone(),
        idd,
        before,
        after_terrain,
        after,
        step_scores: StepScores {
            idd: score_of(&baseline.idd_test),
            before: score_of(&baseline.before_test),
            after: score_of(&after_test),
        },
        total_reduction,
        total_reduction_se,
        terrain_fit: baseline.base_fit,
        terrain_fit_kept: baseline.base_fit_kept,
        screening,
        rounds: selection.rounds,
        pairs: selection.pairs,
        backward: selection.backward,
        final_fit: final_fit.fit,
        final_fit_kept: final_fit.kept,
        stand_ins: final_fit.stand_ins,
        discovery: None,
        diagnosis_before: None,
        diagnosis_after: None,
        effects,
        declared_effects,
        not_evaluated,
        model_before: ctx.declared.clone(),
        model_after,
        residual_before,
        residual_after,
        reproduce,
        twin_check: None,
    })
}

/// The residual of model `m` over the command space and over the step, on the test steps.
fn residual_of(ctx: &Context<'_>, m: &ModelParams) -> Result<ResidualAnalysis> {
    let kernel_var =
        ctx.opts
            .kernel_var
            .unwrap_or(drive_sim_analysis::smoother::KernelCovariance::paper_variance(
                &ctx.declared.robot.name,
            ));
    let space = ctx.declared.robot.command_space();
    Ok(residual::analyse(
        &replayed_features(ctx, m)?,
        &ctx.test.features,
        ctx.declared.robot.idd(),
        &space,
        ctx.opts.grid_step,
        kernel_var,
    ))
}

/// Every effect parameter of the final model, with its interval from the final fit.
fn effect_params(
    model_after: &ModelParams,
    selection: &SelectionOutput,
    fitted: Option<&crate::FitResult>,
) -> Vec<FittedParam> {
    model_after
        .effects
        .values()
        .into_iter()
        // A discovered term carries a coefficient for every library feature; those its
        // equation does not use stay at 0 and are not part of the model.
        .filter(|(k, v)| {
            let generic = drive_sim_model::effects::param_owner(k)
                .is_some_and(|(i, _)| drive_sim_model::effects::REGISTRY[i].generic());
            !(generic && *v == 0.0)
        })
        .map(|(k, v)| {
            let name = format!("effect.{k}");
            let spec = selection
                .selected
                .iter()
                .flat_map(|c| &c.params)
                .find(|p| p.param.name() == name);
            let from_fit = fitted.and_then(|f| f.param(&name)).cloned();
            match (from_fit, spec) {
                (Some(mut p), _) => {
                    p.value = v;
                    p
                }
                (None, Some(spec)) => FittedParam::of(spec, None, v),
                (None, None) => FittedParam {
                    name,
                    initial: None,
                    value: v,
                    lower: f64::NAN,
                    upper: f64::NAN,
                    at_bound: false,
                    unit: String::new(),
                    se: None,
                    ci95: None,
                    identifiable: None,
                    identifiability_note: None,
                    neutral_in_interval: None,
                    confounded: false,
                },
            }
        })
        .collect()
}

/// Every fit of every stage converged.
fn all_converged(baseline: &BaselineOutput, selection: &SelectionOutput, final_fit: &FinalFitOutput) -> bool {
    let mut converged = selection.converged
        && baseline.base_fit.as_ref().is_none_or(|f| f.converged)
        && final_fit.fit.as_ref().is_none_or(|f| f.converged);
    if selection
        .rounds
        .iter()
        .flat_map(|r| &r.ranking)
        .any(|e| !e.converged)
    {
        converged = false;
    }
    converged
}

/// The excluded steps and the stages' own notes, after the set-up's.
fn add_stage_notes(
    ctx: &Context<'_>,
    notes: &mut Vec<String>,
    baseline: &BaselineOutput,
    selection: &SelectionOutput,
    final_fit: &FinalFitOutput,
) {
    if !ctx.excluded.is_empty() {
        notes.push(format!(
            "{} step(s) of the log excluded from every set, as the analysis excludes them (excluded_steps): {}",
            ctx.excluded.len(),
            ctx.excluded
                .iter()
                .map(|e| e.step.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    notes.extend(baseline.notes.iter().cloned());
    notes.extend(selection.notes.iter().cloned());
    notes.extend(final_fit.notes.iter().cloned());
}

/// The file the log was read from, when measured, and a command line that reproduces the
/// calibration from it.
fn source_and_reproduce(ctx: &Context<'_>) -> (Option<String>, String) {
    let source_file = match &ctx.log.meta.origin {
        Origin::Measured { file } => Some(file.clone()),
        _ => None,
    };
    let reproduce = format!(
        "drive-sim calibrate {} --model {} --seed {} --out <DIR>",
        source_file.as_deref().unwrap_or(&ctx.log.meta.name),
        ctx.factory.name(),
        ctx.opts.seed
    );
    (source_file, reproduce)
}
