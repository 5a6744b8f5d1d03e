//! Render settings read from the `[integrator]` table: path depth, samples, seed, and the caustic
//! estimator (method.md §1). Defaults follow Mitsuba's `path` integrator where it has one.
//!
//! This module is the one place where each render setting's default ([`defaults`]) and validity
//! ([`check`]) are written: the scene file (`scene::build`), the command line (`cli`) and every
//! subcommand use them, each naming its own key or flag in the error.
//!
//! ```toml
//! [integrator]
//! max_depth = -1            # -1 = unlimited; otherwise the longest path in segments (Mitsuba's meaning)
//! rr_depth = 5              # Russian roulette starts at this depth (≥ 1)
//! samples_per_pixel = 64    # ≥ 1 (default 16)
//! seed = 0
//! hide_emitters = false     # true: camera rays see no emitter (Mitsuba's `hide_emitters`)
//! [integrator.caustics]     # optional
//! estimator = "mis"         # pt (default) | pm | mis
//! photons = 200000          # photons emitted per pass (> 0); absent: the integrator's default
//! caustic_photons = 70000   # or: emit until this many caustic photons are stored (N = all emitted)
//! knn = 50                  # k of the k-NN density estimate (≥ 1)
//! max_radius = 0.1          # optional search-radius cap, scene units (> 0)
//! ```
//! and `integrator.aovs = "name:type,…"`, the AOVs written beside the image (module `scene::aov`).

/// The default of every render setting.
pub mod defaults {
    /// Longest path in segments; -1 = unlimited (Mitsuba's `path` integrator).
    pub const MAX_DEPTH: i32 = -1;
    /// Depth at which Russian roulette starts (Mitsuba's `rr_depth`).
    pub const RR_DEPTH: u32 = 5;
    /// Samples per pixel of a render without a time limit.
    pub const SAMPLES_PER_PIXEL: u32 = 16;
    pub const SEED: u64 = 0;
    /// Camera rays see the emitters (Mitsuba's `hide_emitters = false`).
    pub const HIDE_EMITTERS: bool = false;
    /// k of the k-NN density estimate.
    pub const KNN: u32 = 50;
    /// Samples per pixel of one pass of a time-limited render.
    pub const PASS_SPP_TIME_LIMITED: u32 = 4;
    /// A round's intended length in seconds (`render::round`: a pass's eye samples over the whole frame,
    /// after its first round of one sample per pixel). Short enough that Ctrl-C or SIGTERM loses little
    /// and a checkpoint can come often; long enough that the rounds' cost (a merge of every tile, the wait
    /// for a round's last tile) stays within a percent: doubling rounds (1, 1, 2, 4 … spp, as pbrt-v4's
    /// waves) cost 5 % of the wall time of teapot-glossy's 8 spp with `pt`.
    pub const ROUND_SECONDS: f64 = 10.0;

    /// Photons emitted per pass when neither `photons` nor `caustic_photons` is given: one per pixel of
    /// the crop window, at least 100,000.
    #[must_use]
    pub fn photons(pixels: u64) -> u64 {
        pixels.max(100_000)
    }

    /// Maximum k-NN search radius when none is given (method.md §3.2): `2·√(k/π)` pixel footprints where
    /// caustics land, `footprint` the width one pixel covers at the far side of the caustic-making (delta)
    /// objects' bounding sphere (`crate::camera::Camera::pixel_footprint`), and never more than 5% of the
    /// scene's bounding radius (the rule before, and the whole rule without a footprint: no delta object).
    #[must_use]
    pub fn max_radius(footprint: Option<f32>, knn: u32, bounding_radius: f32) -> f32 {
        let scene_cap = 0.05 * bounding_radius;
        let camera_cap = footprint.filter(|f| f.is_finite() && *f > 0.0).map(|f| 2.0 * (knn.max(1) as f32 / std::f32::consts::PI).sqrt() * f);
        camera_cap.map_or(scene_cap, |c| c.min(scene_cap)).max(1e-6)
    }
}

