//! The parameters of a BSDF that a texture can drive, as each type exposes them to the material layer
//! (`crate::material`): pbrt-v4 evaluates a material's textures at the hit and builds the BxDF from the
//! values (`Material::GetBxDF`); here the BSDF built from the scene file is the template, and the material
//! layer overwrites its textured parameters at each hit through [`Model::visit_params`](super::Model).
//!
//! A type lists each texturable parameter once, under the key its scene files give it, in a fixed order,
//! and hands over its nested bsdfs under their keys, so that `bsdf_0.reflectance` names the reflectance of a
//! blend's first component. What a type derives from those parameters at construction it recomputes in
//! [`Model::params_changed`](super::Model), except what Mitsuba itself derives from a texture's *mean*
//! (sampling weights: `plastic`'s `specular_sampling_weight`), which stays the template's.

use super::perturbed::{FrameRule, Perturbation};
use super::Bsdf;
use crate::math::Vec3;

/// A texturable parameter: an RGB value (a texture's `eval`), a number (its `eval_1`), two numbers that
/// one key sets to the same value (an isotropic `alpha`, which is `alpha_u` and `alpha_v`), or a perturbed
/// shading frame (`normalmap`, `bumpmap`), which needs more than the texture at a uv: the hit's geometry
/// ([`HitFrame`](super::HitFrame)), from which the scene layer makes it by its [`FrameRule`] (`Scene::bsdf_at`).
pub enum ParamMut<'a> {
    Rgb(&'a mut Vec3),
    Float(&'a mut f32),
    FloatPair(&'a mut f32, &'a mut f32),
    Frame(&'a mut Perturbation, FrameRule),
}

impl ParamMut<'_> {
    /// Sets the parameter from a texture's colour (`eval`) or number (`eval_1`), whichever it takes; a
    /// [`ParamMut::Frame`], which needs the hit's geometry, is left as it is (the identity in a template:
    /// what the per-material facts are decided on, as the frame changes no lobe's presence).
    pub fn set(self, rgb: impl FnOnce() -> Vec3, number: impl FnOnce() -> f32) {
        match self {
            ParamMut::Rgb(v) => *v = rgb(),
            ParamMut::Float(x) => *x = number(),
            ParamMut::FloatPair(x, y) => {
                *x = number();
                *y = *x;
            }
            ParamMut::Frame(..) => {}
        }
    }
}

/// What walks a BSDF's texturable parameters (see the module documentation).
pub trait ParamVisitor {
    /// The parameter the scene files call `key`.
    fn param(&mut self, key: &'static str, value: ParamMut<'_>);
    /// The nested bsdf at `key`, whose parameters the visitor walks in turn (`Bsdf::visit_params`).
    fn nested(&mut self, key: &'static str, bsdf: &mut Bsdf);
}
