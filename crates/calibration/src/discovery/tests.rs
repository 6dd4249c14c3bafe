use super::*;
use rand_distr::{Distribution, Normal};

/// Rows from `y = f(x) + noise`, 8 rows per group, features: 1, a, b, a·b, c (c = 2a + tiny).
fn rows(groups: u32, seed: u64, noise: f64, f: impl Fn(&[f64]) -> f64) -> Rows {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = Normal::new(0.0, 1.0).unwrap();
    let mut r = Rows::default();
    for g in 0..groups {
        for _ in 0..8 {
            let a: f64 = rng.random_range(-1.0..1.0);
            let b: f64 = rng.random_range(-2.0..2.0);
            let x = vec![1.0, a, b, a * b, 3.0];
            let y = f(&x) + noise * n.sample(&mut rng);
            // Weighted by 1 / noise: the response in noise floors, as the calibration weights it.
            r.push(y, x, 1.0 / noise, g);
        }
    }
    r
}

fn library() -> Library {
    Library {
        names: ["1", "a", "b", "ab", "const"].map(String::from).to_vec(),
        intercept: Some(0),
    }
}

#[test]
fn finds_a_sparse_law_with_intervals() {
    let truth = |x: &[f64]| 0.4 * x[3] - 0.2;
    let eq = discover(
        &library(),
        &rows(30, 1, 0.05, truth),
        &rows(10, 2, 0.05, truth),
        &DiscoveryOptions::default(),
    )
    .unwrap();
    let names: Vec<&str> = eq.terms.iter().map(|t| t.feature.as_str()).collect();
    assert_eq!(names, ["1", "ab"], "{eq:?}");
    for (t, c) in eq.terms.iter().zip([-0.2, 0.4]) {
        assert!((t.coefficient - c).abs() < 0.02, "{t:?}");
        assert!(t.ci95[0] <= c && c <= t.ci95[1], "{t:?}");
        assert!(t.stability >= STABILITY_THRESHOLD);
    }
    assert!(eq.validation_r2 > 0.9, "{}", eq.validation_r2);
    // The constant column is left out with its reason.
    assert!(eq
        .skipped
        .iter()
        .any(|s| s.what == "const" && s.reason.contains("constant")));
}

#[test]
fn noise_alone_proposes_nothing() {
    for seed in 0..5 {
        let eq = discover(
            &library(),
            &rows(30, 10 + seed, 1.0, |_| 0.0),
            &rows(10, 20 + seed, 1.0, |_| 0.0),
            &DiscoveryOptions {
                seed,
                ..DiscoveryOptions::default()
            },
        )
        .unwrap();
        assert!(eq.terms.is_empty(), "seed {seed}: {:?}", eq.terms);
    }
}

#[test]
fn bad_designs_are_skipped_with_a_reason() {
    let lib = library();
    let opts = DiscoveryOptions::default();
    // Too few groups.
    let e = discover(&lib, &rows(2, 1, 0.1, |_| 0.0), &rows(10, 2, 0.1, |_| 0.0), &opts).unwrap_err();
    assert!(e.reason.contains("too few steps"), "{e:?}");
    // A duplicated column: collinear, left out, and the fit still runs.
    let mut lib2 = lib.clone();
    lib2.names.push("a_again".into());
    let dup = |mut r: Rows| {
        for x in &mut r.x {
            x.push(x[1] * 2.0);
        }
        r
    };
    let eq = discover(
        &lib2,
        &dup(rows(20, 3, 0.05, |x| x[1])),
        &dup(rows(10, 4, 0.05, |x| x[1])),
        &opts,
    )
    .unwrap();
    assert!(eq
        .skipped
        .iter()
        .any(|s| s.what == "a_again" && s.reason.contains("collinear")));
    assert!(eq.terms.iter().all(|t| t.coefficient.is_finite()));
    // Non-finite response: skipped, not NaN.
    let mut bad = rows(10, 5, 0.1, |_| 0.0);
    bad.y[3] = f64::NAN;
    assert!(discover(&lib, &bad, &rows(10, 6, 0.1, |_| 0.0), &opts).is_err());
    // A singular system.
    let a = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 2.0, 4.0, 3.0, 6.0]);
    assert!(least_squares(&a, &DVector::from_vec(vec![1.0, 2.0, 3.0])).is_none());
}

