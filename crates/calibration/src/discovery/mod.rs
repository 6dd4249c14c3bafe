//! Equation discovery by sparse regression: which few columns of a library of candidate
//! features explain a response, with how much confidence.
//!
//! The method is SINDy's sparse regression (Brunton, Proctor and Kutz 2016) with the
//! safeguards a small, noisy system-identification dataset needs:
//!
//! 1. **Rows are weighted and grouped.** Each row carries a weight (the calibration divides a
//!    residual by its channel's noise floor, so the steady and transient rows of one channel
//!    are comparable) and a group (its step): resamples and validation work by group, because
//!    rows of one step share its errors.
//! 2. **Columns are screened and scaled.** A column that is constant (but the intercept),
//!    non-finite or almost collinear with an earlier one (|r| > [`MAX_COLUMN_CORRELATION`]) is
//!    left out with the reason; the others are scaled to unit root mean square, so the
//!    threshold reads in the response's units (after weighting: in noise floors).
//! 3. **The solver and its threshold are chosen on validation.** Two sparse regressions
//!    ([`SparseSolver`]: STLSQ, and SR3 with the ℓ0 penalty) each choose a threshold, the
//!    sparser of two choices. Each threshold of a grid gives a sparse fit on the training rows.
//!    The validation loss picks the largest threshold whose loss is within one standard error
//!    (over validation groups) of the smallest — the one-standard-error rule, which prefers the
//!    sparser of two equally good equations — or, when larger, within
//!    [`DiscoveryOptions::good_enough_rms`] of the response's noise: below the noise floor, a
//!    smaller threshold buys terms that only fit it. The Bayesian information criterion on the
//!    training fit ([`bic`], the likelihood clustered by step: each coefficient costs
//!    ln(steps)) picks its own; the larger of the two thresholds wins. SR3 then replaces STLSQ
//!    only when its validation loss at its threshold is lower by more than one standard error
//!    of the paired difference over validation groups: the incumbent keeps a tie.
//! 4. **A term is kept only if it is stable** (stability selection; Meinshausen and Bühlmann
//!    2010): the chosen solver on bootstrap resamples of the training groups, and a term is kept if
//!    chosen in at least [`STABILITY_THRESHOLD`] of them. The resamples use half the chosen
//!    threshold: the one-standard-error rule puts the threshold just under the smallest term
//!    it keeps, and at that same threshold the resampling noise alone would drop the term
//!    half of the time.
//! 5. **Coefficients and intervals.** Least squares on the kept terms over all training rows;
//!    the 95 % interval is the percentile interval of the same fit over the bootstrap
//!    resamples. The validation R² is uncentred, `1 - Σ(y - ŷ)² / Σ y²`: the share of the
//!    residual's energy the equation explains (a constant offset counts).
//!
//! Bad designs (too few rows or groups, no usable column, a singular system) give a
//! [`Skipped`] reason, never a NaN coefficient.

mod solvers;

use solvers::minimum_norm_least_squares;
pub use solvers::{least_squares, stlsq, SparseSolver, Sr3, SR3_MAX_ITER, SR3_PULL_PER_ROW, SR3_TOLERANCE};

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Columns correlated beyond this with an earlier column are left out (one of two near copies
/// cannot be told from the other).
pub const MAX_COLUMN_CORRELATION: f64 = 0.98;
/// Share of bootstrap resamples in which a term must be chosen to be kept ("most").
pub const STABILITY_THRESHOLD: f64 = 0.7;
/// Fewest groups (steps) a fit needs in training and in validation.
pub const MIN_GROUPS: usize = 4;
/// STLSQ thresholds tried, in response units per unit-RMS column (noise floors when the
/// response is floor-weighted).
///
/// The smallest is 0.1: a term worth less than a tenth of a noise floor changes no score a
/// user reads, and on a residual many floors large, smaller thresholds admit terms that fit
/// the noise of the large one.
pub const THRESHOLDS: [f64; 9] = [0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0];

/// Rows of one regression: response, features, weight and group per row.
#[derive(Debug, Clone, Default)]
pub struct Rows {
    /// Response per row.
    pub y: Vec<f64>,
    /// Feature values per row (one entry per library column).
    pub x: Vec<Vec<f64>>,
    /// Weight per row (the row and its response are multiplied by it).
    pub w: Vec<f64>,
    /// Group per row (rows of a group are resampled together).
    pub group: Vec<u32>,
}

impl Rows {
    /// Appends one row.
    pub fn push(&mut self, y: f64, x: Vec<f64>, w: f64, group: u32) {
        self.y.push(y);
        self.x.push(x);
        self.w.push(w);
        self.group.push(group);
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// No row.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    fn groups(&self) -> Vec<u32> {
        let mut g = self.group.clone();
        g.sort_unstable();
        g.dedup();
        g
    }
}

/// The library: column names, and which column is the intercept (never screened as constant).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Library {
    /// Column names.
    pub names: Vec<String>,
    /// Index of the intercept column, if any.
    pub intercept: Option<usize>,
}

