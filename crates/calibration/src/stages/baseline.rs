//! Stage 1: where the declared model stands, and the base (terrain / robot) fit.

use super::Context;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::fit::{fit, FitResult, FittedParam};
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
    /// The base parameters the later stages refit: those of the input the training steps
    /// determine ([`undetermined`]).
    pub specs: Vec<crate::params::ParamSpec>,
    /// What happened, in words.
    pub notes: Vec<String>,
}

/// The fitted parameters whose 95 % interval is wider than their search box: the training
/// steps do not determine them (the fit could have put them anywhere in the box), so they stay
/// at their declared value rather than carry the training steps' noise to the model.
pub fn undetermined(params: &[FittedParam]) -> Vec<String> {
    params
        .iter()
        .filter(|p| p.ci95.is_some_and(|[lo, hi]| hi - lo > p.upper - p.lower))
        .map(|p| p.name.clone())
        .collect()
}

/// Scores the IDD and the declared model, then fits the base parameters on the training
/// steps; the fit is a model change like an effect, kept only if it also lowers the
/// validation score (a fit that helps the training steps and hurts others has fitted their
/// noise). A parameter the training steps do not determine ([`undetermined`]) stays declared
/// and the others are refit without it; the later stages refit only those left.
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
            specs: Vec::new(),
            notes,
        });
    }
    let fit_specs = |specs: &[crate::params::ParamSpec]| {
        fit(
            &ctx.train,
            f,
            declared,
            specs,
            &ctx.floor,
            &ctx.opts.fit,
            &mut |_| {},
        )
    };
    let (mut m, mut r) = fit_specs(specs)?;
    // Dropping a parameter changes the others' intervals: refit until every one left is
    // determined (at most once per parameter).
    let mut specs = specs.to_vec();
    loop {
        let loose = undetermined(&r.params);
        if loose.is_empty() {
            break;
        }
        specs.retain(|s| !loose.contains(&s.param.name()));
        notes.push(format!(
            "base fit: {} not determined by the training steps (95 % interval wider than the search box): kept declared, the others refit",
            loose.join(", ")
        ));
        if specs.is_empty() {
            return Ok(BaselineOutput {
                idd_test,
                before_test,
                base_fit: None,
                base_fit_kept: false,
                current: declared.clone(),
                current_validation: before_validation,
                specs,
                notes,
            });
        }
        (m, r) = fit_specs(&specs)?;
    }
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
            specs,
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
            specs,
            notes,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Param, ParamSpec};

    #[test]
    fn a_parameter_whose_interval_is_wider_than_its_box_is_undetermined() {
        let with = |param, ci95: Option<[f64; 2]>| {
            let mut p = FittedParam::of(&ParamSpec::new(param, 0.05, 0.35), None, 0.2);
            p.ci95 = ci95;
            p
        };
        let params = [
            // 0.8 wide in a box 0.3 wide: anywhere in the box would have done.
            with(Param::PeakSlipAngle, Some([-0.2, 0.6])),
            // Within the box's width, even reaching past its edge: determined.
            with(Param::PeakSlipRatio, Some([0.0, 0.29])),
            // On a bound, no interval: a stand-in, reported as such, not undetermined.
            with(Param::PeakLateral, None),
        ];
        assert_eq!(undetermined(&params), ["terrain.friction.peak_slip_angle_rad"]);
    }
}
