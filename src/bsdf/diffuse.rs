//! Lambertian reflection, one-sided as Mitsuba's `diffuse`: `f = R/π` when `wo` and `wi` are both above the
//! surface (+z; `twosided` mirrors the rest), sampled with the cosine-weighted hemisphere (pdf `cos θi/π`),
//! so the sample weight is `R`.
//!
//! ```toml
//! bsdf = { type = "diffuse", reflectance = [0.8, 0.8, 0.8] }   # one number (gray) or RGB in [0, 1]; default 0.5
//! ```

use super::{Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;
use std::f32::consts::FRAC_1_PI;

/// Mitsuba's `diffuse`.
#[derive(Clone, Debug, PartialEq)]
pub struct Diffuse {
    pub reflectance: Vec3,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "diffuse",
    keys: &["reflectance"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    Ok(Bsdf::Diffuse(Diffuse { reflectance: p.reflectance_or("reflectance", Vec3::splat(0.5))? }))
}

impl Model for Diffuse {
    /// The reflectance on either side (Mitsuba's `SmoothDiffuse::eval_diffuse_reflectance`).
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.reflectance
    }
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> Vec3 {
        f(self.reflectance, wo, wi)
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        (f(self.reflectance, wo, wi), pdf_w(wo, wi))
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        pdf_w(wo, wi)
    }
    #[inline]
    fn sample(&self, wo: Vec3, _: f32, u_dir: Vec2, _: TransportMode) -> Option<BsdfSample> {
        sample(self.reflectance, wo, u_dir)
    }
    fn has_non_delta(&self) -> bool {
        self.reflectance.max_element() > 0.0
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("reflectance", ParamMut::Rgb(&mut self.reflectance));
    }
}

/// `R/π` above the surface, 0 elsewhere.
#[must_use]
pub(super) fn f(reflectance: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z > 0.0 && wi.z > 0.0 {
        reflectance * FRAC_1_PI
    } else {
        Vec3::ZERO
    }
}

/// `cos θi/π` above the surface.
#[must_use]
pub(super) fn pdf_w(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z > 0.0 && wi.z > 0.0 {
        wi.z * FRAC_1_PI
    } else {
        0.0
    }
}

/// A cosine-weighted direction above the surface (Malley's method); `None` for `wo` below.
#[must_use]
fn sample_wi(wo: Vec3, u_dir: Vec2) -> Option<Vec3> {
    if wo.z <= 0.0 {
        return None;
    }
    let wi = square_to_cosine_hemisphere(u_dir);
    (wi.z != 0.0).then_some(wi)
}

/// The whole sample: a cosine-weighted `wi` ([`sample_wi`]), its pdf from [`pdf_w`] (the one rule, so MIS
/// weights from either side agree bit for bit), and the weight `f·cos θi / pdf_w = R` written as its exact
/// value instead of through the quotient.
#[must_use]
pub(super) fn sample(reflectance: Vec3, wo: Vec3, u_dir: Vec2) -> Option<BsdfSample> {
    let wi = sample_wi(wo, u_dir)?;
    let pdf_w = pdf_w(wo, wi);
    (pdf_w > 0.0).then_some(BsdfSample { wi_local: wi, weight: reflectance, pdf_w, delta: false, pass_through: false })
}