/// Options of [`discover`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DiscoveryOptions {
    /// Bootstrap resamples for stability selection and intervals.
    pub bootstrap: usize,
    /// Seed of the resamples.
    pub seed: u64,
    /// STLSQ iterations at most.
    pub max_iter: usize,
    /// Validation RMS of the weighted response below which an equation is good enough (in
    /// noise floors when rows are weighted by 1 / floor): the threshold is then the largest
    /// one that reaches it, whatever smaller thresholds would fit below the floor.
    pub good_enough_rms: f64,
}

impl Default for DiscoveryOptions {
    fn default() -> Self {
        Self {
            bootstrap: 100,
            seed: 0,
            max_iter: 10,
            good_enough_rms: 1.2,
        }
    }
}

/// A library column left out, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// Column (or, for a whole regression, the response's name).
    pub what: String,
    /// Why.
    pub reason: String,
}

/// One term of a discovered equation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Term {
    /// Library column.
    pub feature: String,
    /// Coefficient (response units per feature unit).
    pub coefficient: f64,
    /// 95 % percentile bootstrap interval (by group).
    pub ci95: [f64; 2],
    /// Share of bootstrap resamples in which the chosen solver kept it.
    pub stability: f64,
}

/// A solver's threshold chosen on validation, and how its fit there scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolverScore {
    /// The solver.
    pub solver: SparseSolver,
    /// Its threshold (response units per unit-RMS column).
    pub threshold: f64,
    /// Weighted RMS of the validation residual after its fit at that threshold on all
    /// training rows (in noise floors when rows are floor-weighted).
    pub validation_rms: f64,
    /// Terms of that fit, before stability selection.
    pub terms: usize,
}

/// A discovered equation `y = Σ c_k φ_k`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Equation {
    /// The kept terms (none: nothing the library explains).
    pub terms: Vec<Term>,
    /// Threshold chosen on validation (response units per unit-RMS column).
    pub threshold: f64,
    /// The sparse regression chosen on validation.
    #[serde(default)]
    pub solver: SparseSolver,
    /// Each solver's own choice of threshold and its validation score, the chosen one among
    /// them.
    #[serde(default)]
    pub solvers: Vec<SolverScore>,
    /// Uncentred validation R² (see the module doc).
    pub validation_r2: f64,
    /// Weighted RMS of the response on validation rows, before and after the equation.
    pub validation_rms: [f64; 2],
    /// Terms chosen in some but not most resamples (unstable), with their frequency.
    pub unstable: Vec<(String, f64)>,
    /// Columns left out before the fit.
    pub skipped: Vec<Skipped>,
    /// Training and validation rows.
    pub rows: [usize; 2],
}

