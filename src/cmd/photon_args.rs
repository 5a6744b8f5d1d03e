//! The photon-map options `render` and `converge` share: one definition of the flags, one check, one
//! rule for how they override the scene file ([`RenderSettings::from_scene`]).

use anyhow::bail;

use crate::photon::PhotonBudget;
use crate::render::RenderSettings;

/// `--photons | --caustic-photons`, `--knn`, `--max-radius`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct PhotonArgs {
    /// Photons emitted per photon pass (N of the method; every pass of a progressive render emits N).
    #[arg(long, conflicts_with = "caustic_photons")]
    pub photons: Option<u64>,
    /// Instead of --photons: emit until this many caustic photons are stored (N = all emitted).
    #[arg(long)]
    pub caustic_photons: Option<u64>,
    /// k of the k-nearest-neighbour density estimate.
    #[arg(long)]
    pub knn: Option<u32>,
    /// Maximum search radius of the density estimate (scene units).
    #[arg(long)]
    pub max_radius: Option<f32>,
}

impl PhotonArgs {
    /// Rejects what no scene can make valid: zero counts (rejected, not clamped), more photons per pass
    /// than the kd-tree indexes, a search radius that is not positive and finite.
    pub fn validate(&self) -> anyhow::Result<()> {
        for (flag, value) in [("--photons", self.photons), ("--caustic-photons", self.caustic_photons), ("--knn", self.knn.map(u64::from))] {
            match value {
                Some(0) => bail!("{flag} must be at least 1, got 0"),
                Some(n) if n > u64::from(u32::MAX) => bail!("{flag}: at most {} per pass, got {n}", u32::MAX),
                _ => {}
            }
        }
        if let Some(r) = self.max_radius {
            if !(r.is_finite() && r > 0.0) {
                bail!("--max-radius must be a positive finite number, got {r}");
            }
        }
        Ok(())
    }

    /// Command line over scene file: `--photons` / `--caustic-photons` replace either scene key.
    /// Call [`PhotonArgs::validate`] first.
    pub fn apply(&self, settings: &mut RenderSettings) {
        match (self.photons, self.caustic_photons) {
            (Some(n), _) => settings.photons = PhotonBudget::Emitted(n),
            (None, Some(m)) => settings.photons = PhotonBudget::Stored(m),
            (None, None) => {}
        }
        if let Some(k) = self.knn {
            settings.knn = k;
        }
        if let Some(r) = self.max_radius {
            settings.max_radius = r;
        }
    }
}
