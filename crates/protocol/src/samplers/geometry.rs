//! Small planar geometry shared by the strategies: convex polygon clipping and areas, and the
//! bounds of U.

use drive_sim_model::geometry::polygon_area;
use drive_sim_model::kinematics::CommandSpace;

pub use drive_sim_model::geometry::clip_convex as convex_intersection;

/// Area of `poly` translated by `d` intersected with `poly` itself: the overlap of U with a copy
/// shifted by a step `d`. Divided by area(U)², it is the density of the step vector between two
/// independent uniform draws in U (the "tent" that makes uniform sampling favour small steps).
pub fn shifted_overlap_area(poly: &[(f64, f64)], d: (f64, f64)) -> f64 {
    let shifted: Vec<(f64, f64)> = poly.iter().map(|p| (p.0 + d.0, p.1 + d.1)).collect();
    let inter = convex_intersection(&shifted, poly);
    if inter.len() < 3 {
        0.0
    } else {
        polygon_area(&inter)
    }
}

/// Largest |vx| (m/s) and |wz| (rad/s) over U (U is symmetric about the origin).
pub fn body_bounds(space: &CommandSpace) -> (f64, f64) {
    space
        .polygon_body()
        .iter()
        .fold((0.0f64, 0.0f64), |(v, w), p| (v.max(p.0.abs()), w.max(p.1.abs())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_of_a_square_with_its_shift_by_hand() {
        // Unit square shifted by (0.25, 0.5): overlap 0.75 x 0.5 = 0.375.
        let sq = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
        assert!((shifted_overlap_area(&sq, (0.25, 0.5)) - 0.375).abs() < 1e-12);
        assert!((shifted_overlap_area(&sq, (-0.25, 0.0)) - 0.75).abs() < 1e-12);
        assert_eq!(shifted_overlap_area(&sq, (1.5, 0.0)), 0.0);
        // Square against a diamond inscribed in it: the diamond (area 1/2).
        let dia = [(0.5, 0.0), (1.0, 0.5), (0.5, 1.0), (0.0, 0.5)];
        assert!((polygon_area(&convex_intersection(&sq, &dia)) - 0.5).abs() < 1e-12);
    }
}
