//! A Python object as a DRIVE sampler, and the per-step table it reads: the completed steps'
//! commands and what the simulated sensors measured over their steady windows, as a logged
//! run shows them (encoders, IMU, the pose's body velocity), built one row per completed step
//! as the frames arrive.

use crate::errors::SignalWatch;
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::measurement::{held_command, Frame, FrameSink, Phase, Sample};
use drive_sim_model::Error;
use drive_sim_protocol::sampler::{Sampler, SamplingContext};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use std::cell::RefCell;
use std::rc::Rc;

/// The columns of a [`StepRow`], in its order (the DataFrames' column names).
pub(crate) const STEP_COLUMNS: [&str; 11] = [
    "step",
    "attempts",
    "stamp_s",
    "cmd_left_rad_s",
    "cmd_right_rad_s",
    "enc_left_rad_s",
    "enc_right_rad_s",
    "imu_wz_rad_s",
    "vx_m_s",
    "vy_m_s",
    "wz_rad_s",
];

/// One completed step: its command and the mean measurements over its steady windows (the
/// windows after the transient one, of the attempt that completed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StepRow {
    step: u32,
    /// Attempts it took (1 when never interrupted).
    attempts: u32,
    /// Log time of its last sample, s.
    stamp_s: f64,
    cmd: WheelSpeeds,
    /// Encoder wheel speeds, rad/s.
    enc: WheelSpeeds,
    /// IMU yaw rate, rad/s.
    imu_wz_rad_s: f64,
    /// Body velocity from the pose (mean over the steady windows of each window's line fit).
    vx_m_s: f64,
    vy_m_s: f64,
    wz_rad_s: f64,
}

/// A row as the Python tuple of [`STEP_COLUMNS`].
pub(crate) type RowTuple = (u32, u32, f64, f64, f64, f64, f64, f64, f64, f64, f64);

impl StepRow {
    /// The row as a tuple in [`STEP_COLUMNS`] order.
    pub(crate) fn tuple(&self) -> RowTuple {
        (
            self.step,
            self.attempts,
            self.stamp_s,
            self.cmd.left_rad_s,
            self.cmd.right_rad_s,
            self.enc.left_rad_s,
            self.enc.right_rad_s,
            self.imu_wz_rad_s,
            self.vx_m_s,
            self.vy_m_s,
            self.wz_rad_s,
        )
    }
}

/// The completed steps so far, shared by the collector (which appends) and the sampler
/// (which hands the new ones to Python).
pub(crate) type SharedRows = Rc<RefCell<Vec<StepRow>>>;

/// A frame sink that turns each completed step's frames into a [`StepRow`], and polls the
/// interpreter's signal check.
pub(crate) struct Collector<'a> {
    /// The attempt being collected: (step, attempt).
    current: Option<(u32, u32)>,
    /// Its steady windows' samples, window `w` at index `w - 1`.
    steady: Vec<Vec<Sample>>,
    rows: SharedRows,
    watch: &'a mut SignalWatch,
}

impl<'a> Collector<'a> {
    /// A collector appending to `rows`, polling `watch`.
    pub(crate) fn new(rows: SharedRows, watch: &'a mut SignalWatch) -> Self {
        Self {
            current: None,
            steady: Vec::new(),
            rows,
            watch,
        }
    }