/// Discovers a sparse equation for `train` (threshold chosen on `validation`); see the
/// module doc. `Err` says why no regression could be run.
pub fn discover(
    library: &Library,
    train: &Rows,
    validation: &Rows,
    opts: &DiscoveryOptions,
) -> Result<Equation, Skipped> {
    check_rows(library, train, validation)?;
    let columns = Columns::screen(library, train);
    if columns.cols.is_empty() {
        return Err(regression_skipped("no usable library column".into()));
    }
    let design = Design {
        train: columns.design(train),
        validation: columns.design(validation),
    };
    let (choice, solvers) = choose_solver(&design, train, validation, opts)?;
    let threshold = choice.threshold;
    let stable = Stability::resample(&design, train, &choice, opts);
    let freq = &stable.freq;
    let kept: Vec<usize> = (0..columns.cols.len())
        .filter(|&k| freq[k] >= STABILITY_THRESHOLD)
        .collect();
    let unstable = (0..columns.cols.len())
        .filter(|&k| freq[k] > 0.0 && freq[k] < STABILITY_THRESHOLD)
        .map(|k| (library.names[columns.cols[k]].clone(), freq[k]))
        .collect();
    let bv = &design.validation.1;
    let mut eq = Equation {
        terms: Vec::new(),
        threshold,
        solver: choice.solver,
        solvers,
        validation_r2: 0.0,
        validation_rms: [rms(bv), rms(bv)],
        unstable,
        skipped: columns.skipped.clone(),
        rows: [train.len(), validation.len()],
    };
    if kept.is_empty() {
        return Ok(eq);
    }
    fit_terms(
        &mut eq,
        &Kept {
            library,
            design: &design,
            columns: &columns,
            stable: &stable,
            kept: &kept,
        },
    );
    Ok(eq)
}

/// A whole regression that could not be run, and why.
fn regression_skipped(reason: String) -> Skipped {
    Skipped {
        what: "regression".into(),
        reason,
    }
}

/// Rows that fit no regression: a row without the library's columns, too few groups, a
/// non-finite response.
fn check_rows(library: &Library, train: &Rows, validation: &Rows) -> Result<(), Skipped> {
    let p = library.names.len();
    if train.x.iter().chain(&validation.x).any(|r| r.len() != p) {
        return Err(regression_skipped(format!(
            "a row does not have the library's {p} columns"
        )));
    }
    let (g_train, g_val) = (train.groups().len(), validation.groups().len());
    if g_train < MIN_GROUPS || g_val < MIN_GROUPS {
        return Err(regression_skipped(format!(
            "too few steps to fit a library: {g_train} training and {g_val} validation (at least {MIN_GROUPS} each)"
        )));
    }
    if train.y.iter().chain(&validation.y).any(|v| !v.is_finite()) {
        return Err(regression_skipped("the response has non-finite values".into()));
    }
    Ok(())
}

/// Weighted root mean square of a residual.
fn rms(r: &DVector<f64>) -> f64 {
    (r.norm_squared() / r.len().max(1) as f64).sqrt()
}

/// The library columns kept for the fit, with their scales, and those left out.
struct Columns {
    /// Library indices of the kept columns.
    cols: Vec<usize>,
    /// Weighted RMS of each kept column on the training rows.
    scales: Vec<f64>,
    /// Columns left out, with why.
    skipped: Vec<Skipped>,
}

impl Columns {
    /// Screens every column on the training rows, in library order (a column is compared
    /// with the kept ones before it).
    fn screen(library: &Library, train: &Rows) -> Self {
        let mut out = Self {
            cols: Vec::new(),
            scales: Vec::new(),
            skipped: Vec::new(),
        };
        for j in 0..library.names.len() {
            match out.verdict(library, train, j) {
                Ok(rms) => {
                    out.cols.push(j);
                    out.scales.push(rms);
                }
                Err(reason) => out.skipped.push(Skipped {
                    what: library.names[j].clone(),
                    reason,
                }),
            }
        }
        out
    }

    /// Column `j`'s weighted RMS when it is usable beside the columns kept so far, else why
    /// not.
    fn verdict(&self, library: &Library, train: &Rows, j: usize) -> Result<f64, String> {
        let v: Vec<f64> = train.x.iter().zip(&train.w).map(|(r, w)| r[j] * w).collect();
        if v.iter().any(|x| !x.is_finite()) {
            return Err("non-finite values".into());
        }
        let raw: Vec<f64> = train.x.iter().map(|r| r[j]).collect();
        let mean = raw.iter().sum::<f64>() / raw.len() as f64;
        let spread = raw.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
        let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        if Some(j) != library.intercept && spread <= 1e-12 * mean.abs().max(1.0) {
            return Err(if rms == 0.0 {
                "zero on every row".into()
            } else {
                "constant on every row (the intercept stands for it)".into()
            });
        }
        if rms == 0.0 {
            return Err("zero on every row".into());
        }
        if let Some(&k) = self.cols.iter().find(|&&k| {
            let u: Vec<f64> = train.x.iter().zip(&train.w).map(|(r, w)| r[k] * w).collect();
            correlation(&u, &v).abs() > MAX_COLUMN_CORRELATION
        }) {
            return Err(format!(
                "collinear with `{}` (|r| > {MAX_COLUMN_CORRELATION})",
                library.names[k]
            ));
        }
        // A combination of several earlier columns (Δcmd = cmd − previous cmd) is as
        // unusable as a copy of one.
        if let Some(explained) = self.explained_by_kept(train, v) {
            if explained > MAX_COLUMN_CORRELATION * MAX_COLUMN_CORRELATION {
                return Err(format!(
                    "a combination of earlier columns (R² {explained:.4} > {:.4})",
                    MAX_COLUMN_CORRELATION * MAX_COLUMN_CORRELATION
                ));
            }
        }
        Ok(rms)
    }

