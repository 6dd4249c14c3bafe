//! Both runs' turn memory side by side (a diagnostic, not part of the verdict): how much further
//! a loaded wheel falls short after a turn the other way than after one the same way
//! ([`drive_sim_analysis::turn_memory`]).
//!
//! Why beside the verdict: it is a property of the order of the steps, which the verdict's
//! medians, hulls and maps ignore (they would be the same for the steps in any order), yet it
//! sets how far each loaded step gets. The measured Warthog asphalt run's difference is +0.14
//! of the command; 9 of the 10 runs of its tuned twin without an integral in the speed loop
//! remember less (README, "A speed loop that remembers").

use drive_sim_analysis::turn_memory::TurnMemory;
use serde::{Deserialize, Serialize};

/// Smallest difference between the two runs' memories that counts, in shortfall (a fraction of
/// the command): 0.05 is 0.5 rad/s on a 10 rad/s wheel, twice the measured Warthog runs' largest
/// within-step scatter (0.25 rad/s) there, and under half the asphalt run's memory (+0.14).
pub const TURN_MEMORY_TOLERANCE: f64 = 0.05;

/// Both runs' turn memory and whether they differ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TurnMemoryDiff {
    /// The real run's.
    pub real: TurnMemory,
    /// The simulated run's.
    pub sim: TurnMemory,
    /// The two intervals of `reversed_minus_same` miss each other and the estimates are at
    /// least [`TURN_MEMORY_TOLERANCE`] apart.
    pub differs: bool,
}

impl TurnMemoryDiff {
    /// The two runs' memories compared.
    pub fn new(real: TurnMemory, sim: TurnMemory) -> Self {
        let differs = match (
            real.ci95,
            sim.ci95,
            real.reversed_minus_same,
            sim.reversed_minus_same,
        ) {
            (Some(r), Some(s), Some(a), Some(b)) => r.misses(&s) && (a - b).abs() >= TURN_MEMORY_TOLERANCE,
            _ => false,
        };
        Self { real, sim, differs }
    }

    /// One line for the verdict's text.
    pub fn line(&self) -> String {
        let est = |m: &TurnMemory| match (m.reversed_minus_same, m.ci95) {
            (Some(v), Some(i)) => format!(
                "{v:+.2} [{:+.2}, {:+.2}] ({} reversed / {} same-way turns)",
                i.lower, i.upper, m.reversed.steps, m.same.steps
            ),
            (Some(v), None) => format!("{v:+.2}"),
            _ => format!(
                "- ({} reversed / {} same-way turns: too few)",
                m.reversed.steps, m.same.steps
            ),
        };
        let tail = match (self.differs, self.real.reversed_minus_same > self.sim.reversed_minus_same) {
            (true, true) => ": the simulated speed loop forgets the previous turn (`droop_recovery_s` with `speed_droop_rad_s_per_knm` gives the memory)",
            (true, false) => ": the simulated speed loop remembers more than the real one",
            (false, _) => ": alike (intervals overlap or within 0.05 of the command)",
        };
        format!(
            "turn memory (shortfall after a reversed turn minus after a same-way one, a diagnostic): real {}, sim {}{tail}",
            est(&self.real),
            est(&self.sim)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_analysis::bootstrap::Interval;

    fn memory(v: f64, lo: f64, hi: f64) -> TurnMemory {
        TurnMemory {
            reversed_minus_same: Some(v),
            ci95: Some(Interval {
                lower: lo,
                upper: hi,
                level: 0.95,
            }),
            ..Default::default()
        }
    }

    #[test]
    fn a_loop_without_memory_differs_and_overlap_is_no_difference() {
        let d = TurnMemoryDiff::new(memory(0.12, 0.06, 0.18), memory(0.01, -0.02, 0.03));
        assert!(d.differs);
        assert!(d.line().contains("forgets the previous turn"), "{}", d.line());
        let same = TurnMemoryDiff::new(memory(0.12, 0.06, 0.18), memory(0.10, 0.05, 0.16));
        assert!(!same.differs && same.line().contains("alike"));
        // Apart, but by less than the tolerance: alike.
        let close = TurnMemoryDiff::new(memory(0.04, 0.035, 0.045), memory(0.0, -0.005, 0.005));
        assert!(!close.differs);
        let more = TurnMemoryDiff::new(memory(0.01, -0.02, 0.03), memory(0.12, 0.06, 0.18));
        assert!(more.differs && more.line().contains("remembers more"));
        let none = TurnMemoryDiff::new(TurnMemory::default(), memory(0.12, 0.06, 0.18));
        assert!(!none.differs && none.line().contains("too few"));
    }
}
