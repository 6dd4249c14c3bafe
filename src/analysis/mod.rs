//! The slip and unpredictability pipeline.
