//! Planar polygon geometry shared by the command space, the analysis of reached spaces, the
//! samplers and the figures: areas, convex hulls, convex clipping. Points are `(x, y)` pairs.

/// Wraps an angle to (-π, π].
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    // Within one turn `a % TAU` is `a` itself: skip the remainder (a libm `fmod` call, a
    // quarter of a kinematic calibration's time when every integration step wrapped its yaw).
    let mut a = if a.abs() < std::f64::consts::TAU {
        a
    } else {
        a % std::f64::consts::TAU
    };
    if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    } else if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    }
    a
}

/// Signed area (shoelace formula); positive for counter-clockwise polygons.
pub fn signed_area(poly: &[(f64, f64)]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (p, q) = (poly[i], poly[(i + 1) % n]);
            p.0 * q.1 - q.0 * p.1
        })
        .sum::<f64>()
        / 2.0
}

/// Area of a simple polygon.
pub fn polygon_area(poly: &[(f64, f64)]) -> f64 {
    signed_area(poly).abs()
}

/// The polygon with its vertices counter-clockwise.
pub fn ensure_ccw(mut poly: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if signed_area(&poly) < 0.0 {
        poly.reverse();
    }
    poly
}

/// Keeps the part of `poly` where `side(p) >= 0` (one Sutherland–Hodgman pass).
fn clip_by(poly: &[(f64, f64)], side: impl Fn((f64, f64)) -> f64) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            let t = sp / (sp - sq);
            out.push((p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1)));
        }
    }
    out
}

/// Clips a polygon by the half-plane `a x + c y <= d`.
pub fn clip_half_plane(poly: &[(f64, f64)], a: f64, c: f64, d: f64) -> Vec<(f64, f64)> {
    clip_by(poly, |p| d - (a * p.0 + c * p.1))
}

/// Intersection of `subject` with the convex polygon `clip` (either orientation); empty if they
/// do not overlap.
pub fn clip_convex(subject: &[(f64, f64)], clip: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let orient = if signed_area(clip) >= 0.0 { 1.0 } else { -1.0 };
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        if out.is_empty() {
            break;
        }
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        // Inside = left of a->b for a counter-clockwise clip polygon.
        out = clip_by(&out, |p| {
            orient * ((b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0))
        });
    }
    out
}

/// Convex hull of the finite points, counter-clockwise without collinear points (Andrew's
/// monotone chain). Fewer than three distinct points are returned as they are.
pub fn convex_hull(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|q| q.0.is_finite() && q.1.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross =
        |o: (f64, f64), a: (f64, f64), b: (f64, f64)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let chain = |pts: &mut dyn Iterator<Item = (f64, f64)>| {
        let mut h: Vec<(f64, f64)> = Vec::new();
        for q in pts {
            while h.len() >= 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
        h
    };
    let mut hull = chain(&mut p.iter().copied());
    hull.extend(chain(&mut p.iter().rev().copied()));
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn areas_hull_and_clipping_by_hand() {
        let sq = vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
        assert_eq!(signed_area(&sq), 1.0);
        let mut cw = sq.clone();
        cw.reverse();
        assert_eq!(signed_area(&cw), -1.0);
        assert!(signed_area(&ensure_ccw(cw.clone())) > 0.0);
        // Hull of the square's corners, its centre and a NaN: the four corners, CCW.
        let h = convex_hull(&[
            (0.5, 0.5),
            (1.0, 1.0),
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0),
            (f64::NAN, 0.0),
            (0.5, 0.0),
        ]);
        assert_eq!(h.len(), 4);
        assert_eq!(polygon_area(&h), 1.0);
        assert!(signed_area(&h) > 0.0);
        // Half-plane x + y <= 1 cuts the unit square into a triangle of area 1/2.
        assert!((polygon_area(&clip_half_plane(&sq, 1.0, 1.0, 1.0)) - 0.5).abs() < 1e-12);
        // The diamond |x| + |y| <= 1 against the square [0, 1]²: the same triangle, whichever
        // orientation the clip polygon has.
        let dia = vec![(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)];
        assert!((polygon_area(&clip_convex(&sq, &dia)) - 0.5).abs() < 1e-12);
        let mut dia_cw = dia.clone();
        dia_cw.reverse();
        assert!((polygon_area(&clip_convex(&sq, &dia_cw)) - 0.5).abs() < 1e-12);
        // Disjoint polygons: empty.
        let far: Vec<_> = sq.iter().map(|p| (p.0 + 5.0, p.1)).collect();
        assert!(clip_convex(&sq, &far).is_empty());
    }
}
