//! Measured-CSV reader (format: shared/data/measured/README.md).
