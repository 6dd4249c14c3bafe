//! The ground: a rapier collider (a half-space on flat terrains, a seeded Gaussian height
//! field on rough ones) and the suspension ray casts against it.
//!
//! The ray casts do not go through parry: a suspension ray is nearly vertical and the ground
//! is a plane or a gently sloped height field, so the hit is the root of a piecewise-linear
//! function of the distance, which Newton's method finds exactly in one or two steps on the
//! same triangles as parry's height field (same heights, same diagonal). Parry's general
//! cast (a traversal of the cells the ray crosses, in f32) took 14 % of a simulated DRIVE
//! run; the lookup takes under 1 %. Where the lookup cannot vouch for its answer (a slope
//! steeper than the ray, no convergence), it asks parry.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::parry::query::Ray;
use rapier3d::parry::utils::Array2;
use rapier3d::prelude::*;

/// Number of random Fourier modes of the height field: enough for a visually Gaussian
/// surface, few enough to build a 100 m field in milliseconds.
const MODES: usize = 48;

/// Where a ray met the ground.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Distance along the ray, m.
    pub distance_m: f64,
    /// Ground normal at the hit (unit, world frame).
    pub normal: [f64; 3],
}

/// The ground collider, held in the simulator's collider set, and the shape the ray casts
/// read directly.
#[derive(Debug, Clone)]
pub struct Ground {
    handle: ColliderHandle,
    shape: Surface,
}

/// What the suspension rays are cast against.
#[derive(Debug, Clone)]
enum Surface {
    /// The plane z = 0.
    Flat,
    /// The height field, as parry triangulates it.
    Field(HeightGrid),
}

/// A square height grid in the world frame, triangulated as parry's height field with default
/// cell status: in each cell, the diagonal joins node (i + 1, j) and node (i, j + 1).
#[derive(Debug, Clone)]
struct HeightGrid {
    /// Nodes per side.
    n: usize,
    /// Node spacing, m.
    spacing_m: f64,
    /// Half the side length, m: node j is at x = -half + j spacing, row i at y = half - i spacing.
    half_m: f64,
    /// Heights, m, row-major: `heights[i * n + j]`, rounded to f32 like the collider's.
    heights: Vec<f64>,
}

impl HeightGrid {
    /// The plane of the triangle under (x, y) as (height, dh/dx, dh/dy), or `None` off the grid.
    fn plane_at(&self, x: f64, y: f64) -> Option<(f64, f64, f64)> {
        // Local cell coordinates: s along +x (columns), t along rows (world -y).
        let u = (x + self.half_m) / self.spacing_m;
        let v = (self.half_m - y) / self.spacing_m;
        let last = (self.n - 1) as f64;
        if !(0.0..=last).contains(&u) || !(0.0..=last).contains(&v) {
            return None;
        }
        // Truncation is the floor here (u, v >= 0) and, unlike `floor`, one instruction.
        let j = (u as usize).min(self.n - 2);
        let i = (v as usize).min(self.n - 2);
        let (s, t) = (u - j as f64, v - i as f64);
        let h = |i: usize, j: usize| self.heights[i * self.n + j];
        let (dhds, dhdt, h_at) = if s + t <= 1.0 {
            // Triangle (i, j), (i + 1, j), (i, j + 1).
            let (h00, h10, h01) = (h(i, j), h(i + 1, j), h(i, j + 1));
            (h01 - h00, h10 - h00, h00 + s * (h01 - h00) + t * (h10 - h00))
        } else {
            // Triangle (i + 1, j), (i + 1, j + 1), (i, j + 1).
            let (h11, h10, h01) = (h(i + 1, j + 1), h(i + 1, j), h(i, j + 1));
            (
                h11 - h10,
                h11 - h01,
                h11 + (1.0 - s) * (h10 - h11) + (1.0 - t) * (h01 - h11),
            )
        };
        // t grows towards -y.
        Some((h_at, dhds / self.spacing_m, -dhdt / self.spacing_m))
    }

    /// The first hit of the ray `origin + d dir` (d in [0, max_m]) on the grid; `Err(())`
    /// when the lookup cannot vouch for its answer.
    fn cast(&self, origin: [f64; 3], dir: [f64; 3], max_m: f64) -> Result<Option<Hit>, ()> {
        // g(d) = ray height - ground height under the ray: piecewise linear in d.
        let mut d = 0.0;
        for _ in 0..8 {
            let (x, y) = (origin[0] + d * dir[0], origin[1] + d * dir[1]);
            let Some((h, hx, hy)) = self.plane_at(x, y) else {
                // Off the grid at the start: parry's field is not under the ray either.
                return if d == 0.0 { Ok(None) } else { Err(()) };
            };
            let g = origin[2] + d * dir[2] - h;
            let slope = dir[2] - hx * dir[0] - hy * dir[1];
            if slope >= -1e-9 {
                // The ray does not descend through this triangle: not the nearly vertical cast
                // the lookup is for.
                return Err(());
            }
            if g < 0.0 && d == 0.0 {
                // The origin is below the ground: parry's solid field reports a hit at 0.
                return Err(());
            }
            if g.abs() <= 1e-12 {
                if d > max_m {
                    return Ok(None);
                }
                let n = (hx * hx + hy * hy + 1.0).sqrt();
                return Ok(Some(Hit {
                    distance_m: d,
                    normal: [-hx / n, -hy / n, 1.0 / n],
                }));
            }
            d -= g / slope;
            if d > max_m + self.spacing_m {
                return Ok(None);
            }
        }
        Err(())
    }
}

