//! Random numbers drawn per step, independent of the physics' random stream.
//!
//! Effects that vary from step to step (a loop that settles off its target, a ground whose
//! grip differs under each step) draw their numbers from a hash of the run's seed, the step and
//! a stream number rather than from the simulator's generator: the same seed gives the same
//! draws, the draws do not depend on how many physics steps a DRIVE step took, and switching
//! such an effect on moves no other random draw (sensor noise, the sampler's commands).

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Two 53-bit uniforms that depend only on `(seed, index, stream)`, the first in (0, 1] (its
/// logarithm is finite), the second in [0, 1).
fn uniforms(seed: u64, index: u64, stream: u8) -> (f64, f64) {
    let key = mix(seed ^ mix((index << 8) | u64::from(stream)));
    let a = mix(key);
    let b = mix(a);
    let u1 = ((a >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    (u1, u2)
}

/// A standard normal number that depends only on `(seed, step, stream)`: two uniforms of a
/// hash of the three, Box–Muller.
pub(crate) fn step_normal(seed: u64, step: u32, stream: u8) -> f64 {
    let (u1, u2) = uniforms(seed, u64::from(step), stream);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A standard exponential number (mean 1) that depends only on `(seed, index, stream)`: for
/// effects that draw per event rather than per step (an odometry update), `index` counting
/// the events.
pub(crate) fn event_exponential(seed: u64, index: u64, stream: u8) -> f64 {
    -uniforms(seed, index, stream).0.ln()
}

/// A uniform number in (0, 1] that depends only on `(seed, index, stream)`.
pub(crate) fn event_uniform(seed: u64, index: u64, stream: u8) -> f64 {
    uniforms(seed, index, stream).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The draws are standard normal and independent across steps and streams: mean 0, variance
    /// 1, no correlation between two streams, within what 20 000 draws allow (5 standard errors).
    #[test]
    fn step_normals_are_standard_and_independent() {
        let n = 20_000u32;
        let left: Vec<f64> = (0..n).map(|k| step_normal(7, k, 0)).collect();
        let right: Vec<f64> = (0..n).map(|k| step_normal(7, k, 1)).collect();
        let other_seed: Vec<f64> = (0..n).map(|k| step_normal(8, k, 0)).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let cov = |a: &[f64], b: &[f64]| {
            let (ma, mb) = (mean(a), mean(b));
            a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum::<f64>() / a.len() as f64
        };
        let se = 1.0 / (n as f64).sqrt();
        assert!(mean(&left).abs() < 5.0 * se, "mean {}", mean(&left));
        // Var of a sample variance of normals: 2/n.
        assert!((cov(&left, &left) - 1.0).abs() < 5.0 * (2.0f64).sqrt() * se);
        assert!(cov(&left, &right).abs() < 5.0 * se, "streams correlate");
        assert!(cov(&left, &other_seed).abs() < 5.0 * se, "seeds correlate");
        assert!(
            cov(&left[1..], &left[..n as usize - 1]).abs() < 5.0 * se,
            "steps correlate"
        );
        // Tails: about 4.55 % beyond 2.
        let beyond = left.iter().filter(|z| z.abs() > 2.0).count() as f64 / n as f64;
        assert!((beyond - 0.0455).abs() < 0.008, "share beyond 2: {beyond}");
    }
}
