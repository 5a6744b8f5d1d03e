//! Mitsuba's `twosided`: the inner, reflecting BSDF on both sides of the surface. A configuration below the
//! surface (`wo.z < 0`) is mirrored to +z through the tangent plane, evaluated or sampled by the inner BSDF,
//! and a sampled `wi` mirrored back.
//!
//! ```toml
//! bsdf = { type = "twosided", bsdf = { type = "diffuse" } }   # a name or an inline table
//! ```
//!
//! The inner BSDF must not transmit (a dielectric), as in Mitsuba.

use super::{flip_z, Bsdf, BsdfSample, Model, Plugin, TransportMode, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `twosided` around its inner BSDF.
#[derive(Clone, Debug, PartialEq)]
pub struct TwoSided(pub Box<Bsdf>);

pub(super) const PLUGIN: Plugin = Plugin {
    name: "twosided",
    keys: &["bsdf"],
    nested: &["bsdf"],
    build,
};

fn build(mut p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let Some(inner) = p.take_nested("bsdf") else {
        return Err(PropError::new("", "twosided needs `bsdf` (the bsdf used on both sides)"));
    };
    if inner.transmits() {
        return Err(PropError::new("bsdf", "twosided cannot hold a transmitting bsdf (dielectric), as in Mitsuba"));
    }
    Ok(Bsdf::TwoSided(TwoSided(Box::new(inner))))
}

impl Model for TwoSided {
    /// The inner BSDF's, seen from the front (Mitsuba's `TwoSidedBRDF::eval_diffuse_reflectance`).
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.0.diffuse_reflectance(if wo.z < 0.0 { flip_z(wo) } else { wo })
    }
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        if wo.z < 0.0 {
            self.0.f(flip_z(wo), flip_z(wi), mode)
        } else {
            self.0.f(wo, wi, mode)
        }
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        if wo.z < 0.0 {
            self.0.f_pdf(flip_z(wo), flip_z(wi), mode)
        } else {
            self.0.f_pdf(wo, wi, mode)
        }
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z < 0.0 {
            self.0.pdf_w(flip_z(wo), flip_z(wi))
        } else {
            self.0.pdf_w(wo, wi)
        }
    }
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z < 0.0 {
            self.0.sample(flip_z(wo), u_lobe, u_dir, mode).map(|s| BsdfSample { wi_local: flip_z(s.wi_local), ..s })
        } else {
            self.0.sample(wo, u_lobe, u_dir, mode)
        }
    }
    fn chooses_lobe(&self) -> bool {
        self.0.chooses_lobe()
    }
    fn has_delta(&self) -> bool {
        self.0.has_delta()
    }
    fn has_non_delta(&self) -> bool {
        self.0.has_non_delta()
    }
    fn anisotropic(&self) -> bool {
        self.0.anisotropic()
    }
    fn transmits(&self) -> bool {
        self.0.transmits()
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.nested("bsdf", &mut self.0);
    }
}