/// The criterion by hand: 10 steps of 40 rows with a mean square of 1 cost only their
/// coefficients, ln 10 each; halving the mean square is worth 10 ln 2 = 6.93, more than three
/// coefficients (6.91) and less than four (9.21).
#[test]
fn bic_counts_steps_not_rows_and_charges_each_coefficient_ln_steps() {
    assert!((bic(400.0, 400, 10, 2) - 2.0 * 10f64.ln()).abs() < 1e-12);
    let base = bic(400.0, 400, 10, 1);
    assert!(bic(200.0, 400, 10, 4) < base);
    assert!(bic(200.0, 400, 10, 5) > base);
}

/// Eight columns sharing 90 % of their variance, three of them in the law: SR3 and STLSQ at
/// the same threshold, on designs where the law stands well above the noise, both find it.
#[test]
fn sr3_finds_a_sparse_law_among_correlated_columns() {
    let n = Normal::new(0.0, 1.0).unwrap();
    let truth = [0.5, -0.4, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0];
    for seed in 0..5u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (rows, p, shared) = (400, truth.len(), 0.9f64);
        let mut a = DMatrix::zeros(rows, p);
        for i in 0..rows {
            let z: f64 = n.sample(&mut rng);
            for j in 0..p {
                a[(i, j)] = shared.sqrt() * z + (1.0 - shared).sqrt() * n.sample(&mut rng);
            }
        }
        let b = DVector::from_fn(rows, |i, _| {
            (0..p).map(|j| a[(i, j)] * truth[j]).sum::<f64>() + 0.1 * n.sample(&mut rng)
        });
        let sr3 = Sr3::new(&a, &b).unwrap().fit(0.1);
        let st = stlsq(&a, &b, 0.1, 10);
        for j in 0..p {
            assert!((sr3[j] - truth[j]).abs() < 0.05, "seed {seed}: SR3 {sr3:?}");
            assert_eq!(
                sr3[j] != 0.0,
                st[j] != 0.0,
                "seed {seed}: SR3 {sr3:?}, STLSQ {st:?}"
            );
        }
    }
}

#[test]
fn a_challenger_solver_must_win_by_more_than_one_standard_error() {
    let incumbent = [1.0, 1.0, 1.0, 1.0];
    // Lower on every group: clearly better.
    assert!(clearly_better(&incumbent, &[0.8, 0.9, 0.85, 0.8]));
    // Lower in total, but by one group's luck: not.
    assert!(!clearly_better(&incumbent, &[0.2, 1.1, 1.1, 1.1]));
    // Equal: the incumbent stays.
    assert!(!clearly_better(&incumbent, &incumbent));
}

#[test]
fn the_equation_says_which_solver_it_used_and_how_each_scored() {
    let truth = |x: &[f64]| 0.4 * x[3] - 0.2;
    let eq = discover(
        &library(),
        &rows(30, 1, 0.05, truth),
        &rows(10, 2, 0.05, truth),
        &DiscoveryOptions::default(),
    )
    .unwrap();
    let solvers: Vec<SparseSolver> = eq.solvers.iter().map(|s| s.solver).collect();
    assert_eq!(solvers, SparseSolver::ALL);
    // Both find the law: a tie, and the incumbent keeps it.
    assert_eq!(eq.solver, SparseSolver::Stlsq);
    assert!(eq.solvers.iter().all(|s| s.terms == 2), "{:?}", eq.solvers);
    let chosen = eq.solvers.iter().find(|s| s.solver == eq.solver).unwrap();
    assert_eq!(chosen.threshold, eq.threshold);
}
