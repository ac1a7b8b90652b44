//! A family of generated hair scenes on which the dual-scattering integrator is compared with
//! the path tracer (the example `dual_family` and the test `dual_scattering_family` of
//! this crate): every combination of six two- or three-valued axes, so that a constant fitted
//! on one kind of scene is tested on the others.
//!
//! | axis | values |
//! |---|---|
//! | [`Density`] | dense (a thick layer, no skin seen through it) or sparse (skin between the strands) |
//! | [`Skin`] | the head sphere Lambertian skin-coloured, or black (no light off the skin) |
//! | [`LightSide`] | the sun in front (behind the camera, above) or behind the head (rim light) |
//! | [`Sky`] | a white or a blue sky (the environment) |
//! | [`HairColour`] | blond, brown, black (Chiang 2016 with melanin concentrations) |
//! | [`Floor`] | none, or a grey Lambertian floor below the hair (light off it reaches the hair from below, through the hair) |
//!
//! The hair is straight (the generator's `straight` style, no clumps) on a unit sphere; the
//! camera frames the head from the front-left. [`FamilySize`] scales the image and the strand
//! count; a smaller size keeps the hair layer's optical thickness by thickening the strands
//! in the same proportion (the number of fibers a ray crosses goes as strands × diameter).

use std::fmt::Write as _;

/// Hair density.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Density {
    /// The full strand count: the layer hides the skin.
    Dense,
    /// A sixth of it: the skin shows between the strands.
    Sparse,
}

/// The head sphere's material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skin {
    /// Lambertian, albedo (0.62, 0.45, 0.36).
    Visible,
    /// Black: no light comes off the head.
    Dark,
}

/// Where the sun is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSide {
    /// Above and behind the camera.
    Front,
    /// Above and behind the head: the hair is rim-lit and light crosses it toward the camera.
    Back,
}

/// The environment's colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sky {
    /// Radiance (0.3, 0.3, 0.3).
    White,
    /// Radiance (0.10, 0.14, 0.25), dim and blue.
    Blue,
}

/// The hair's pigments (Chiang 2016 with d'Eon 2011's melanin, β_m = β_n = 0.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairColour {
    /// Eumelanin 0.12, pheomelanin 0.08.
    Blond,
    /// Eumelanin 0.8, pheomelanin 0.4.
    Brown,
    /// Eumelanin 3.0.
    Black,
}

impl HairColour {
    /// `(eumelanin, pheomelanin)`.
    #[must_use]
    pub fn melanin(self) -> (f64, f64) {
        match self {
            Self::Blond => (0.12, 0.08),
            Self::Brown => (0.8, 0.4),
            Self::Black => (3.0, 0.0),
        }
    }
}

/// What lies below the head.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Floor {
    /// Nothing: the sky all round.
    None,
    /// A Lambertian floor of albedo 0.35 at y = −1.8, under the hair's ends (y ≈ −1.2…−1.6).
    Grey,
}

/// One scene of the family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FamilyScene {
    /// Hair density.
    pub density: Density,
    /// Head material.
    pub skin: Skin,
    /// Sun position.
    pub light: LightSide,
    /// Sky colour.
    pub sky: Sky,
    /// Hair colour.
    pub hair: HairColour,
    /// Below the head.
    pub floor: Floor,
}

/// Image and hair size of the generated scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FamilySize {
    /// Image width and height, pixels.
    pub px: u32,
    /// Strands of the dense hair (the sparse hair has a sixth of them).
    pub dense_strands: usize,
    /// Segments per strand.
    pub segments: usize,
}

impl FamilySize {
    /// The benchmark's size: 160², 24,000 strands of 16 segments (diameter 0.002).
    pub const BENCH: Self = Self { px: 160, dense_strands: 24_000, segments: 16 };
    /// The test's size: 48², 3,000 strands of 8 segments (diameter 0.016, the same layer).
    pub const TEST: Self = Self { px: 48, dense_strands: 3_000, segments: 8 };
}

/// `test` or `bench`, as the examples' `--size` takes it.
impl std::str::FromStr for FamilySize {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "test" => Ok(Self::TEST),
            "bench" => Ok(Self::BENCH),
            other => Err(format!("a family size is test or bench, not {other}")),
        }
    }
}

/// Root diameter of the strands at [`FamilySize::BENCH`]'s strand count.
const BENCH_DIAMETER: f64 = 0.002;

