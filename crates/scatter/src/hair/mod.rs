//! The hair core: the pieces of fiber optics that the hair models (`marschner_2003`,
//! `deon_2011`, `chiang_2016`, and the fur of `yan_2017`) share, one concept per file, so that a model file holds only
//! its model and the fur, dual-scattering, wood and cloth models can reuse the pieces.
//!
//! | file | concept | papers |
//! |---|---|---|
//! | [`longitudinal`] | d'Eon's normalized `M_p` and Marschner's Gaussian lobes | d'Eon 2011, Marschner 2003 |
//! | [`ellipse`] | elliptical cross-sections: offsets, boundary points, exact smooth paths | Khungurn & Marschner 2017 |
//! | [`normal_plane`] | Bravais' `η′`, the exit azimuth `Φ(p, h)`, its roots and the TRT caustic | Marschner 2003 |
//! | [`attenuation`] | Fresnel, chord lengths (optionally through a concentric core), `A_p` | Marschner 2003, Chiang 2016, Yan 2015 |
//! | [`absorption`] | where σ_a comes from: given, melanin, or a desired colour | d'Eon 2011, Chiang 2016 |
//! | [`tilt`] | the cuticle tilt of each lobe, as a rotation of the fixed direction (Chiang's and Marschner's ratios) | Chiang 2016, d'Eon 2013, Marschner 2003 |
//! | [`rough_interface`] | directional albedos of a rough (GGX) dielectric interface | Walter 2007, Heitz 2018 |
//! | [`roughness`] | Chiang's maps β → `v_p`, `s`, and d'Eon's azimuthal σ | Chiang 2016 |
//! | [`backward_form`] | `f_s = g/cosθ_i`, light-side albedo, measured non-reciprocity | Chiang 2016 |
//! | [`tube`] | a wall around a concentric core of another index: the kinds of wall pass, their turns and Fresnel weights | (ours; Bravais 1856 as in Marschner 2003) |
//! | [`parameters`] | the parameter table entries the hair models share | |
//! | [`fiber`] | the fiber parameters Chiang and d'Eon share, with presets and checks | |
//! | [`pole_taper`] | a sampled inclination's density made to vanish on the fiber axis (finite pdf per steradian) | |
//!
//! The mathematics, in our words and with the peers' discrepancies, is in
//! `docs/theory/hair.md`, `docs/theory/conventions.md`, `docs/theory/radiometry.md` and
//! `docs/theory/peer-discrepancies.md`. Papers: Marschner, Jensen, Cammarano, Worley &
//! Hanrahan 2003, *Light scattering from human hair fibers*; d'Eon, Francois, Hill, Letteri &
//! Aubry 2011, *An energy-conserving hair reflectance model*; Chiang, Bitterli, Tappan &
//! Burley 2016, *A practical and controllable hair and fur model for production path
//! tracing*; Yan, Tseng, Jensen & Ramamoorthi 2015, *Physically-accurate fur reflectance*.
//! Equations are cited by the quantity they define (and Marschner's Table 1); equation
//! numbers are not quoted because they have not been checked against the papers.
//!
//! Conventions (those of `fiberlab_math::frame`): θ is the inclination from the normal plane,
//! positive toward the tip; φ the azimuth; `h ∈ [−1, 1]` the offset across the fiber,
//! `γ = asin h`; radius 1, so σ_a is per unit radius; every angle in radians.
//!
//! The core imports nothing from a model; models import from it and never from each other.

pub mod absorption;
pub mod attenuation;
pub mod backward_form;
pub mod ellipse;
pub mod fiber;
pub mod longitudinal;
pub mod medulla;
pub mod normal_plane;
pub mod parameters;
pub mod pole_taper;
pub mod rough_interface;
pub mod roughness;
pub mod tilt;
pub mod tube;
