//! The photon-map options `render` and `converge` share: one definition of the flags (checked by
//! [`crate::scene::settings::check`] through [`super::args`]), one rule for how they override the scene
//! file ([`RenderSettings::from_scene`]).

use super::args;
use crate::photon::PhotonBudget;
use crate::render::RenderSettings;
use crate::scene::Scene;

/// `--photons | --caustic-photons`, `--knn`, `--max-radius`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct PhotonArgs {
    /// Photons emitted per photon pass (N of the method; every pass of a progressive render emits N)
    /// [default: the scene's, else one per pixel, at least 100,000].
    #[arg(long, conflicts_with = "caustic_photons", value_parser = args::photons)]
    pub photons: Option<u64>,
    /// Instead of --photons: emit until this many caustic photons are stored (N = all emitted).
    #[arg(long, value_parser = args::photons)]
    pub caustic_photons: Option<u64>,
    /// k of the k-nearest-neighbour density estimate [default: the scene's, else 50].
    #[arg(long, value_parser = args::knn)]
    pub knn: Option<u32>,
    /// Maximum search radius of the density estimate, scene units [default: the scene's, else 2·√(k/π)
    /// pixel footprints beyond the mirrors and glass, at most 5% of the scene's bounding radius].
    #[arg(long, value_parser = args::max_radius)]
    pub max_radius: Option<f32>,
}

impl PhotonArgs {
    /// Command line over scene file: `--photons` / `--caustic-photons` replace either scene key; a `--knn`
    /// over a default search-radius cap (neither the scene nor `--max-radius` gives one) makes that
    /// default the new k's.
    pub fn apply(&self, settings: &mut RenderSettings, scene: &Scene) {
        match (self.photons, self.caustic_photons) {
            (Some(n), _) => settings.photons = PhotonBudget::Emitted(n),
            (None, Some(m)) => settings.photons = PhotonBudget::Stored(m),
            (None, None) => {}
        }
        if let Some(k) = self.knn {
            settings.knn = k;
            if scene.integrator.caustics.max_radius.is_none() {
                settings.max_radius = RenderSettings::default_max_radius(scene, k);
            }
        }
        if let Some(r) = self.max_radius {
            settings.max_radius = r;
        }
    }
}
