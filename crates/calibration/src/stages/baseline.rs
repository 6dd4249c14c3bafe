//! Stage 1: where the declared model stands, and the base (terrain / robot) fit.

use super::Context;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::fit::{fit, FitResult};
use crate::metrics::{score, StepErrors};
use crate::model::{IddFactory, ModelParams};

/// Input of [`run`].
pub struct BaselineInput<'m> {
    /// The model the calibration starts from.
    pub declared: &'m ModelParams,
    /// The base parameters: the plant's own ([`crate::model::PlantFactory::base_params`])
    /// and those of the effects the starting model declares
    /// ([`super::candidates::declared_specs`]).
    pub specs: &'m [crate::params::ParamSpec],
}

/// Output of [`run`].
pub struct BaselineOutput {
    /// Test errors of the IDD.
    pub idd_test: Vec<StepErrors>,
    /// Test errors of the declared model.
    pub before_test: Vec<StepErrors>,
    /// The base fit, when the model has base parameters.
    pub base_fit: Option<FitResult>,
    /// The base fit lowered the validation score and was kept.
    pub base_fit_kept: bool,
    /// The model after this stage (declared, or base-fitted).
    pub current: ModelParams,
    /// Its validation errors.
    pub current_validation: Vec<StepErrors>,
    /// What happened, in words.
    pub notes: Vec<String>,
}

/// Scores the IDD and the declared model, then fits the base parameters on the training
/// steps; the fit is a model change like an effect, kept only if it also lowers the
/// validation score (a fit that helps the training steps and hurts others has fitted their
/// noise).
pub fn run(ctx: &Context<'_>, input: BaselineInput<'_>) -> Result<BaselineOutput> {
    let declared = input.declared;
    let f = ctx.factory;
    let idd_test = ctx.test.errors(&IddFactory, declared)?;
    let before_test = ctx.test.errors(f, declared)?;
    let before_validation = ctx.validation.errors(f, declared)?;
    let before_val = score(&before_validation, &ctx.floor);
    (ctx.progress)(&CalibrationEvent::Baseline {
        validation_score: before_val,
        steps: ctx.validation.len(),
    });
    let mut notes = Vec::new();
    let specs = input.specs;
    if specs.is_empty() {
        notes.push(format!(
            "the {} model exposes no base parameter: base fit skipped",
            f.name()
        ));
        return Ok(BaselineOutput {
            idd_test,
            before_test,
            base_fit: None,
            base_fit_kept: false,
            current: declared.clone(),
            current_validation: before_validation,
            notes,
        });
    }
    let (m, r) = fit(
        &ctx.train,
        f,
        declared,
        specs,
        &ctx.floor,
        &ctx.opts.fit,
        &mut |_| {},
    )?;
    if !r.converged {
        notes.push(format!("base fit: {}", r.status));
    }
    let validation = ctx.validation.errors(f, &m)?;
    let val = score(&validation, &ctx.floor);
    let kept = r.score <= r.initial_score && val <= before_val;
    if !kept {
        notes.push(format!(
            "base fit discarded: validation score {before_val:.3} -> {val:.3} (training {:.3} -> {:.3})",
            r.initial_score, r.score
        ));
    }
    (ctx.progress)(&CalibrationEvent::BaseFit {
        params: specs.len(),
        evaluations: r.evaluations,
        status: r.status.clone(),
        training_before: r.initial_score,
        training_after: r.score,
        validation_before: before_val,
        validation_after: val,
        kept,
    });
    Ok(if kept {
        BaselineOutput {
            idd_test,
            before_test,
            base_fit: Some(r),
            base_fit_kept: true,
            current: m,
            current_validation: validation,
            notes,
        }
    } else {
        BaselineOutput {
            idd_test,
            before_test,
            base_fit: Some(r),
            base_fit_kept: false,
            current: declared.clone(),
            current_validation: before_validation,
            notes,
        }
    })
}
