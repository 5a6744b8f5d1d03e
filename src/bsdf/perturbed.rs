//! What Mitsuba 3's `normalmap` and `bumpmap` share (src/bsdfs/normalmap.cpp, bumpmap.cpp,
//! normalmap_helpers.h): a nested BSDF evaluated and sampled in a shading frame perturbed at the hit.
//!
//! The material layer sets the perturbation at each hit ([`Perturbation`], through the parameter
//! [`ParamMut::Frame`](super::ParamMut): `Scene::bsdf_at` computes it from the texture and the hit's
//! geometry by the rule of the type, [`FrameRule`]); this file applies it as Mitsuba does:
//!
//! - the perturbed normal `n`, if `flip_invalid_normals` (default true), has its tangential part negated
//!   (`(−x, −y, z)`) when it lies on the other side of `wo` than the unperturbed normal
//!   (`cos θo · (wo·n) ≤ 0`), then is normalised; the frame's tangent is the perturbation's tangent made
//!   orthogonal to `n` (Gram–Schmidt), its bitangent `n × s`;
//! - the nested BSDF sees `wo` and `wi` in that frame; a direction on different sides of the two frames
//!   (`cos θi · cos θ′i ≤ 0`) scatters nothing;
//! - Mitsuba's `eval` includes the cosine of the perturbed frame, `f′·|cos θ′i|`, so our `f` (without the
//!   cosine, which the integrators multiply by `|cos θi|` of the unperturbed frame) is
//!   `f′·|cos θ′i|/|cos θi|`, and a sample's weight is the nested one's;
//! - with `use_shadowing_function` (default true) the value is multiplied by the shadow terminator of
//!   Estevez et al. 2019 (Ray Tracing Gems, "A Microfacet-Based Shadowing Function to Solve the Bump
//!   Terminator Problem"): `2/(1 + sqrt(1 + α²·tan²θi))`, `α² = min(tan²θₙ/8, 1)` (θₙ: the perturbed
//!   normal's angle to the unperturbed one).
//!
//! The pdf is the nested BSDF's (a rotation has no Jacobian), so it integrates to at most one.

use super::{non_delta_sample, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, TransportMode};
use crate::math::{Frame, Vec2, Vec3};

/// A perturbed shading normal at a hit, in the hit's local frame (the frame the BSDF is evaluated in):
/// the normal `n` (any length) and the direction `tangent` the perturbed frame's tangent is made from.
/// The identity (`+z`, `+x`) perturbs nothing: the template's value before any hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation {
    pub n: Vec3,
    pub tangent: Vec3,
}

impl Default for Perturbation {
    fn default() -> Self {
        Self { n: Vec3::Z, tangent: Vec3::X }
    }
}

/// How a [`Perturbation`] is made from a texture at the hit (the rule of `normalmap` or `bumpmap`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameRule {
    /// The texture's colour is the normal (`normalmap`).
    NormalMap,
    /// The texture's gradient, times `scale`, is the slope of a height field (`bumpmap`).
    Height { scale: f32 },
}

/// The hit's geometry a [`FrameRule`] reads, in world space: the shading frame the BSDF is evaluated in
/// (`SurfaceInteraction::frame`), the geometric normal, and the surface's derivatives `∂p/∂u`, `∂p/∂v`
/// (Mitsuba's `si.dp_du`, `si.dp_dv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitFrame {
    pub frame: Frame,
    pub ng: Vec3,
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
}

impl HitFrame {
    /// Mitsuba's shading tangent in the local frame: `∂p/∂u` made orthogonal to the shading normal
    /// (`SurfaceInteraction::initialize_sh_frame`), a unit vector in the local xy-plane; where `∂p/∂u` has no
    /// part orthogonal to the normal, the local frame's own tangent (which is Mitsuba's fallback,
    /// `coordinate_system(n)`, when `∂p/∂u` is zero: the same construction).
    #[must_use]
    pub fn tangent(&self) -> Vec2 {
        Vec2::new(self.frame.s.dot(self.dp_du), self.frame.t.dot(self.dp_du)).try_normalize().unwrap_or(Vec2::X)
    }

    /// A vector given in Mitsuba's shading frame (its tangent `s`, `n × s`, `n`) in the local frame.
    #[must_use]
    pub fn from_mitsuba_local(&self, v: Vec3) -> Vec3 {
        let s = self.tangent();
        Vec3::new(v.x * s.x - v.y * s.y, v.x * s.y + v.y * s.x, v.z)
    }
}

