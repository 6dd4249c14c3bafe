use super::super::{Layout, LeastSquares};
use super::*;

/// y = a·exp(−b t) sampled on two channels with different noise, clusters of 5 samples.
struct Decay {
    t: Vec<f64>,
    y: Vec<f64>,
    layout: Layout,
}

impl LeastSquares for Decay {
    fn dim(&self) -> usize {
        2
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        vec![(0.1, 10.0), (0.01, 5.0)]
    }
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        Some(
            self.t
                .iter()
                .zip(&self.y)
                .map(|(t, y)| x[0] * (-x[1] * t).exp() - y)
                .collect(),
        )
    }
    fn layout(&self) -> &Layout {
        &self.layout
    }
}

#[test]
fn recovers_an_exact_model_and_stops_on_a_criterion() {
    let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.1).collect();
    let y: Vec<f64> = t.iter().map(|t| 2.5 * (-0.7 * t).exp()).collect();
    let layout = Layout {
        channel: (0..40).map(|i| (i % 2) as u8).collect(),
        cluster: (0..40).map(|i| i / 5).collect(),
        floor: vec![1.0, 1.0],
        min_ratio: 0.0,
    };
    let p = Decay { t, y, layout };
    let sol = minimize(&p, &[1.0, 2.0], &LmOptions::default(), &mut |_| {});
    assert!(sol.stop.converged(), "{:?}", sol.stop);
    assert!(
        (sol.x[0] - 2.5).abs() < 1e-4 && (sol.x[1] - 0.7).abs() < 1e-4,
        "{:?}",
        sol.x
    );
}

/// Two channels each see one parameter `x`: channel 0 wants x = 0 (2 entries), channel 1
/// wants x = 1 (1 entry), floors 1. The geometric-mean score
/// exp(½ [ln x² + ln (x − 1)²]) = x (1 − x) is smallest on the box [0.2, 0.7] at its lower
/// bound (0.16, against 0.21 at 0.7), while the arithmetic mean of the channel MSEs,
/// (x² + (x − 1)²) / 2, is smallest at x = 0.5. The solver must find the geometric one.
struct TwoChannels {
    layout: Layout,
}

impl LeastSquares for TwoChannels {
    fn dim(&self) -> usize {
        1
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        vec![(0.2, 0.7)]
    }
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        Some(vec![x[0], x[0], x[0] - 1.0])
    }
    fn layout(&self) -> &Layout {
        &self.layout
    }
}

#[test]
fn minimises_the_geometric_not_the_arithmetic_mean() {
    let p = TwoChannels {
        layout: Layout {
            channel: vec![0, 0, 1],
            cluster: vec![0, 1, 2],
            floor: vec![1.0, 1.0],
            min_ratio: 0.0,
        },
    };
    // By hand: score(x) = |x| |x − 1| on [0.2, 0.7]; score(0.2) = 0.16, score(0.5) = 0.25,
    // score(0.7) = 0.21. The minimum is the lower bound.
    let sol = minimize(&p, &[0.45], &LmOptions::default(), &mut |_| {});
    assert!((sol.x[0] - 0.2).abs() < 1e-9, "{:?}", sol);
    assert!((sol.score - 0.16).abs() < 1e-9, "{}", sol.score);
    assert!(sol.stop.converged(), "{:?}", sol.stop);
}
