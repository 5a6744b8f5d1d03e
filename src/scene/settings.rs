//! Render settings read from the `[integrator]` table: path depth, samples, seed, and the caustic
//! estimator (method.md §1). Defaults follow Mitsuba's `path` integrator where it has one.
//!
//! ```toml
//! [integrator]
//! max_depth = -1            # -1 = unlimited; otherwise the longest path in segments (Mitsuba's meaning)
//! rr_depth = 5              # Russian roulette starts at this depth (≥ 1)
//! samples_per_pixel = 64    # ≥ 1 (default 16)
//! seed = 0
//! [integrator.caustics]     # optional
//! estimator = "mis"         # pt (default) | pm | mis
//! photons = 200000          # photons emitted per pass (> 0); absent: the integrator's default
//! caustic_photons = 70000   # or: emit until this many caustic photons are stored (N = all emitted)
//! knn = 50                  # k of the k-NN density estimate (≥ 1)
//! max_radius = 0.1          # optional search-radius cap, scene units (> 0)
//! ```

/// How caustic paths (L S⁺ x at a non-delta eye vertex x) are estimated (method.md §1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
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
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Pt => "pt",
            Estimator::Pm => "pm",
            Estimator::Mis => "mis",
        }
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
            knn: 50,
            max_radius: None,
        }
    }
}

/// The `[integrator]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Longest path in segments (Mitsuba's `max_depth`: 1 = only emitters seen directly); -1 = unlimited.
    pub max_depth: i32,
    /// Depth at which Russian roulette starts.
    pub rr_depth: u32,
    pub samples_per_pixel: u32,
    pub seed: u64,
    pub caustics: CausticsSettings,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            max_depth: -1,
            rr_depth: 5,
            samples_per_pixel: 16,
            seed: 0,
            caustics: CausticsSettings::default(),
        }
    }
}