impl Ground {
    /// Inserts the ground into `colliders`: flat at z = 0 when `height_std_m == 0`, otherwise a
    /// height field of `extent_m` x `extent_m` centred on the origin, Gaussian heights of
    /// standard deviation `height_std_m` and Gaussian correlation of length
    /// `correlation_length_m`, drawn from `seed`.
    pub fn build(
        colliders: &mut ColliderSet,
        height_std_m: f64,
        correlation_length_m: f64,
        extent_m: f64,
        seed: u64,
    ) -> Self {
        let (builder, shape) = if height_std_m <= 0.0 {
            (
                ColliderBuilder::new(SharedShape::halfspace(Vector::Z)),
                Surface::Flat,
            )
        } else {
            let (heights, spacing) = height_grid(height_std_m, correlation_length_m, extent_m, seed);
            let n = heights.nrows();
            let size = spacing * (n - 1) as f64;
            let mut rows = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    rows[i * n + j] = heights[(i, j)] as f64;
                }
            }
            let grid = HeightGrid {
                n,
                spacing_m: spacing,
                half_m: size / 2.0,
                heights: rows,
            };
            // Parry height fields are y-up with rows along local z; rotating by +90° about x
            // maps local y to world z and local z to world -y.
            let builder = ColliderBuilder::heightfield(heights, Vector::new(size as f32, 1.0, size as f32))
                .rotation(Vector::X * std::f32::consts::FRAC_PI_2);
            (builder, Surface::Field(grid))
        };
        Self {
            handle: colliders.insert(builder.build()),
            shape,
        }
    }

    /// Half the side of the height field's square, m (`None` for the unbounded plane): beyond
    /// it there is no ground.
    pub fn half_extent_m(&self) -> Option<f64> {
        match &self.shape {
            Surface::Flat => None,
            Surface::Field(grid) => Some(grid.half_m),
        }
    }

    /// Casts a ray from `origin` along the unit `dir` (world frame) up to `max_m`: the direct
    /// lookup of the module docs, parry's cast where the lookup declines.
    pub fn cast(&self, colliders: &ColliderSet, origin: [f64; 3], dir: [f64; 3], max_m: f64) -> Option<Hit> {
        match &self.shape {
            Surface::Flat if dir[2] < 0.0 && origin[2] >= 0.0 => {
                let d = origin[2] / -dir[2];
                (d <= max_m).then_some(Hit {
                    distance_m: d,
                    normal: [0.0, 0.0, 1.0],
                })
            }
            Surface::Field(grid) => match grid.cast(origin, dir, max_m) {
                Ok(hit) => hit,
                Err(()) => self.cast_parry(colliders, origin, dir, max_m),
            },
            Surface::Flat => self.cast_parry(colliders, origin, dir, max_m),
        }
    }

    /// Parry's ray cast against the collider (in f32).
    pub fn cast_parry(
        &self,
        colliders: &ColliderSet,
        origin: [f64; 3],
        dir: [f64; 3],
        max_m: f64,
    ) -> Option<Hit> {
        let c = &colliders[self.handle];
        let ray = Ray::new(
            Vector::new(origin[0] as f32, origin[1] as f32, origin[2] as f32),
            Vector::new(dir[0] as f32, dir[1] as f32, dir[2] as f32),
        );
        let hit = c
            .shape()
            .cast_ray_and_get_normal(c.position(), &ray, max_m as f32, true)?;
        let mut n = [hit.normal.x as f64, hit.normal.y as f64, hit.normal.z as f64];
        // A ray from above can meet a triangle from below on a vertical edge; the ground
        // pushes up.
        if n[2] < 0.0 {
            n = [-n[0], -n[1], -n[2]];
        }
        Some(Hit {
            distance_m: hit.time_of_impact as f64,
            normal: n,
        })
    }

    /// Ground height under (x, y), by a vertical ray from 50 m above; 0 when off the field.
    pub fn height_at(&self, colliders: &ColliderSet, x: f64, y: f64) -> f64 {
        self.cast(colliders, [x, y, 50.0], [0.0, 0.0, -1.0], 100.0)
            .map_or(0.0, |h| 50.0 - h.distance_m)
    }
}