    /// The share of `v` (a weighted column) the kept columns explain by least squares;
    /// `None` before any column is kept or when the fit fails.
    fn explained_by_kept(&self, train: &Rows, v: Vec<f64>) -> Option<f64> {
        if self.cols.is_empty() {
            return None;
        }
        let kept = DMatrix::from_fn(train.len(), self.cols.len(), |i, k| {
            train.x[i][self.cols[k]] * train.w[i] / self.scales[k]
        });
        let vv = DVector::from_vec(v);
        let c = minimum_norm_least_squares(&kept, &vv)?;
        let fit = &kept * c;
        Some(1.0 - (&vv - fit).norm_squared() / vv.norm_squared())
    }

    /// The weighted, scaled design matrix of `rows` on the kept columns, and the weighted
    /// response.
    fn design(&self, rows: &Rows) -> (DMatrix<f64>, DVector<f64>) {
        let n = rows.len();
        let a = DMatrix::from_fn(n, self.cols.len(), |i, k| {
            rows.x[i][self.cols[k]] * rows.w[i] / self.scales[k]
        });
        let b = DVector::from_fn(n, |i, _| rows.y[i] * rows.w[i]);
        (a, b)
    }
}

/// The training and validation designs.
struct Design {
    train: (DMatrix<f64>, DVector<f64>),
    validation: (DMatrix<f64>, DVector<f64>),
}

/// A solver's choice of threshold, and what it scores on validation.
struct Choice {
    solver: SparseSolver,
    threshold: f64,
    /// The validation loss (weighted squared residual) of each validation group at that
    /// threshold.
    per_group: Vec<f64>,
    /// Terms of the fit at that threshold on all training rows.
    terms: usize,
}

impl Choice {
    fn loss(&self) -> f64 {
        self.per_group.iter().sum()
    }
}

/// The solver and its threshold: each solver's threshold chosen by [`threshold_for`], then
/// the solver whose validation loss is lower than the incumbent's (STLSQ's) by more than one
/// standard error of the paired difference over validation groups; otherwise the incumbent.
/// A challenger must win clearly, as a smaller threshold must under the one-standard-error
/// rule.
fn choose_solver(
    design: &Design,
    train: &Rows,
    validation: &Rows,
    opts: &DiscoveryOptions,
) -> Result<(Choice, Vec<SolverScore>), Skipped> {
    let mut choices = Vec::new();
    for solver in SparseSolver::ALL {
        choices.push(threshold_for(solver, design, train, validation, opts)?);
    }
    let scores = choices
        .iter()
        .map(|c| SolverScore {
            solver: c.solver,
            threshold: c.threshold,
            validation_rms: (c.loss() / validation.len().max(1) as f64).sqrt(),
            terms: c.terms,
        })
        .collect();
    let mut best = 0;
    for (k, c) in choices.iter().enumerate().skip(1) {
        if clearly_better(&choices[0].per_group, &c.per_group) && c.loss() < choices[best].loss() {
            best = k;
        }
    }
    Ok((choices.swap_remove(best), scores))
}