    fn row(&self) -> Option<StepRow> {
        let (step, attempt) = self.current?;
        let all: Vec<&Sample> = self.steady.iter().flatten().collect();
        let last = all.last()?;
        let n = all.len() as f64;
        let mean = |f: &dyn Fn(&Sample) -> f64| all.iter().map(|s| f(s)).sum::<f64>() / n;
        let windows: Vec<_> = self
            .steady
            .iter()
            .filter(|w| w.len() >= 2)
            .map(|w| drive_sim_analysis::velocity::window_mean_body_velocity(w))
            .collect();
        let nw = windows.len() as f64;
        let wmean = |f: &dyn Fn(&drive_sim_model::kinematics::BodyVelocity) -> f64| {
            windows.iter().map(f).sum::<f64>() / nw
        };
        Some(StepRow {
            step,
            attempts: attempt + 1,
            stamp_s: last.stamp_s,
            cmd: held_command(all.iter().copied()).map_or(last.m.cmd, |h| h.cmd),
            enc: WheelSpeeds::new(mean(&|s| s.m.enc.left_rad_s), mean(&|s| s.m.enc.right_rad_s)),
            imu_wz_rad_s: mean(&|s| s.m.imu.wz_rad_s),
            vx_m_s: wmean(&|v| v.vx_m_s),
            vy_m_s: wmean(&|v| v.vy_m_s),
            wz_rad_s: wmean(&|v| v.wz_rad_s),
        })
    }
}

impl FrameSink for Collector<'_> {
    fn frame(&mut self, frame: &Frame) -> drive_sim_model::Result<()> {
        self.watch.poll();
        if let Phase::Step {
            step,
            attempt,
            window,
            k,
            t_in_step_s,
        } = frame.phase
        {
            if self.current != Some((step, attempt)) {
                self.current = Some((step, attempt));
                self.steady.iter_mut().for_each(Vec::clear);
            }
            if window > 0 {
                let w = window as usize - 1;
                if self.steady.len() <= w {
                    self.steady.resize_with(w + 1, Vec::new);
                }
                self.steady[w].push(Sample {
                    step,
                    window,
                    k,
                    t_in_step_s,
                    stamp_s: frame.stamp_s,
                    m: frame.m,
                });
            }
        }
        Ok(())
    }

    fn step_done(&mut self, _completed: u32) {
        if let Some(r) = self.row() {
            self.rows.borrow_mut().push(r);
        }
    }
}

/// A Python sampler behind the `drive_sim` adapter: a callable `adapter(step, new_rows)`
/// that appends the rows of the steps completed since its last call to the history it keeps,
/// asks the user's `next_command(history)` and returns `(left_rad_s, right_rad_s)`.
pub(crate) struct PySampler {
    adapter: Py<PyAny>,
    label: String,
    rows: SharedRows,
    /// Rows already handed to Python.
    sent: usize,
    /// The exception the sampler raised, raised again (as the cause) when the run has stopped.
    pub(crate) raised: Option<PyErr>,
}

impl PySampler {
    /// The sampler calling `adapter`, named `label`, reading `rows`.
    pub(crate) fn new(adapter: Py<PyAny>, label: String, rows: SharedRows) -> Self {
        Self {
            adapter,
            label,
            rows,
            sent: 0,
            raised: None,
        }
    }
}

impl Sampler for PySampler {
    fn name(&self) -> &str {
        &self.label
    }

    fn next(&mut self, ctx: &SamplingContext<'_>) -> drive_sim_model::Result<WheelSpeeds> {
        let new: Vec<RowTuple> = self.rows.borrow()[self.sent..]
            .iter()
            .map(StepRow::tuple)
            .collect();
        let drawn = Python::with_gil(|py| {
            self.adapter
                .call1(py, (ctx.step, new))
                .and_then(|c| c.extract::<(f64, f64)>(py))
                .map_err(|e| {
                    let interrupt = e.is_instance_of::<PyKeyboardInterrupt>(py);
                    (interrupt, e.to_string(), e)
                })
        });
        match drawn {
            Ok((l, r)) => {
                self.sent = self.rows.borrow().len();
                Ok(WheelSpeeds::new(l, r))
            }
            Err((interrupt, message, e)) => {
                self.raised = Some(e);
                Err(match interrupt {
                    true => Error::Interrupted {
                        step: ctx.history.len() as u32,
                        time_s: f64::NAN,
                    },
                    false => Error::Sampler {
                        sampler: self.label.clone(),
                        step: ctx.step,
                        message,
                    },
                })
            }
        }
    }
}
