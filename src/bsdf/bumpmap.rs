//! Mitsuba 3's `bumpmap` (src/bsdfs/bumpmap.cpp): the nested BSDF in a shading frame whose normal is that
//! of the surface displaced along its shading normal by a height texture times `scale`. Evaluation,
//! sampling, `flip_invalid_normals` and the shadow terminator: `super::perturbed`.
//!
//! ```toml
//! bsdf = { type = "bumpmap", texture = { type = "bitmap", filename = "height.png", raw = true },
//!          bsdf = { type = "roughplastic" }, scale = 1.0,
//!          flip_invalid_normals = true, use_shadowing_function = true }   # the defaults
//! ```
//!
//! `texture` is the height (Mitsuba takes its one nested texture under any name; the XML reader names it
//! `texture`); its gradient is Mitsuba's `eval_1_grad` (`Texture::eval_1_grad`: a bilinear bitmap's; zero for
//! a `nearest` one as in Mitsuba, and for a constant or a checkerboard, which Mitsuba refuses here).

use super::perturbed::{FrameRule, HitFrame, Perturbation, Perturbed};
use super::{Bsdf, BsdfSample, Model, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `bumpmap` around its nested BSDF; `scale` multiplies the height's gradient.
#[derive(Clone, Debug, PartialEq)]
pub struct BumpMap {
    pub perturbed: Perturbed,
    pub scale: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "bumpmap",
    keys: &["texture", "bsdf", "scale", "flip_invalid_normals", "use_shadowing_function"],
    nested: &["bsdf"],
    build,
};

fn build(mut p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    p.require_texture("texture", "the height, a texture")?;
    let Some(bsdf) = p.take_nested("bsdf") else {
        return Err(PropError::new("", "bumpmap needs `bsdf` (the bsdf whose normals the height perturbs)"));
    };
    Ok(Bsdf::BumpMap(BumpMap {
        perturbed: Perturbed {
            bsdf: Box::new(bsdf),
            flip_invalid_normals: p.bool_or("flip_invalid_normals", true)?,
            use_shadowing_function: p.bool_or("use_shadowing_function", true)?,
            at: Perturbation::default(),
        },
        scale: p.float_or("scale", 1.0)?,
    }))
}

/// The perturbation of the height gradient `grad` (times `scale`) at a hit (Mitsuba's `BumpMap::frame`,
/// before the flip that depends on `wo`): `∂p/∂u` and `∂p/∂v` with their parts along the shading normal
/// replaced by the gradient's, the normal of the plane they span turned to the geometric normal's side.
/// The tangent is Mitsuba's: its `si.dp_du`, a world-space vector, read as coordinates in the shading frame
/// (bumpmap.cpp orthogonalises it against the local normal as it is), which only an anisotropic nested BSDF
/// sees.
pub(super) fn perturbation(grad: Vec2, hit: &HitFrame) -> Perturbation {
    let ns = hit.frame.n;
    let dp_du = hit.dp_du + ns * (grad.x - ns.dot(hit.dp_du));
    let dp_dv = hit.dp_dv + ns * (grad.y - ns.dot(hit.dp_dv));
    let n = match dp_du.cross(dp_dv).try_normalize() {
        Some(n) if n.dot(hit.ng) < 0.0 => -n,
        Some(n) => n,
        None => ns,
    };
    Perturbation { n: hit.frame.to_local(n), tangent: hit.from_mitsuba_local(hit.dp_du) }
}

impl Model for BumpMap {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        self.perturbed.f_pdf(wo, wi, mode)
    }
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.perturbed.pdf_w(wo, wi)
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.perturbed.sample(wo, u_lobe, u_dir, mode)
    }
    fn chooses_lobe(&self) -> bool {
        self.perturbed.chooses_lobe()
    }
    fn has_delta(&self) -> bool {
        self.perturbed.has_delta()
    }
    fn has_non_delta(&self) -> bool {
        self.perturbed.has_non_delta()
    }
    fn transmits(&self) -> bool {
        self.perturbed.transmits()
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        self.perturbed.visit_params("texture", FrameRule::Height { scale: self.scale }, v);
    }
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.perturbed.diffuse_reflectance(wo)
    }
}
