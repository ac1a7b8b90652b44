//! Every tolerance the harness uses, defined and explained once.

/// Relative error allowed between a quadrature albedo and a closed form. The midpoint rule
/// on the default 256×512 (θ, φ) grid integrates smooth lobes (KK up to p = 100, Gaussians of
/// width ≥ 2°) to better than 1e−3; 2e−3 leaves room for lobe edges.
pub const ALBEDO_REL: f64 = 2e-3;

/// Absolute error allowed in `∫ pdf dω = 1` (midpoint quadrature, fine grid).
pub const PDF_INTEGRAL_ABS: f64 = 1e-3;

/// Relative disagreement allowed between `sample().pdf` and `pdf()`, and between
/// `sample().weight` and `eval·cosθ_i/pdf`: both are the same formula evaluated twice, so
/// only rounding separates them.
pub const SAMPLE_CONSISTENCY_REL: f64 = 1e-6;

/// Relative reciprocity defect allowed for models that claim reciprocity.
pub const RECIPROCITY_REL: f64 = 1e-9;

/// Relative slack on the energy bound ρ ≤ 1 (quadrature error).
pub const ENERGY_BOUND_SLACK: f64 = 2e-3;

/// Family-wise significance of the χ² goodness-of-fit tests (Bonferroni-corrected over the
/// number of χ² cases of a model), as in Mitsuba's `chi2.py`.
pub const CHI2_SIGNIFICANCE: f64 = 0.01;

/// Cells whose expected count is below this are pooled into one cell before χ².
pub const CHI2_MIN_EXPECTED: f64 = 5.0;

/// Monte Carlo estimates must agree with quadrature within this many standard errors.
pub const MC_SIGMAS: f64 = 5.0;

/// Relative error allowed in a camera-side white furnace computed by quadrature (models
/// that conserve energy exactly on the camera side, e.g. Chiang with σ_a = 0): midpoint
/// quadrature of lobes with β ≥ 0.3 on the default grid.
pub const FURNACE_REL: f64 = 3e-3;