impl FamilyScene {
    /// Every combination of the axes (96 scenes), in a fixed order: the 48 without a floor
    /// first.
    #[must_use]
    pub fn all() -> Vec<Self> {
        let mut v = Vec::with_capacity(96);
        for floor in [Floor::None, Floor::Grey] {
            for density in [Density::Dense, Density::Sparse] {
                for skin in [Skin::Visible, Skin::Dark] {
                    for light in [LightSide::Front, LightSide::Back] {
                        for sky in [Sky::White, Sky::Blue] {
                            for hair in [HairColour::Blond, HairColour::Brown, HairColour::Black] {
                                v.push(Self { density, skin, light, sky, hair, floor });
                            }
                        }
                    }
                }
            }
        }
        v
    }

    /// A name made of the axes' values, e.g. `sparse-skin-front-blue-blond`, with `-floor` at
    /// the end where there is one.
    #[must_use]
    pub fn name(&self) -> String {
        let d = match self.density {
            Density::Dense => "dense",
            Density::Sparse => "sparse",
        };
        let s = match self.skin {
            Skin::Visible => "skin",
            Skin::Dark => "dark",
        };
        let l = match self.light {
            LightSide::Front => "front",
            LightSide::Back => "back",
        };
        let k = match self.sky {
            Sky::White => "white",
            Sky::Blue => "blue",
        };
        let h = match self.hair {
            HairColour::Blond => "blond",
            HairColour::Brown => "brown",
            HairColour::Black => "black",
        };
        let f = match self.floor {
            Floor::None => "",
            Floor::Grey => "-floor",
        };
        format!("{d}-{s}-{l}-{k}-{h}{f}")
    }

    /// The scene as TOML (`fiberlab render`'s format), at `size`, rendered at `spp` samples.
    #[must_use]
    pub fn scene_text(&self, size: &FamilySize, spp: u32) -> String {
        let (eu, ph) = self.hair.melanin();
        let strands = match self.density {
            Density::Dense => size.dense_strands,
            Density::Sparse => size.dense_strands.div_ceil(6),
        };
        let diameter = BENCH_DIAMETER * FamilySize::BENCH.dense_strands as f64 / size.dense_strands as f64;
        let skin = match self.skin {
            Skin::Visible => "[0.62, 0.45, 0.36]",
            Skin::Dark => "[0.0, 0.0, 0.0]",
        };
        let sun = match self.light {
            LightSide::Front => "[0.9, 1.1, -1.0]",
            LightSide::Back => "[-0.7, 0.9, 1.2]",
        };
        let sky = match self.sky {
            Sky::White => "[0.3, 0.3, 0.3]",
            Sky::Blue => "[0.10, 0.14, 0.25]",
        };
        let mut t = String::new();
        let _ = write!(
            t,
            "# fiberlab_render::scene_family: {name}\n\
             [camera]\neye = [3.0, 1.2, -3.6]\ntarget = [0.0, 0.05, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = 36.0\n\
             width = {px}\nheight = {px}\n\n\
             [render]\nspp = {spp}\nmax_depth = 64\nseed = 0\n\n\
             [materials.hair]\nmodel = \"chiang\"\n\
             params = {{ eumelanin = {eu}, pheomelanin = {ph}, beta_m = 0.3, beta_n = 0.3 }}\n\n\
             [materials.skin]\nlambert = {skin}\n\n\
             [[hair]]\nmaterial = \"hair\"\n\
             generator = {{ strands = {strands}, segments = {seg}, style = \"straight\", length = 1.2, \
             root_diameter = {diameter}, clumps = 0, gravity = 2.0, seed = 7 }}\n\n\
             [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"skin\"\n\n\
             {floor}[[light]]\ntype = \"environment\"\nradiance = {sky}\n\n\
             [[light]]\ntype = \"sun\"\ndirection = {sun}\nangular_radius_deg = 1.0\nirradiance = [4.0, 3.8, 3.5]\n",
            name = self.name(),
            floor = match self.floor {
                Floor::None => "",
                Floor::Grey =>
                    "[materials.ground]\nlambert = [0.35, 0.35, 0.35]\n\n[[mesh]]\nfloor = -1.8\nmaterial = \"ground\"\n\n",
            },
            px = size.px,
            seg = size.segments,
        );
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene_file::SceneFile;
    use std::path::Path;

    #[test]
    fn every_member_parses_and_names_are_unique() {
        let all = FamilyScene::all();
        assert_eq!(all.len(), 96);
        let mut names: Vec<String> = all.iter().map(FamilyScene::name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), 96);
        for m in &all {
            let f = SceneFile::parse(&m.scene_text(&FamilySize::TEST, 4), Path::new("family.toml"))
                .unwrap_or_else(|e| panic!("{}: {e}", m.name()));
            assert_eq!(f.image_size(), (48, 48));
        }
    }
}