impl FrameRule {
    /// The perturbation at a hit with geometry `hit`, from the texture's colour there (`rgb`) or its
    /// gradient with respect to `(u, v)` (`grad`), whichever the rule reads.
    #[must_use]
    pub fn perturbation(self, rgb: impl FnOnce() -> Vec3, grad: impl FnOnce() -> Vec2, hit: &HitFrame) -> Perturbation {
        match self {
            FrameRule::NormalMap => super::normalmap::perturbation(rgb(), hit),
            FrameRule::Height { scale } => super::bumpmap::perturbation(scale * grad(), hit),
        }
    }
}

/// The nested BSDF, its options and the perturbation at the hit (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Perturbed {
    pub bsdf: Box<Bsdf>,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
    pub at: Perturbation,
}

/// Mitsuba's `Frame3f::tan_theta_2`.
#[inline]
fn tan_theta_2(v: Vec3) -> f32 {
    (1.0 - v.z * v.z).max(0.0) / (v.z * v.z)
}

/// Estevez et al.'s shadow terminator for the perturbed normal `n` (unit, local) and a direction `wi`
/// (Mitsuba's `eval_shadow_terminator`); 1 for an unperturbed normal (where Mitsuba's `0·∞` at a direction
/// whose `cos²θ` underflows would be NaN).
#[inline]
fn shadow_terminator(n: Vec3, wi: Vec3) -> f32 {
    let alpha2 = (0.125 * tan_theta_2(n)).min(1.0);
    if alpha2 == 0.0 {
        return 1.0;
    }
    2.0 / (1.0 + (1.0 + alpha2 * tan_theta_2(wi)).sqrt())
}

impl Perturbed {
    /// The perturbed frame seen from `wo` (in the local frame).
    #[inline]
    fn frame(&self, wo: Vec3) -> Frame {
        let mut n = self.at.n;
        if self.flip_invalid_normals && wo.z * wo.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        let n = n.try_normalize().unwrap_or(Vec3::Z);
        let tangent = self.at.tangent;
        let s = (tangent - n * n.dot(tangent)).try_normalize().unwrap_or_else(|| Frame::from_normal(n).s);
        Frame { s, t: n.cross(s), n }
    }

    /// The factor of a value at `wi` besides the nested BSDF's: `|cos θ′i|/|cos θi|` and the shadow
    /// terminator; 0 where `wi` is on different sides of the two frames.
    #[inline]
    fn factor(&self, frame: &Frame, wi: Vec3, wi_p: Vec3) -> f32 {
        if wi.z * wi_p.z <= 0.0 {
            return 0.0;
        }
        let cos = wi_p.z.abs() / wi.z.abs();
        if self.use_shadowing_function {
            cos * shadow_terminator(frame.n, wi)
        } else {
            cos
        }
    }
}

impl Model for Perturbed {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        let frame = self.frame(wo);
        let wi_p = frame.to_local(wi);
        let k = self.factor(&frame, wi, wi_p);
        if k == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (f, pdf) = self.bsdf.f_pdf(frame.to_local(wo), wi_p, mode);
        (f * k, pdf)
    }
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        let frame = self.frame(wo);
        let wi_p = frame.to_local(wi);
        if wi.z * wi_p.z <= 0.0 {
            return 0.0;
        }
        self.bsdf.pdf_w(frame.to_local(wo), wi_p)
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let frame = self.frame(wo);
        let s = self.bsdf.sample(frame.to_local(wo), u_lobe, u_dir, mode)?;
        let wi = frame.to_world(s.wi_local);
        if !(s.wi_local.z * wi.z > 0.0) {
            return None;
        }
        if !s.delta {
            // f, pdf and weight from one evaluation at the direction as returned (module `bsdf`'s rule).
            return non_delta_sample(self, wo, wi, mode);
        }
        let shadow = if self.use_shadowing_function { shadow_terminator(frame.n, wi) } else { 1.0 };
        Some(BsdfSample { wi_local: wi, weight: s.weight * shadow, ..s })
    }
    fn chooses_lobe(&self) -> bool {
        self.bsdf.chooses_lobe()
    }
    fn has_delta(&self) -> bool {
        self.bsdf.has_delta()
    }
    fn has_non_delta(&self) -> bool {
        self.bsdf.has_non_delta()
    }
    fn transmits(&self) -> bool {
        self.bsdf.transmits()
    }
    /// The nested BSDF's, unperturbed (Mitsuba's `NormalMap`/`BumpMap::eval_diffuse_reflectance`).
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.bsdf.diffuse_reflectance(wo)
    }
}

impl Perturbed {
    /// The perturbation (under the key `key`, made by `rule`) and the nested bsdf.
    pub(super) fn visit_params(&mut self, key: &'static str, rule: FrameRule, v: &mut dyn ParamVisitor) {
        v.param(key, ParamMut::Frame(&mut self.at, rule));
        v.nested("bsdf", &mut self.bsdf);
    }
}
