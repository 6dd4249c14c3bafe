//! Small planar geometry shared by the strategies: convex polygon clipping and areas, and the
//! bounds of U.

use crate::kinematics::{polygon_area, CommandSpace};

/// Intersection of two convex polygons (vertices counter-clockwise), by Sutherland–Hodgman
/// clipping of `subject` with each edge of `clip`. Empty if they do not overlap.
pub fn convex_intersection(subject: &[(f64, f64)], clip: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = subject.to_vec();
    let n = clip.len();
    for i in 0..n {
        if out.is_empty() {
            break;
        }
        let (a, b) = (clip[i], clip[(i + 1) % n]);
        // Inside = left of the edge a->b (counter-clockwise clip polygon): cross >= 0.
        let side = |p: (f64, f64)| (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let p = input[j];
            let q = input[(j + 1) % input.len()];
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let t = sp / (sp - sq);
                out.push((p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1)));
            }
        }
    }
    out
}

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
