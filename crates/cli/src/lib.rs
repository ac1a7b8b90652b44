//! The fiberlab command line (placeholder).