/// A challenger's validation losses per group are lower than the incumbent's by more than
/// one standard error of the paired difference (groups are the validation steps).
fn clearly_better(incumbent: &[f64], challenger: &[f64]) -> bool {
    let d: Vec<f64> = incumbent.iter().zip(challenger).map(|(a, b)| a - b).collect();
    let m = d.len() as f64;
    if m < 2.0 {
        return false;
    }
    let mean = d.iter().sum::<f64>() / m;
    let se = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0) / m).sqrt();
    mean > se
}

/// `solver`'s threshold: the sparser of the one-standard-error rule's on the validation loss
/// and the Bayesian information criterion's on the training fit (see the module doc).
fn threshold_for(
    solver: SparseSolver,
    design: &Design,
    train: &Rows,
    validation: &Rows,
    opts: &DiscoveryOptions,
) -> Result<Choice, Skipped> {
    let ((a, b), (av, bv)) = (&design.train, &design.validation);
    let train_groups = train.groups().len();
    let val_groups = validation.groups();
    let group_index: Vec<usize> = validation
        .group
        .iter()
        .map(|g| val_groups.binary_search(g).unwrap_or(0))
        .collect();
    // SR3 factors its relaxed normal equations once for every threshold.
    let sr3 = match solver {
        SparseSolver::Sr3 => Sr3::new(a, b),
        SparseSolver::Stlsq => None,
    };
    let mut fits = Vec::new();
    for &lambda in &THRESHOLDS {
        let xi = match &sr3 {
            Some(s) => s.fit(lambda),
            None => solver.fit(a, b, lambda, opts.max_iter),
        };
        let terms = xi.iter().filter(|c| **c != 0.0).count();
        let bic = bic((b - a * &xi).norm_squared(), b.len(), train_groups, terms);
        let r = bv - av * &xi;
        let mut per_group = vec![0.0; val_groups.len()];
        for (i, v) in r.iter().enumerate() {
            per_group[group_index[i]] += v * v;
        }
        fits.push((lambda, bic, per_group, terms));
    }
    let loss = |f: &(f64, f64, Vec<f64>, usize)| f.2.iter().sum::<f64>();
    let se = |f: &(f64, f64, Vec<f64>, usize)| {
        let m = f.2.len() as f64;
        let mean = loss(f) / m;
        (f.2.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt() * m.sqrt()
    };
    let best = fits
        .iter()
        .min_by(|x, y| loss(x).total_cmp(&loss(y)))
        .ok_or_else(|| regression_skipped("no threshold".into()))?;
    // An equation that already brings the response to `good_enough_rms` is as good as any:
    // terms below the noise floor only fit it.
    let enough = opts.good_enough_rms.powi(2) * validation.len() as f64;
    let one_se = fits
        .iter()
        .filter(|f| loss(f) <= (loss(best) + se(best)).max(enough))
        .map(|f| f.0)
        .fold(best.0, f64::max);
    // The criterion's least value; on a tie, the larger threshold (the sparser equation).
    let by_bic = fits
        .iter()
        .reduce(|m, x| if x.1 <= m.1 { x } else { m })
        .map_or(one_se, |f| f.0);
    let threshold = one_se.max(by_bic);
    let chosen = fits
        .into_iter()
        .find(|f| f.0 == threshold)
        .ok_or_else(|| regression_skipped("no threshold".into()))?;
    Ok(Choice {
        solver,
        threshold,
        per_group: chosen.2,
        terms: chosen.3,
    })
}

/// The Bayesian information criterion of a least-squares fit with `terms` coefficients whose
/// residual sum of squares over `rows` rows is `rss`, on the step-clustered likelihood: the
/// rows of a step share its errors, so the sample counts `groups` steps, not rows (a Gaussian
/// log-likelihood scaled from rows to steps), and each coefficient costs ln(steps).
pub fn bic(rss: f64, rows: usize, groups: usize, terms: usize) -> f64 {
    let g = groups.max(1) as f64;
    g * (rss / rows.max(1) as f64).max(f64::MIN_POSITIVE).ln() + terms as f64 * g.ln()
}

/// Stability selection over bootstrap resamples of the training groups.
struct Stability {
    /// Share of resamples in which each kept column was chosen.
    freq: Vec<f64>,
    /// The resamples' training rows (for the intervals).
    resamples: Vec<Vec<usize>>,
}

impl Stability {
    /// The chosen solver at half its threshold on `opts.bootstrap` resamples of the training
    /// groups.
    fn resample(design: &Design, train: &Rows, choice: &Choice, opts: &DiscoveryOptions) -> Self {
        let (a, b) = &design.train;
        let groups = train.groups();
        let rows_of: Vec<Vec<usize>> = groups
            .iter()
            .map(|g| (0..train.len()).filter(|&i| train.group[i] == *g).collect())
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        let mut chosen = vec![0usize; a.ncols()];
        let mut resamples: Vec<Vec<usize>> = Vec::with_capacity(opts.bootstrap);
        for _ in 0..opts.bootstrap {
            let idx: Vec<usize> = (0..groups.len())
                .flat_map(|_| rows_of[rng.random_range(0..groups.len())].iter().copied())
                .collect();
            let ab = a.select_rows(idx.iter());
            let bb = b.select_rows(idx.iter());
            let xi = choice.solver.fit(&ab, &bb, 0.5 * choice.threshold, opts.max_iter);
            for (k, c) in chosen.iter_mut().enumerate() {
                if xi[k] != 0.0 {
                    *c += 1;
                }
            }
            resamples.push(idx);
        }
        let freq = chosen
            .iter()
            .map(|&c| c as f64 / opts.bootstrap.max(1) as f64)
            .collect();
        Self { freq, resamples }
    }
}

/// What the final fit on the stable terms reads.
struct Kept<'a> {
    library: &'a Library,
    design: &'a Design,
    columns: &'a Columns,
    stable: &'a Stability,
    /// Indices (among the kept columns) of the stable terms.
    kept: &'a [usize],
}

