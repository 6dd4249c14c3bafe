//! Stage 5: the base and effect parameters refit together, with their covariance.

use super::candidates::Candidate;
use super::Context;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::fit::{fit, FitResult};
use crate::metrics::{score, StepErrors};
use crate::model::ModelParams;
use crate::params::ParamSpec;

/// Input of [`run`].
pub struct FinalFitInput<'m> {
    /// The selected model.
    pub current: &'m ModelParams,
    /// Its validation errors.
    pub current_validation: &'m [StepErrors],
    /// Effects selected.
    pub selected: &'m [Candidate],
    /// Base parameters.
    pub base: &'m [ParamSpec],
    /// The base fit was kept (else the base parameters stay declared).
    pub base_fit_kept: bool,
    /// `current` is already the joint fit of these parameters: only the covariance is
    /// computed.
    pub already_fitted: bool,
}

/// Output of [`run`].
pub struct FinalFitOutput {
    /// The joint fit (always reported, for its covariance).
    pub fit: Option<FitResult>,
    /// The final model.
    pub model: ModelParams,
    /// The joint fit replaced the selected model (it did not worsen the validation score).
    pub kept: bool,
    /// Parameters that ended on a bound of their box: likely stand-ins for something the
    /// model lacks.
    pub stand_ins: Vec<String>,
    /// What happened, in words.
    pub notes: Vec<String>,
}

/// Refits everything together on the training steps; kept if the validation score does not
/// get worse. Its covariance gives every fitted value its interval.
pub fn run(ctx: &Context<'_>, input: FinalFitInput<'_>) -> Result<FinalFitOutput> {
    let mut specs: Vec<ParamSpec> = if input.base_fit_kept {
        input.base.to_vec()
    } else {
        Vec::new()
    };
    specs.extend(
        input
            .selected
            .iter()
            .flat_map(|c| c.params.iter().filter(|p| !p.discrete).copied()),
    );
    let mut notes = Vec::new();
    if specs.is_empty() {
        return Ok(FinalFitOutput {
            fit: None,
            model: input.current.clone(),
            kept: false,
            stand_ins: Vec::new(),
            notes,
        });
    }
    let mut opts = ctx.opts.fit.clone();
    if input.already_fitted {
        // No iteration: the Jacobian at the selected model, for its covariance.
        opts.lm.max_iters = 0;
        notes.push("final fit: the selected model is already the joint fit; covariance only".into());
    }
    let (m, mut r) = fit(
        &ctx.train,
        ctx.factory,
        input.current,
        &specs,
        &ctx.floor,
        &opts,
        &mut |_| {},
    )?;
    if input.already_fitted {
        r.converged = true;
        r.status = "the joint refit of the selection stage converged; covariance at its solution".into();
    }
    let v = ctx.validation.errors(ctx.factory, &m)?;
    let (old, new) = (score(input.current_validation, &ctx.floor), score(&v, &ctx.floor));
    let kept = new <= old;
    if !r.converged {
        notes.push(format!("final fit: {}", r.status));
    }
    if !kept {
        notes.push(format!(
            "final joint fit not kept: validation {old:.3} -> {new:.3}; the selected model stays"
        ));
    }
    // Not kept: the intervals come from the covariance at the selected model itself (a fit
    // with no iteration evaluates the Jacobian there and stops).
    let r = if kept {
        r
    } else {
        let mut at_current = ctx.opts.fit.clone();
        at_current.lm.max_iters = 0;
        let (_, r0) = fit(
            &ctx.train,
            ctx.factory,
            input.current,
            &specs,
            &ctx.floor,
            &at_current,
            &mut |_| {},
        )?;
        crate::fit::FitResult {
            converged: r.converged,
            status: format!(
                "{}; the joint fit was not kept, so the values and intervals are those of the selected model",
                r.status
            ),
            stop: r.stop,
            iterations: r.iterations,
            evaluations: r.evaluations + r0.evaluations,
            ..r0
        }
    };
    let stand_ins: Vec<String> = r
        .params
        .iter()
        .filter(|p| p.at_bound)
        .map(|p| p.name.clone())
        .collect();
    for s in &stand_ins {
        notes.push(format!(
            "{s} ended on a bound of its box: likely a stand-in for an effect the model lacks"
        ));
    }
    (ctx.progress)(&CalibrationEvent::FinalFit {
        params: specs.len(),
        evaluations: r.evaluations,
        status: r.status.clone(),
        validation_before: old,
        validation_after: new,
        kept,
    });
    Ok(FinalFitOutput {
        model: if kept { m } else { input.current.clone() },
        fit: Some(r),
        kept,
        stand_ins,
        notes,
    })
}
