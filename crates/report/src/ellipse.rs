//! Confidence ellipses of 2-D Gaussian summaries (risk map).

use nalgebra::{Matrix2, SymmetricEigen};

use crate::error::{Error, Result};

/// Chi-square quantile with 2 degrees of freedom at 95 %: `-2 ln(0.05)`.
pub const CHI2_2DOF_95: f64 = 5.991_464_547_107_979;

/// Axes of a confidence ellipse `(p - c)ᵀ Σ⁻¹ (p - c) = s` (s = chi-square scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EllipseAxes {
    /// Semi-axis along the largest-eigenvalue eigenvector: `sqrt(s · λ_max)`.
    pub semi_major: f64,
    /// Semi-axis along the other eigenvector: `sqrt(s · λ_min)`.
    pub semi_minor: f64,
    /// Angle of the major axis from the first coordinate axis, rad, in (-π/2, π/2].
    pub angle_rad: f64,
}

/// Axes of the ellipse of covariance `cov` scaled by the chi-square value `chi2`.
///
/// Errors if `cov` is not finite, not symmetric (relative tolerance 1e-9), or not positive
/// semi-definite, or if `chi2` is not positive. A zero variance gives a degenerate (flat)
/// ellipse, which is valid.
pub fn ellipse_axes(cov: [[f64; 2]; 2], chi2: f64) -> Result<EllipseAxes> {
    if !(chi2.is_finite() && chi2 > 0.0) {
        return Err(Error::InvalidShape(format!(
            "chi-square scale must be positive, got {chi2}"
        )));
    }
    let flat = [cov[0][0], cov[0][1], cov[1][0], cov[1][1]];
    if flat.iter().any(|v| !v.is_finite()) {
        return Err(Error::InvalidShape(format!("covariance {cov:?} is not finite")));
    }
    let scale = flat.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if (cov[0][1] - cov[1][0]).abs() > 1e-9 * scale.max(f64::MIN_POSITIVE) {
        return Err(Error::InvalidShape(format!(
            "covariance {cov:?} is not symmetric"
        )));
    }
    let m = Matrix2::new(cov[0][0], cov[0][1], cov[1][0], cov[1][1]);
    let eig = SymmetricEigen::new(m);
    let (l0, l1) = (eig.eigenvalues[0], eig.eigenvalues[1]);
    let tol = -1e-12 * scale;
    if l0 < tol || l1 < tol {
        return Err(Error::InvalidShape(format!(
            "covariance {cov:?} is not positive semi-definite (eigenvalues {l0}, {l1})"
        )));
    }
    let (major, lmax, lmin) = if l0 >= l1 { (0, l0, l1) } else { (1, l1, l0) };
    let v = eig.eigenvectors.column(major);
    let mut angle = v[1].atan2(v[0]);
    // An eigenvector's sign is arbitrary: fold the angle into (-π/2, π/2].
    if angle > std::f64::consts::FRAC_PI_2 {
        angle -= std::f64::consts::PI;
    } else if angle <= -std::f64::consts::FRAC_PI_2 {
        angle += std::f64::consts::PI;
    }
    Ok(EllipseAxes {
        semi_major: (chi2 * lmax.max(0.0)).sqrt(),
        semi_minor: (chi2 * lmin.max(0.0)).sqrt(),
        angle_rad: angle,
    })
}

/// `n` points (closed: the first is repeated at the end) on the confidence ellipse around
/// `centre`.
pub fn ellipse_points(
    centre: (f64, f64),
    cov: [[f64; 2]; 2],
    chi2: f64,
    n: usize,
) -> Result<Vec<(f64, f64)>> {
    if !(centre.0.is_finite() && centre.1.is_finite()) {
        return Err(Error::InvalidShape(format!(
            "ellipse centre {centre:?} is not finite"
        )));
    }
    let ax = ellipse_axes(cov, chi2)?;
    let n = n.max(8);
    let (s, c) = ax.angle_rad.sin_cos();
    Ok((0..=n)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            let (a, b) = (ax.semi_major * t.cos(), ax.semi_minor * t.sin());
            (centre.0 + a * c - b * s, centre.1 + a * s + b * c)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_by_hand() {
        // [[2, 1], [1, 2]]: eigenvalues 3 (along (1, 1)) and 1 (along (1, -1)).
        let a = ellipse_axes([[2.0, 1.0], [1.0, 2.0]], CHI2_2DOF_95).unwrap();
        assert!((a.semi_major - (5.991_464_547 * 3.0f64).sqrt()).abs() < 1e-8);
        assert!((a.semi_minor - 5.991_464_547f64.sqrt()).abs() < 1e-8);
        assert!((a.angle_rad - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // Diagonal with the larger variance on the second axis: major axis vertical.
        let b = ellipse_axes([[1.0, 0.0], [0.0, 4.0]], 1.0).unwrap();
        assert!((b.semi_major - 2.0).abs() < 1e-12 && (b.semi_minor - 1.0).abs() < 1e-12);
        assert!((b.angle_rad.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn points_satisfy_the_quadratic_form() {
        let cov = [[0.01, 3.0], [3.0, 2500.0]];
        let c = (0.4, 800.0);
        let pts = ellipse_points(c, cov, CHI2_2DOF_95, 64).unwrap();
        assert_eq!(pts.len(), 65);
        let det = cov[0][0] * cov[1][1] - cov[0][1] * cov[1][0];
        for (x, y) in pts {
            let (dx, dy) = (x - c.0, y - c.1);
            // Inverse of a 2x2 by hand.
            let q = (cov[1][1] * dx * dx - 2.0 * cov[0][1] * dx * dy + cov[0][0] * dy * dy) / det;
            assert!((q - CHI2_2DOF_95).abs() < 1e-6, "q = {q}");
        }
    }

    #[test]
    fn bad_covariances() {
        assert!(ellipse_axes([[1.0, 2.0], [2.0, 1.0]], 1.0).is_err()); // eigenvalue -1
        assert!(ellipse_axes([[1.0, 0.5], [0.0, 1.0]], 1.0).is_err()); // not symmetric
        assert!(ellipse_axes([[f64::NAN, 0.0], [0.0, 1.0]], 1.0).is_err());
        assert!(ellipse_axes([[1.0, 0.0], [0.0, 1.0]], 0.0).is_err());
        // Degenerate but valid: a single-point scenario.
        let z = ellipse_axes([[0.0, 0.0], [0.0, 0.0]], CHI2_2DOF_95).unwrap();
        assert_eq!((z.semi_major, z.semi_minor), (0.0, 0.0));
        assert!(ellipse_points((f64::NAN, 0.0), [[1.0, 0.0], [0.0, 1.0]], 1.0, 16).is_err());
    }
}
