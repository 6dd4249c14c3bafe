//! The ground: a rapier collider (a half-space on flat terrains, a seeded Gaussian height
//! field on rough ones) and the suspension ray casts against it.

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

/// The ground collider, held in the simulator's collider set.
#[derive(Debug, Clone, Copy)]
pub struct Ground {
    handle: ColliderHandle,
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
        let builder = if height_std_m <= 0.0 {
            ColliderBuilder::new(SharedShape::halfspace(Vector::Z))
        } else {
            let (heights, spacing) = height_grid(height_std_m, correlation_length_m, extent_m, seed);
            let n = heights.nrows();
            let size = spacing * (n - 1) as f64;
            // Parry height fields are y-up with rows along local z; rotating by +90° about x
            // maps local y to world z and local z to world -y.
            ColliderBuilder::heightfield(heights, Vector::new(size as f32, 1.0, size as f32))
                .rotation(Vector::X * std::f32::consts::FRAC_PI_2)
        };
        Self {
            handle: colliders.insert(builder.build()),
        }
    }

    /// Casts a ray from `origin` along the unit `dir` (world frame) up to `max_m`.
    pub fn cast(&self, colliders: &ColliderSet, origin: [f64; 3], dir: [f64; 3], max_m: f64) -> Option<Hit> {
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
            let row = &mut h[i * n..(i + 1) * n];
            for j in 0..n {
                row[j] += amp * (cx[j] * c_y - sx[j] * s_y);
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
}
