//! Mitsuba's `mask`: the nested BSDF where the surface is opaque, and nothing where it is not. With opacity
//! `α` (a number in [0, 1] or a texture, Mitsuba's default 0.5): `f = α·f_nested`, and sampling takes the
//! nested BSDF with probability `α` (`u_lobe < α`, rescaled to `u_lobe/α` inside it) or passes straight
//! through (`wi = −wo`, weight 1, discrete probability `1 − α`), as src/bsdfs/mask.cpp does. A non-delta
//! sample of the nested BSDF is completed with the mask's own `f` and `pdf_w = α·pdf_nested` (the same
//! weight as the nested BSDF's); a delta one keeps its weight and has probability `α·q`. The pass-through is
//! `null`'s lobe (`null::pass_through`): a bounce, blocking shadow rays, a delta surface for photons.
//!
//! ```toml
//! bsdf = { type = "mask", opacity = { type = "bitmap", filename = "leaf-alpha.png", raw = true }, bsdf = "leaf" }
//! ```

use super::null::pass_through;
use super::{non_delta_sample, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode, ONE_MINUS_EPSILON};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `mask` around its nested BSDF.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    pub opacity: f32,
    pub bsdf: Box<Bsdf>,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "mask",
    keys: &["opacity", "bsdf"],
    nested: &["bsdf"],
    build,
};

fn build(mut p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let opacity = p.in_range_or("opacity", 0.5, 0.0, 1.0, "the opacity")?;
    let Some(bsdf) = p.take_nested("bsdf") else {
        return Err(PropError::new("", "mask needs `bsdf` (the bsdf where the surface is opaque)"));
    };
    Ok(Bsdf::Mask(Mask { opacity, bsdf: Box::new(bsdf) }))
}

impl Mask {
    /// The opacity as used: in [0, 1] (the loader and the texture checks keep it there; NaN → 0).
    #[inline]
    fn alpha(&self) -> f32 {
        if self.opacity > 0.0 {
            self.opacity.min(1.0)
        } else {
            0.0
        }
    }
}

impl Model for Mask {
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let a = self.alpha();
        if a > 0.0 {
            a * self.bsdf.f(wo, wi, mode)
        } else {
            Vec3::ZERO
        }
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        let a = self.alpha();
        if a > 0.0 {
            let (f, pdf) = self.bsdf.f_pdf(wo, wi, mode);
            (a * f, a * pdf)
        } else {
            (Vec3::ZERO, 0.0)
        }
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        let a = self.alpha();
        if a > 0.0 {
            a * self.bsdf.pdf_w(wo, wi)
        } else {
            0.0
        }
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let a = self.alpha();
        if u_lobe >= a {
            return pass_through(wo, 1.0 - a);
        }
        let s = self.bsdf.sample(wo, (u_lobe / a).min(ONE_MINUS_EPSILON), u_dir, mode)?;
        if s.delta {
            Some(BsdfSample { pdf_w: a * s.pdf_w, ..s })
        } else {
            non_delta_sample(self, wo, s.wi_local, mode)
        }
    }
    fn chooses_lobe(&self) -> bool {
        true
    }
    fn has_delta(&self) -> bool {
        self.alpha() < 1.0 || self.bsdf.has_delta()
    }
    fn has_non_delta(&self) -> bool {
        self.alpha() > 0.0 && self.bsdf.has_non_delta()
    }
    fn anisotropic(&self) -> bool {
        self.bsdf.anisotropic()
    }
    fn transmits(&self) -> bool {
        self.alpha() < 1.0 || self.bsdf.transmits()
    }
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.alpha() * self.bsdf.diffuse_reflectance(wo)
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("opacity", ParamMut::Float(&mut self.opacity));
        v.nested("bsdf", &mut self.bsdf);
    }
}
