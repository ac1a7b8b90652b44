//! Parameter-table entries shared by the hair models (`chiang`, `deon`), named, so that a
//! model lists them by name and never by position in another model's table.
//!
//! The entries below are the one statement of these parameters: the tables users read are
//! generated from the models' registry entries that list them (`fiberlab models --model chiang`,
//! the book's pages `docs/book/src/models/chiang.md` and `deon.md`).

use crate::params::{ParamKind, ParamSpec, Range};

/// Valid index of refraction η.
pub const ETA_RANGE: Range = Range::open_closed(1.0, 4.0);
/// Valid roughness β_m, β_n: [0.01, 1]. Below 0.01 the lobes are deltas in all but name
/// (β_m = 0.01 is a TT lobe of variance 1.3·10⁻⁵, a quarter of a degree wide; β_n = 0.01 an
/// azimuthal scale of 0.1°), and toward 0 Chiang's maps underflow: `v_0 = (0.726β_m + …)²`
/// is 0 below β_m ≈ 1e−162 and the logistic's `1/s` overflows below β_n ≈ 1e−308, giving NaN
/// and ∞. The range is what the models evaluate and sample exactly (tested at both ends,
/// `tests/finite_everywhere.rs`), down to the smallest lobe variance the longitudinal tests
/// cover (10⁻⁵).
pub const BETA_RANGE: Range = Range::closed(0.01, 1.0);
/// Valid cuticle tilt α, in degrees.
pub const ALPHA_RANGE: Range = Range::closed(-20.0, 20.0);
/// Valid absorption coefficient σ_a per channel, per unit radius.
pub const SIGMA_A_RANGE: Range = Range::closed(0.0, f64::INFINITY);
/// Valid melanin concentrations.
pub const MELANIN_RANGE: Range = Range::closed(0.0, 100.0);
/// Valid desired colour per channel.
pub const COLOR_RANGE: Range = Range::open_closed(0.0, 1.0);

/// `eta`: index of refraction.
pub const ETA: ParamSpec =
    ParamSpec { key: "eta", kind: ParamKind::Number(ETA_RANGE), unit: "", default: "1.55", doc: "index of refraction" };
/// `beta_m`: longitudinal roughness.
pub const BETA_M: ParamSpec = ParamSpec {
    key: "beta_m",
    kind: ParamKind::Number(BETA_RANGE),
    unit: "",
    default: "0.3",
    doc: "longitudinal roughness",
};
/// `beta_n`: azimuthal roughness.
pub const BETA_N: ParamSpec = ParamSpec {
    key: "beta_n",
    kind: ParamKind::Number(BETA_RANGE),
    unit: "",
    default: "0.3",
    doc: "azimuthal roughness",
};
/// `alpha`: cuticle scale tilt, degrees at the edge.
pub const ALPHA: ParamSpec = ParamSpec {
    key: "alpha",
    kind: ParamKind::Number(ALPHA_RANGE),
    unit: "degrees",
    default: "2",
    doc: "cuticle scale tilt; > 0 moves the R lobe toward the root",
};
/// `sigma_a`: absorption coefficient.
pub const SIGMA_A: ParamSpec = ParamSpec {
    key: "sigma_a",
    kind: ParamKind::Color(SIGMA_A_RANGE),
    unit: "1/radius",
    default: "",
    doc: "absorption coefficient (exclusive with melanin and color)",
};
/// `eumelanin`: eumelanin concentration.
pub const EUMELANIN: ParamSpec = ParamSpec {
    key: "eumelanin",
    kind: ParamKind::Number(MELANIN_RANGE),
    unit: "",
    default: "",
    doc: "eumelanin concentration (1.3 when no absorption key is given)",
};
/// `pheomelanin`: pheomelanin concentration.
pub const PHEOMELANIN: ParamSpec = ParamSpec {
    key: "pheomelanin",
    kind: ParamKind::Number(MELANIN_RANGE),
    unit: "",
    default: "",
    doc: "pheomelanin concentration",
};
/// `color`: desired multiple-scattering colour.
pub const COLOR: ParamSpec = ParamSpec {
    key: "color",
    kind: ParamKind::Color(COLOR_RANGE),
    unit: "",
    default: "",
    doc: "desired multiple-scattering colour; σ_a by Chiang's inversion (depends on beta_n)",
};
