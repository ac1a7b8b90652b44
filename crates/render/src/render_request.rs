//! One render request, built by the command line (`fiberlab render`) and Python
//! (`fiberlab.render`) alike: the raw overrides a user gives ([`RenderOptions`]: samples,
//! seed, depth, threads, integrator, fiber count, dual-scattering options) validated against
//! a scene file into one [`RenderRequest`] — raw flags → one validated request, as ripgrep's
//! `lowargs` → `hiargs`. Each front end formats the errors in its own words.

use crate::dual_scattering::{DualScatteringSettings, IntegratorError, integrator_named};
use crate::integrator::RenderSettings;
use crate::scene::Scene;
use crate::scene_file::SceneFile;
use thiserror::Error;

/// The overrides of a scene's settings a render is asked for; `None` (empty) keeps the
/// scene's.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderOptions {
    /// Samples per pixel (≥ 1).
    pub spp: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
    /// Maximum path depth.
    pub max_depth: Option<u32>,
    /// Worker threads (0: every core).
    pub threads: usize,
    /// `path` or `dual-scattering` (the scene's `[render] integrator` when `None`).
    pub integrator: Option<String>,
    /// `exact` or `grid` (the scene's `[render] fiber_count` when `None`).
    pub fiber_count: Option<String>,
    /// Dual-scattering options, `KEY=VALUE` each (`fiberlab render --dual`).
    pub dual: Vec<String>,
}

/// A validated render: the sampling settings (the scene's, overridden) and the integrator
/// asked for, which [`RenderRequest::settings_for`] builds for the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderRequest {
    /// Samples, seed, depth, threads (the integrator is set by
    /// [`RenderRequest::settings_for`]).
    pub settings: RenderSettings,
    /// The integrator's name.
    pub integrator: String,
    /// Dual scattering's constants and choices.
    pub dual: DualScatteringSettings,
}

/// Why the options do not make a render.
#[non_exhaustive]
#[derive(Debug, Error, PartialEq, Eq)]
pub enum RenderRequestError {
    /// `spp = 0`.
    #[error("spp must be at least 1")]
    ZeroSpp,
    /// A fiber count or dual-scattering option that does not parse (the message names it:
    /// `dual KEY: …`).
    #[error("{0}")]
    Dual(String),
}

impl RenderOptions {
    /// The request these options make of `file`: its `[render]` settings overridden.
    pub fn validate(&self, file: &SceneFile) -> Result<RenderRequest, RenderRequestError> {
        if self.spp == Some(0) {
            return Err(RenderRequestError::ZeroSpp);
        }
        let desc = file.render_settings();
        let integrator = self.integrator.clone().unwrap_or_else(|| desc.integrator.clone());
        let fiber_count = self.fiber_count.as_deref().unwrap_or(&desc.fiber_count);
        let dual = DualScatteringSettings::from_options(fiber_count, &self.dual).map_err(RenderRequestError::Dual)?;
        let scene = file.sampling();
        let settings = RenderSettings {
            spp: self.spp.unwrap_or(scene.spp),
            seed: self.seed.unwrap_or(scene.seed),
            max_depth: self.max_depth.unwrap_or(scene.max_depth),
            threads: self.threads,
            ..scene
        };
        Ok(RenderRequest { settings, integrator, dual })
    }
}

impl RenderRequest {
    /// The settings with the integrator built for `scene` (dual scattering computes its
    /// tables and, for a grid count, its density grid here).
    pub fn settings_for(&self, scene: &Scene) -> Result<RenderSettings, IntegratorError> {
        let integrator = integrator_named(scene, &self.integrator, self.dual)?;
        Ok(RenderSettings { integrator, ..self.settings.clone() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_override_the_scene_and_bad_ones_are_refused() {
        let file = SceneFile::default_scene();
        let scene = file.sampling();
        let kept = RenderOptions::default().validate(&file).unwrap();
        assert_eq!(
            (kept.settings.spp, kept.settings.seed, kept.settings.max_depth),
            (scene.spp, scene.seed, scene.max_depth)
        );
        assert_eq!(kept.integrator, file.render_settings().integrator);
        let options =
            RenderOptions { spp: Some(3), seed: Some(9), max_depth: Some(2), threads: 1, ..Default::default() };
        let r = options.validate(&file).unwrap();
        assert_eq!((r.settings.spp, r.settings.seed, r.settings.max_depth, r.settings.threads), (3, 9, 2, 1));
        let zero = RenderOptions { spp: Some(0), ..Default::default() };
        assert_eq!(zero.validate(&file), Err(RenderRequestError::ZeroSpp));
        let bad = RenderOptions { dual: vec!["d_f=x".into()], ..Default::default() };
        let e = bad.validate(&file).unwrap_err().to_string();
        assert!(e.starts_with("dual d_f"), "{e}");
    }
}