/// The validity of every render setting. Each check returns the reason without the key (e.g. "must be
/// ≥ 1, got 0"); the caller prefixes the scene key or the flag.
pub mod check {
    /// Why a value is rejected.
    #[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
    #[error("{0}")]
    pub struct Invalid(pub String);

    fn at_least_one(v: u64) -> Result<(), Invalid> {
        if v == 0 {
            return Err(Invalid("must be ≥ 1, got 0".into()));
        }
        Ok(())
    }

    /// Samples per pixel (`samples_per_pixel`, `--spp`): ≥ 1.
    pub fn spp(v: u32) -> Result<(), Invalid> {
        at_least_one(v.into())
    }

    /// Samples per pixel of one pass (`--pass-spp`): ≥ 1.
    pub fn pass_spp(v: u32) -> Result<(), Invalid> {
        at_least_one(v.into())
    }

    /// Worker threads (`--threads`): ≥ 1.
    pub fn threads(v: usize) -> Result<(), Invalid> {
        at_least_one(v as u64)
    }

    /// Film width or height in pixels: ≥ 1.
    pub fn resolution(v: u32) -> Result<(), Invalid> {
        at_least_one(v.into())
    }

    /// k of the k-NN estimate: ≥ 1.
    pub fn knn(v: u32) -> Result<(), Invalid> {
        at_least_one(v.into())
    }

    /// A photon count per pass (`photons`, `caustic_photons`): ≥ 1 and at most what the kd-tree indexes.
    pub fn photons(v: u64) -> Result<(), Invalid> {
        at_least_one(v)?;
        if v > u64::from(u32::MAX) {
            return Err(Invalid(format!("at most {} per pass, got {v}", u32::MAX)));
        }
        Ok(())
    }

    /// A positive finite number (`max_radius`, `--time-limit`, `--time-budget`).
    pub fn non_negative(v: f64) -> Result<(), Invalid> {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Invalid(format!("must be a finite number ≥ 0, got {v}")));
        }
        Ok(())
    }

    pub fn positive(v: f64) -> Result<(), Invalid> {
        if !(v.is_finite() && v > 0.0) {
            return Err(Invalid(format!("must be a finite number > 0, got {v}")));
        }
        Ok(())
    }

    /// The k-NN search radius cap (scene units): positive and finite.
    pub fn max_radius(v: f32) -> Result<(), Invalid> {
        positive(v.into())
    }

    /// Longest path in segments: -1 (unlimited) or ≥ 0.
    pub fn max_depth(v: i32) -> Result<(), Invalid> {
        if v < -1 {
            return Err(Invalid(format!("must be -1 (unlimited) or ≥ 0, got {v}")));
        }
        Ok(())
    }

    /// Depth at which Russian roulette starts: ≥ 1.
    pub fn rr_depth(v: u32) -> Result<(), Invalid> {
        at_least_one(v.into())
    }

    /// The AOVs to write (`integrator.aovs`, Mitsuba's `aovs`, `--aov`): `name:type` pairs or types
    /// (`crate::scene::aov::Aovs::parse`, which says what is wrong).
    pub fn aovs(v: &str) -> Result<crate::scene::aov::Aovs, Invalid> {
        crate::scene::aov::Aovs::parse(v)
    }

    /// Exposure of a PNG in stops: finite.
    pub fn exposure(v: f32) -> Result<(), Invalid> {
        if !v.is_finite() {
            return Err(Invalid(format!("must be a finite number of stops, got {v}")));
        }
        Ok(())
    }
}

/// How caustic paths (L S⁺ x at a non-delta eye vertex x) are estimated (method.md §1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// Plain path tracing, no photon pass.
    #[default]
    Pt,
    /// Caustics only from the photon map ("general density estimation").
    Pm,
    /// Photon map and BSDF sampling combined by the power heuristic (the paper's method).
    Mis,
}

