//! Linear blend `(1 − w)·bsdf_0 + w·bsdf_1` (Mitsuba's `blendbsdf`).
//!
//! Sampling picks `bsdf_1` with probability `w` and `bsdf_0` with `1 − w` (the blend weights), re-using
//! the rescaled `u_lobe` inside the chosen component. Unbiased and MIS-consistent:
//! - a **non-delta** sample from either component is completed with the *mixture*:
//!   `pdf_w = (1 − w)·pdf_0 + w·pdf_1` (the density of the whole sampler producing `wi` through any
//!   non-delta lobe, Veach 1997 §9.2.2 "one-sample model") and `weight = f_mix·|cos θi|/pdf_w`, where
//!   `f_mix = (1 − w)·f_0 + w·f_1`. These are exactly `Bsdf::f`/`Bsdf::pdf_w` of the blend, so the pdf
//!   reported at sample time equals `pdf_w()` and `E[weight] = ∫ f_mix |cos|`;
//! - a **delta** sample from component `c` (chosen with probability `p_c`, its delta lobe with `q`) has
//!   `pdf_w = p_c·q` and weight `(w_c/p_c)·(T/q)` = the component's weight, since `p_c = w_c`.
//!   Nested blends compose by the same rules.

//!
//! ```toml
//! bsdf = { type = "blendbsdf", weight = 0.3, bsdf_0 = "white", bsdf_1 = { type = "roughconductor" } }
//! ```
//!
//! `weight` in [0, 1] (default 0.5); `bsdf_0`, `bsdf_1`: names of `[bsdf.<name>]` tables or inline tables.

use super::{non_delta_sample, Bsdf, BsdfSample, Model, Plugin, TransportMode, ONE_MINUS_EPSILON, ParamMut, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `blendbsdf`: (1 − weight)·bsdf_0 + weight·bsdf_1.
#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    pub weight: f32,
    pub bsdf_0: Box<Bsdf>,
    pub bsdf_1: Box<Bsdf>,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "blendbsdf",
    keys: &["weight", "bsdf_0", "bsdf_1"],
    nested: &["bsdf_0", "bsdf_1"],
    build,
};

fn build(mut p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let weight = p.in_range_or("weight", 0.5, 0.0, 1.0, "the blend weight")?;
    let (Some(bsdf_0), Some(bsdf_1)) = (p.take_nested("bsdf_0"), p.take_nested("bsdf_1")) else {
        let missing = if p.has("bsdf_0") { "bsdf_1" } else { "bsdf_0" };
        return Err(PropError::new("", format!("blendbsdf needs `bsdf_0` and `bsdf_1`; `{missing}` is missing")));
    };
    Ok(Bsdf::Blend(Blend { weight, bsdf_0: Box::new(bsdf_0), bsdf_1: Box::new(bsdf_1) }))
}

impl Model for Blend {
    /// The blend of its components' (Mitsuba's `BlendBSDF::eval_diffuse_reflectance`).
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.bsdf_0.diffuse_reflectance(wo) * (1.0 - self.weight) + self.bsdf_1.diffuse_reflectance(wo) * self.weight
    }
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        f(self.weight, &self.bsdf_0, &self.bsdf_1, wo, wi, mode)
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        f_pdf(self.weight, &self.bsdf_0, &self.bsdf_1, wo, wi, mode)
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        pdf_w(self.weight, &self.bsdf_0, &self.bsdf_1, wo, wi)
    }
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        sample(self, wo, u_lobe, u_dir, mode)
    }
    fn chooses_lobe(&self) -> bool {
        true
    }
    fn has_delta(&self) -> bool {
        (self.weight < 1.0 && self.bsdf_0.has_delta()) || (self.weight > 0.0 && self.bsdf_1.has_delta())
    }
    fn has_non_delta(&self) -> bool {
        (self.weight < 1.0 && self.bsdf_0.has_non_delta()) || (self.weight > 0.0 && self.bsdf_1.has_non_delta())
    }
    fn anisotropic(&self) -> bool {
        self.bsdf_0.anisotropic() || self.bsdf_1.anisotropic()
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("weight", ParamMut::Float(&mut self.weight));
        v.nested("bsdf_0", &mut self.bsdf_0);
        v.nested("bsdf_1", &mut self.bsdf_1);
    }
    fn transmits(&self) -> bool {
        self.bsdf_0.transmits() || self.bsdf_1.transmits()
    }
}

/// The blend weight as used: clamped to [0, 1] (the scene loader rejects other values; NaN → 0).
#[inline]
pub(super) fn clamp_weight(weight: f32) -> f32 {
    debug_assert!((0.0..=1.0).contains(&weight), "blend weight {weight} outside [0, 1]");
    if weight > 0.0 {
        weight.min(1.0)
    } else {
        0.0
    }
}

#[must_use]
pub(super) fn f(weight: f32, bsdf_0: &Bsdf, bsdf_1: &Bsdf, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
    let w = clamp_weight(weight);
    let mut sum = Vec3::ZERO;
    if w < 1.0 {
        sum += (1.0 - w) * bsdf_0.f(wo, wi, mode);
    }
    if w > 0.0 {
        sum += w * bsdf_1.f(wo, wi, mode);
    }
    sum
}

/// `(f, pdf_w)` of the mixture in one pass over the components (same sums as [`f`] and [`pdf_w`]).
#[must_use]
pub(super) fn f_pdf(weight: f32, bsdf_0: &Bsdf, bsdf_1: &Bsdf, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
    let w = clamp_weight(weight);
    let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
    if w < 1.0 {
        let (f0, p0) = bsdf_0.f_pdf(wo, wi, mode);
        f += (1.0 - w) * f0;
        pdf += (1.0 - w) * p0;
    }
    if w > 0.0 {
        let (f1, p1) = bsdf_1.f_pdf(wo, wi, mode);
        f += w * f1;
        pdf += w * p1;
    }
    (f, pdf)
}

#[must_use]
pub(super) fn pdf_w(weight: f32, bsdf_0: &Bsdf, bsdf_1: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
    let w = clamp_weight(weight);
    let mut sum = 0.0;
    if w < 1.0 {
        sum += (1.0 - w) * bsdf_0.pdf_w(wo, wi);
    }
    if w > 0.0 {
        sum += w * bsdf_1.pdf_w(wo, wi);
    }
    sum
}

#[must_use]
fn sample(
    blend: &Blend,
    wo: Vec3,
    u_lobe: f32,
    u_dir: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let Blend { weight, bsdf_0, bsdf_1 } = blend;
    let w = clamp_weight(*weight);
    let p0 = 1.0 - w;
    // Select with probability (1 − w | w) and rescale u_lobe to [0, 1) for the component.
    let (component, p_sel, u_rest) = if u_lobe < p0 {
        (bsdf_0, p0, u_lobe / p0)
    } else {
        (bsdf_1, w, (u_lobe - p0) / w)
    };
    let s = component.sample(wo, u_rest.min(ONE_MINUS_EPSILON), u_dir, mode)?;
    if s.delta {
        // weight: (w_c / p_c)·s.weight with p_c = w_c.
        Some(BsdfSample {
            pdf_w: p_sel * s.pdf_w,
            ..s
        })
    } else {
        non_delta_sample(blend, wo, s.wi_local, mode)
    }
}
