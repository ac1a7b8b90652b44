//! The validation harness (placeholder until the harness lands).
