//! Which quadrants a run's commands were drawn in, and how likely that mix is.
//!
//! The paper's statistics are medians over a run's steps, and a skid-steering robot's slips
//! change sign with the command's quadrant (forward or backward, turning left or right): a run
//! that drew more right turns than left ones has the right turns' median yaw slip, whatever
//! the robot. DRIVE draws uniformly in a U that is symmetric under negation and under swapping
//! the sides, so each half (left or right turns, forward or backward) is a fair coin per step.
//! This stage counts the analysed steps per quadrant and gives the exact two-sided binomial
//! p-value of each balance: a small one says the run's medians carry its draw's luck (the
//! twin's runs compared with such a run draw in its quadrants,
//! `drive_sim_protocol::samplers::matched`). It also counts the steps whose wheels turn
//! opposite ways (pivots and turns in place), a skid-steer's least predictable commands: on the
//! measured asphalt runs all but one of them have a ρ above their run's median
//! (`scripts/command_mix.py`), so a run's median ρ moves with how many it drew. Their expected
//! share depends on U's shape (27.5 % of the Warthog's), so no p-value is given for it.

use drive_sim_model::kinematics::WheelSpeeds;
use serde::{Deserialize, Serialize};

/// Analysed steps per quadrant of their commands, and the balances' p-values.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CommandMix {
    /// Forward and turning left (`vx >= 0`, `wz >= 0`).
    pub forward_left: usize,
    /// Forward and turning right.
    pub forward_right: usize,
    /// Backward and turning left.
    pub backward_left: usize,
    /// Backward and turning right.
    pub backward_right: usize,
    /// Exact two-sided binomial p-value of the left turns' count among the steps, under a fair
    /// coin (uniform draws in a symmetric U); 1 without steps.
    pub left_turns_p: f64,
    /// The same for the forward commands' count.
    pub forward_p: f64,
    /// Steps whose wheels turn opposite ways (`left · right < 0`).
    #[serde(default)]
    pub counter_rotating: usize,
}

/// A balance whose fair-coin p is below this is a lopsided draw.
pub const LOPSIDED_P: f64 = 0.05;

impl CommandMix {
    /// True when the left turns' or the forward commands' count is unlikely under a fair coin
    /// (p below [`LOPSIDED_P`]): the run's medians carry its draw.
    pub fn is_lopsided(&self) -> bool {
        self.left_turns_p.min(self.forward_p) < LOPSIDED_P
    }
    /// Steps counted.
    pub fn steps(&self) -> usize {
        self.forward_left + self.forward_right + self.backward_left + self.backward_right
    }
    /// Steps turning left.
    pub fn left_turns(&self) -> usize {
        self.forward_left + self.backward_left
    }
    /// Steps driving forward.
    pub fn forward(&self) -> usize {
        self.forward_left + self.forward_right
    }
}

impl std::fmt::Display for CommandMix {
    /// One line: the counts, and the balances' p-values (what a small one means).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "commands drawn: {} left turns of {} (fair-coin p {:.4}), {} forward (p {:.4}); \
             by quadrant forward-left {}, forward-right {}, backward-left {}, backward-right {}; \
             {} with the wheels turning opposite ways",
            self.left_turns(),
            self.steps(),
            self.left_turns_p,
            self.forward(),
            self.forward_p,
            self.forward_left,
            self.forward_right,
            self.backward_left,
            self.backward_right,
            self.counter_rotating
        )?;
        if self.is_lopsided() {
            write!(f, " (a lopsided draw: this run's medians carry it)")?;
        }
        Ok(())
    }
}

/// The mix of `commands` (one per analysed step).
pub fn command_mix(commands: impl IntoIterator<Item = WheelSpeeds>) -> CommandMix {
    let mut m = CommandMix::default();
    for c in commands {
        m.counter_rotating += usize::from(c.left_rad_s * c.right_rad_s < 0.0);
        let q = c.quadrant();
        match (q.forward, q.left) {
            (true, true) => m.forward_left += 1,
            (true, false) => m.forward_right += 1,
            (false, true) => m.backward_left += 1,
            (false, false) => m.backward_right += 1,
        }
    }
    m.left_turns_p = fair_coin_p(m.left_turns(), m.steps());
    m.forward_p = fair_coin_p(m.forward(), m.steps());
    m
}

/// Exact two-sided p-value of `k` heads in `n` tosses of a fair coin: the probability of a
/// count at least as far from `n / 2`. 1 when `n` is 0.
pub fn fair_coin_p(k: usize, n: usize) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let far = (2.0 * k as f64 - n as f64).abs();
    // ln C(n, i) - n ln 2, by the running product C(n, i + 1) = C(n, i) (n - i) / (i + 1).
    let mut ln_pmf = -(n as f64) * std::f64::consts::LN_2;
    let mut p = 0.0;
    for i in 0..=n {
        // Half a unit of slack against rounding of the distances, which are integers.
        if (2.0 * i as f64 - n as f64).abs() >= far - 0.5 {
            p += ln_pmf.exp();
        }
        ln_pmf += ((n - i) as f64).ln() - ((i + 1) as f64).ln();
    }
    p.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_coins_p_value_matches_its_known_values() {
        // 35 of 100: sum of C(100, i) / 2^100 for i <= 35 and i >= 65.
        assert!(
            (fair_coin_p(35, 100) - 0.003_518).abs() < 5e-6,
            "{}",
            fair_coin_p(35, 100)
        );
        assert!((fair_coin_p(65, 100) - fair_coin_p(35, 100)).abs() < 1e-15);
        assert!((fair_coin_p(50, 100) - 1.0).abs() < 1e-12);
        // 0 of 10 or 10 of 10: 2 / 1024.
        assert!((fair_coin_p(0, 10) - 2.0 / 1024.0).abs() < 1e-15);
        // 2 of 5: every count is at least half a toss from 2.5.
        assert!((fair_coin_p(2, 5) - 1.0).abs() < 1e-12);
        assert_eq!(fair_coin_p(0, 0), 1.0);
    }

    #[test]
    fn commands_are_counted_by_quadrant() {
        let m = command_mix([
            WheelSpeeds::new(1.0, 2.0),
            WheelSpeeds::new(2.0, 1.0),
            WheelSpeeds::new(-1.0, -2.0),
            WheelSpeeds::new(-2.0, -1.0),
            WheelSpeeds::new(-3.0, 3.0),
        ]);
        assert_eq!(
            (m.forward_left, m.forward_right, m.backward_left, m.backward_right),
            (2, 1, 1, 1)
        );
        assert_eq!((m.steps(), m.left_turns(), m.forward()), (5, 3, 3));
        assert!((m.left_turns_p - 1.0).abs() < 1e-12);
        // Only the turn in place counter-rotates.
        assert_eq!(m.counter_rotating, 1);
    }
}
