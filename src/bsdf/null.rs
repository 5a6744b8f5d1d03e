//! Mitsuba's `null`: an invisible surface. Every ray passes straight through (`wi = −wo`, a delta lobe of
//! weight 1 and probability 1); nothing is reflected. As in Mitsuba's `path` integrator, a pass-through counts
//! as a bounce and the surface blocks shadow rays (light arrives behind it only along sampled paths); for
//! the photon map it is a delta surface like a pane of `thindielectric` (src/bsdfs/null.cpp).
//!
//! ```toml
//! bsdf = { type = "null" }
//! ```

use super::{Bsdf, BsdfSample, Model, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `null`.
#[derive(Clone, Debug, PartialEq)]
pub struct Null;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "null",
    keys: &[],
    nested: &[],
    build,
};

fn build(_: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    Ok(Bsdf::Null(Null))
}

/// The pass-through lobe with discrete probability `pdf_w` (1 for `null`, `1 − opacity` for a `mask`).
#[must_use]
pub(super) fn pass_through(wo: Vec3, pdf_w: f32) -> Option<BsdfSample> {
    (pdf_w > 0.0).then_some(BsdfSample { wi_local: -wo, weight: Vec3::ONE, pdf_w, delta: true, pass_through: true })
}

impl Model for Null {
    fn sample(&self, wo: Vec3, _: f32, _: Vec2, _: TransportMode) -> Option<BsdfSample> {
        pass_through(wo, 1.0)
    }
    fn has_delta(&self) -> bool {
        true
    }
    fn has_non_delta(&self) -> bool {
        false
    }
    fn transmits(&self) -> bool {
        true
    }
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        Vec3::ZERO
    }
}
