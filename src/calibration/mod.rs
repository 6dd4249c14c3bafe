//! Closing the loop with measured data: replay, error metrics, fitting, residual analysis.

pub mod fit;
pub mod metrics;
pub mod model;
pub mod replay;
pub mod surrogate;
