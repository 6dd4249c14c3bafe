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