/// Least squares on the stable terms over all training rows, their percentile intervals over
/// the resamples, and the validation R² and RMS, into `eq`.
fn fit_terms(eq: &mut Equation, k: &Kept<'_>) {
    let ((a, b), (av, bv)) = (&k.design.train, &k.design.validation);
    let (kept, scales) = (k.kept, &k.columns.scales);
    let ak = a.select_columns(kept.iter());
    let Some(xi) = least_squares(&ak, b) else {
        eq.skipped.push(regression_skipped(
            "the kept terms' design matrix is singular".into(),
        ));
        return;
    };
    let mut boot: Vec<Vec<f64>> = vec![Vec::new(); kept.len()];
    for idx in &k.stable.resamples {
        if let Some(x) = least_squares(&ak.select_rows(idx.iter()), &b.select_rows(idx.iter())) {
            for (j, v) in x.iter().enumerate() {
                boot[j].push(*v / scales[kept[j]]);
            }
        }
    }
    let avk = av.select_columns(kept.iter());
    let r = bv - &avk * &xi;
    let energy = bv.norm_squared();
    eq.validation_r2 = if energy > 0.0 {
        1.0 - r.norm_squared() / energy
    } else {
        0.0
    };
    eq.validation_rms[1] = rms(&r);
    for (j, &c) in kept.iter().enumerate() {
        let coefficient = xi[j] / scales[c];
        let ci95 = percentile_interval(&mut boot[j]).unwrap_or([coefficient, coefficient]);
        eq.terms.push(Term {
            feature: k.library.names[k.columns.cols[c]].clone(),
            coefficient,
            ci95,
            stability: k.stable.freq[c],
        });
    }
}

fn correlation(u: &[f64], v: &[f64]) -> f64 {
    // Uncentred: two columns that are multiples of each other cannot both be fitted, whatever
    // their means (the intercept is one column among others).
    let uv: f64 = u.iter().zip(v).map(|(a, b)| a * b).sum();
    let uu: f64 = u.iter().map(|a| a * a).sum();
    let vv: f64 = v.iter().map(|a| a * a).sum();
    if uu == 0.0 || vv == 0.0 {
        0.0
    } else {
        uv / (uu * vv).sqrt()
    }
}

/// 2.5 and 97.5 % percentiles (linear interpolation); `None` for fewer than 2 values.
fn percentile_interval(v: &mut [f64]) -> Option<[f64; 2]> {
    if v.len() < 2 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some([
        drive_sim_analysis::stats::quantile_sorted(v, 0.025),
        drive_sim_analysis::stats::quantile_sorted(v, 0.975),
    ])
}

#[cfg(test)]
mod tests;