impl Estimator {
    /// Every estimator, in the order of the documentation.
    pub const ALL: [Estimator; 3] = [Estimator::Pt, Estimator::Pm, Estimator::Mis];

    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Pt => "pt",
            Estimator::Pm => "pm",
            Estimator::Mis => "mis",
        }
    }
}

impl std::str::FromStr for Estimator {
    type Err = check::Invalid;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Estimator::ALL.into_iter().find(|e| e.name() == s).ok_or_else(|| check::Invalid(format!("unknown estimator {s:?} (pt, pm or mis)")))
    }
}

/// The `[integrator.caustics]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticsSettings {
    pub estimator: Estimator,
    /// Photons emitted per pass; `None` = the integrator's default.
    pub photons: Option<u64>,
    /// Instead of a fixed emission count: emit until at least this many caustic photons are stored.
    pub caustic_photons: Option<u64>,
    /// k of the k-NN density estimate.
    pub knn: u32,
    /// Cap on the k-NN search radius (scene units); `None` = unbounded.
    pub max_radius: Option<f32>,
}

impl Default for CausticsSettings {
    fn default() -> Self {
        Self {
            estimator: Estimator::Pt,
            photons: None,
            caustic_photons: None,
            knn: defaults::KNN,
            max_radius: None,
        }
    }
}

/// The `[integrator]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Longest path in segments (Mitsuba's `max_depth`: 1 = only emitters seen directly); -1 = unlimited.
    pub max_depth: i32,
    /// Depth at which Russian roulette starts.
    pub rr_depth: u32,
    pub samples_per_pixel: u32,
    pub seed: u64,
    /// Mitsuba's `hide_emitters`: a camera path whose ray passes through area emitters and that shows
    /// nothing until it scatters (the rule: `integrator::path`, `PathTracer::hide_unscattered`).
    pub hide_emitters: bool,
    pub caustics: CausticsSettings,
    /// The AOVs written beside the image (`integrator.aovs`, Mitsuba's `aov` integrator: [`super::aov`]);
    /// none by default.
    pub aovs: super::aov::Aovs,
}

impl IntegratorSettings {
    /// `max_depth` as a number of path segments, `u32::MAX` for unlimited (-1): the bound the path tracer
    /// and the photon pass compare path lengths with.
    #[must_use]
    pub fn max_segments(&self) -> u32 {
        u32::try_from(self.max_depth).unwrap_or(u32::MAX)
    }
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            max_depth: defaults::MAX_DEPTH,
            rr_depth: defaults::RR_DEPTH,
            samples_per_pixel: defaults::SAMPLES_PER_PIXEL,
            seed: defaults::SEED,
            hide_emitters: defaults::HIDE_EMITTERS,
            caustics: CausticsSettings::default(),
            aovs: super::aov::Aovs::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::defaults;

    #[test]
    fn the_default_search_radius_cap_is_the_smaller_of_the_camera_and_the_scene_rules() {
        // 2·√(k/π) footprints: 8.0 of them at k = 50.
        let r = defaults::max_radius(Some(0.01), 50, 100.0);
        assert!((r - 0.01 * 2.0 * (50.0f32 / std::f32::consts::PI).sqrt()).abs() < 1e-7, "{r}");
        assert!((r / 0.01 - 7.98).abs() < 0.01);
        // More neighbours, a wider cap; never beyond 5% of the scene's bounding radius.
        assert!(defaults::max_radius(Some(0.01), 200, 100.0) > r);
        assert_eq!(defaults::max_radius(Some(1.0), 50, 10.0), 0.5);
        // No footprint (no delta object) or a useless one: the scene's rule alone.
        for f in [None, Some(0.0), Some(f32::NAN), Some(f32::INFINITY)] {
            assert_eq!(defaults::max_radius(f, 50, 10.0), 0.5);
        }
        assert_eq!(defaults::max_radius(None, 50, 0.0), 1e-6);
    }
}
