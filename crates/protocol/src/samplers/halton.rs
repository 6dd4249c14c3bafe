//! `halton`: a scrambled Halton sequence (bases 2 and 3) over the wheel-limit square, keeping the
//! points that fall in U.
//!
//! Low discrepancy: after N commands, every region of U has received close to its share of
//! them (error about log²N / N instead of 1/√N for independent draws), so short runs cover U
//! evenly. The seed draws a random permutation of the digits at each digit position of each
//! base (random digit scrambling, Matoušek 1998): different seeds give different, equally
//! well-spread sequences. Points outside U are skipped in sequence order, so the sequence stays
//! deterministic; the skipped subsequence keeps its low discrepancy over U.

use super::SamplerEntry;
use crate::sampler::{Sampler, SamplingContext};
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::Result;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "halton",
    summary: "scrambled Halton low-discrepancy sequence over the wheel-frame command space",
    build: |seed, _protocol| Box::new(Halton::new(seed)),
};

/// Bases of the two coordinates (left, right wheel).
const BASES: [u64; 2] = [2, 3];

/// A scrambled 2-D Halton sequence mapped to the wheel-limit square, restricted to U.
#[derive(Debug, Clone)]
pub struct Halton {
    /// Index of the next point of the sequence.
    index: u64,
    /// For each base, one permutation of the digits per digit position.
    perms: [Vec<Vec<u8>>; 2],
}

impl Halton {
    /// A sequence scrambled with `seed`.
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut perms_for = |base: u64| -> Vec<Vec<u8>> {
            // Enough digits to exhaust the 53-bit mantissa.
            let digits = (53.0 / (base as f64).log2()).ceil() as usize;
            (0..digits)
                .map(|_| {
                    let mut p: Vec<u8> = (0..base as u8).collect();
                    p.shuffle(&mut rng);
                    p
                })
                .collect()
        };
        let perms = [perms_for(BASES[0]), perms_for(BASES[1])];
        Self { index: 0, perms }
    }

    /// The `i`-th point of the scrambled sequence in the unit square.
    pub fn point(&self, i: u64) -> (f64, f64) {
        (
            scrambled_radical_inverse(i, BASES[0], &self.perms[0]),
            scrambled_radical_inverse(i, BASES[1], &self.perms[1]),
        )
    }
}

/// The textbook (unscrambled) radical inverse of `i` in `base`: the `i`-th coordinate of the
/// Halton sequence in that base (also the design of a closed-loop search's first points,
/// `drive_sim_compare::tune`]).
pub fn radical_inverse(i: u64, base: u64) -> f64 {
    let digits = (53.0 / (base as f64).log2()).ceil() as usize;
    let identity: Vec<Vec<u8>> = (0..digits).map(|_| (0..base as u8).collect()).collect();
    scrambled_radical_inverse(i, base, &identity)
}

/// Radical inverse of `i` in `base`, each digit passed through that position's permutation.
fn scrambled_radical_inverse(mut i: u64, base: u64, perms: &[Vec<u8>]) -> f64 {
    let inv = 1.0 / base as f64;
    let mut scale = inv;
    let mut x = 0.0;
    for p in perms {
        let d = (i % base) as usize;
        i /= base;
        x += p[d] as f64 * scale;
        scale *= inv;
    }
    x
}

impl Sampler for Halton {
    fn name(&self) -> &str {
        ENTRY.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        Ok(self.draw(ctx))
    }
}

impl Halton {
    /// The next command of this strategy: it cannot fail.
    fn draw(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        let w = ctx.space.wheel_bound_rad_s();
        loop {
            let (a, b) = self.point(self.index);
            self.index += 1;
            let c = WheelSpeeds::new(w * (2.0 * a - 1.0), w * (2.0 * b - 1.0));
            if ctx.space.contains_wheels(c) {
                return c;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unscrambled_digits_give_the_textbook_halton_points() {
        // Identity permutations: base 2 of 1, 2, 3 = 0.5, 0.25, 0.75; base 3 of 1, 2, 4 =
        // 1/3, 2/3, 1/9 + 1/3 = 4/9.
        let id2: Vec<Vec<u8>> = vec![vec![0, 1]; 53];
        let id3: Vec<Vec<u8>> = vec![vec![0, 1, 2]; 34];
        assert_eq!(scrambled_radical_inverse(1, 2, &id2), 0.5);
        assert_eq!(scrambled_radical_inverse(2, 2, &id2), 0.25);
        assert_eq!(scrambled_radical_inverse(3, 2, &id2), 0.75);
        assert!((scrambled_radical_inverse(1, 3, &id3) - 1.0 / 3.0).abs() < 1e-15);
        assert!((scrambled_radical_inverse(2, 3, &id3) - 2.0 / 3.0).abs() < 1e-15);
        assert!((scrambled_radical_inverse(4, 3, &id3) - 4.0 / 9.0).abs() < 1e-15);
    }

    #[test]
    fn scrambling_keeps_one_point_per_elementary_interval() {
        // The first 2^k points of a digit-scrambled base-2 sequence still fall one in each
        // interval [j/2^k, (j+1)/2^k): the property that makes the sequence low-discrepancy.
        let h = Halton::new(11);
        let k = 6;
        let mut seen = vec![0u32; 1 << k];
        for i in 0..(1u64 << k) {
            let (a, _) = h.point(i);
            seen[(a * (1 << k) as f64) as usize] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        let mut seen3 = [0u32; 27];
        for i in 0..27 {
            let (_, b) = h.point(i);
            seen3[(b * 27.0) as usize] += 1;
        }
        assert!(seen3.iter().all(|&c| c == 1), "{seen3:?}");
        assert_ne!(Halton::new(11).point(5), Halton::new(12).point(5));
    }
}