/// Heights on a square grid (row i along world -y, column j along world x) and the spacing.
/// A sum of random cosines with wave vectors drawn from N(0, 1/l²) per component has the
/// covariance `σ² exp(-r² / (2 l²))`; each cosine separates into products of per-row and
/// per-column tables, so the grid costs no trigonometry per node.
fn height_grid(std_m: f64, corr_m: f64, extent_m: f64, seed: u64) -> (Array2<f32>, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6772_6f75_6e64);
    let spacing = (corr_m / 2.0).clamp(0.05, 0.5);
    let n = ((extent_m / spacing).ceil() as usize + 1).max(3);
    let half = spacing * (n - 1) as f64 / 2.0;
    let coord: Vec<f64> = (0..n).map(|k| -half + spacing * k as f64).collect();
    let amp = std_m * (2.0 / MODES as f64).sqrt();
    let mut h = vec![0.0f64; n * n];
    let mut cx = vec![0.0; n];
    let mut sx = vec![0.0; n];
    let mut cy = vec![0.0; n];
    let mut sy = vec![0.0; n];
    for _ in 0..MODES {
        let kx: f64 = rng.sample::<f64, _>(StandardNormal) / corr_m;
        let ky: f64 = rng.sample::<f64, _>(StandardNormal) / corr_m;
        let phase: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        for k in 0..n {
            (sx[k], cx[k]) = (kx * coord[k] + phase).sin_cos();
            (sy[k], cy[k]) = (ky * coord[k]).sin_cos();
        }
        // cos(kx x + φ + ky y) = cos(kx x + φ) cos(ky y) - sin(kx x + φ) sin(ky y)
        for i in 0..n {
            // Row i is at local z = coord[i], i.e. world y = -coord[i].
            let (c_y, s_y) = (cy[i], -sy[i]);
            // Zipped slices, not indices: no bounds checks in the loop that runs once per node
            // and mode (a 110 m field at 0.25 m is 194 000 nodes x 48 modes).
            let row = &mut h[i * n..(i + 1) * n];
            for ((r, c), s) in row.iter_mut().zip(&cx).zip(&sx) {
                *r += amp * (c * c_y - s * s_y);
            }
        }
    }
    // Array2 is column-major: element (i, j) at i + j * nrows.
    let mut data = vec![0.0f32; n * n];
    for i in 0..n {
        for j in 0..n {
            data[i + j * n] = h[i * n + j] as f32;
        }
    }
    (Array2::new(n, n, data), spacing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn height_field_is_up_and_has_the_requested_spread() {
        let mut cs = ColliderSet::new();
        let g = Ground::build(&mut cs, 0.02, 1.0, 40.0, 3);
        let mut sum2 = 0.0;
        let mut n = 0.0;
        for i in 0..40 {
            for j in 0..40 {
                let (x, y) = (-15.0 + 0.77 * i as f64, -15.0 + 0.73 * j as f64);
                let h = g.cast(&cs, [x, y, 1.0], [0.0, 0.0, -1.0], 2.0).unwrap();
                let z = 1.0 - h.distance_m;
                assert!(z.abs() < 0.15, "{x} {y} {z}");
                assert!(h.normal[2] > 0.9, "{:?}", h.normal);
                sum2 += z * z;
                n += 1.0;
            }
        }
        let std = (sum2 / n).sqrt();
        assert!(std > 0.01 && std < 0.03, "{std}");
    }

    /// The lookup and parry's cast agree on tilted rays over a rough field and on the plane
    /// (parry works in f32: agreement to its rounding).
    #[test]
    fn the_lookup_hits_where_parry_hits() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (std_m, corr_m) in [(0.0, 1.0), (0.01, 0.5), (0.05, 0.7)] {
            let mut cs = ColliderSet::new();
            let g = Ground::build(&mut cs, std_m, corr_m, 30.0, 11);
            let mut fallbacks = 0;
            for _ in 0..2000 {
                let x = rng.random_range(-12.0..12.0);
                let y = rng.random_range(-12.0..12.0);
                let (tx, ty): (f64, f64) = (rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4));
                let dz = -(1.0 - tx * tx - ty * ty).sqrt();
                let (o, d) = ([x, y, 0.6], [tx, ty, dz]);
                let ours = g.cast(&cs, o, d, 1.5).expect("a hit");
                let parry = g.cast_parry(&cs, o, d, 1.5).expect("a hit");
                assert!((ours.distance_m - parry.distance_m).abs() < 2e-5, "{o:?} {d:?}");
                for k in 0..3 {
                    assert!(
                        (ours.normal[k] - parry.normal[k]).abs() < 1e-4,
                        "{:?} {:?}",
                        ours,
                        parry
                    );
                }
                if let Surface::Field(grid) = &g.shape {
                    fallbacks += usize::from(grid.cast(o, d, 1.5).is_err());
                }
            }
            // The fallback is for pathological rays, not the common case.
            assert!(fallbacks < 20, "{fallbacks} of 2000 rays fell back to parry");
            // A ray too short to reach the ground misses in both.
            assert!(g.cast(&cs, [0.0, 0.0, 0.6], [0.0, 0.0, -1.0], 0.3).is_none());
            assert!(g
                .cast_parry(&cs, [0.0, 0.0, 0.6], [0.0, 0.0, -1.0], 0.3)
                .is_none());
        }
    }
}
