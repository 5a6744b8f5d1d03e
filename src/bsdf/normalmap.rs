//! Mitsuba 3's `normalmap` (src/bsdfs/normalmap.cpp): the nested BSDF in a shading frame whose normal a
//! texture gives, `n = 2·rgb − 1` in Mitsuba's shading frame at the hit (its tangent along `∂p/∂u`,
//! `HitFrame::tangent`), the perturbed frame's tangent that tangent made orthogonal to `n`. Evaluation,
//! sampling, `flip_invalid_normals` and the shadow terminator: `super::perturbed`.
//!
//! ```toml
//! bsdf = { type = "normalmap", normalmap = { type = "bitmap", filename = "normals.png", raw = true },
//!          bsdf = { type = "roughplastic" },
//!          flip_invalid_normals = true, use_shadowing_function = true }   # the defaults
//! ```
//!
//! `normalmap` must be a texture (`raw = true` keeps its values as stored: without it an 8-bit image is
//! read as sRGB, as in Mitsuba); `bsdf` a name or an inline table. A colour of `(½, ½, 1)` leaves the
//! normal unperturbed; a colour of `(½, ½, ½)` has no normal and leaves it unperturbed too (Mitsuba's
//! normalisation of a zero vector is undefined).

use super::perturbed::{FrameRule, HitFrame, Perturbation, Perturbed};
use super::{Bsdf, BsdfSample, Model, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `normalmap` around its nested BSDF.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap(pub Perturbed);

pub(super) const PLUGIN: Plugin = Plugin {
    name: "normalmap",
    keys: &["normalmap", "bsdf", "flip_invalid_normals", "use_shadowing_function"],
    nested: &["bsdf"],
    build,
};

fn build(mut p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    p.require_texture("normalmap", "the normals, a texture whose colour c gives the normal 2c − 1")?;
    let Some(bsdf) = p.take_nested("bsdf") else {
        return Err(PropError::new("", "normalmap needs `bsdf` (the bsdf whose normals the map perturbs)"));
    };
    Ok(Bsdf::NormalMap(NormalMap(Perturbed {
        bsdf: Box::new(bsdf),
        flip_invalid_normals: p.bool_or("flip_invalid_normals", true)?,
        use_shadowing_function: p.bool_or("use_shadowing_function", true)?,
        at: Perturbation::default(),
    })))
}

/// The perturbation of the normal-map colour `rgb` at a hit (Mitsuba's `NormalMap::frame`, before the flip
/// that depends on `wo`): `2·rgb − 1` and the tangent `(1, 0, 0)`, both in Mitsuba's shading frame.
pub(super) fn perturbation(rgb: Vec3, hit: &HitFrame) -> Perturbation {
    let n = rgb * 2.0 - Vec3::ONE;
    let n = if n == Vec3::ZERO || !n.is_finite() { Vec3::Z } else { n };
    Perturbation { n: hit.from_mitsuba_local(n), tangent: hit.from_mitsuba_local(Vec3::X) }
}

impl Model for NormalMap {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        self.0.f_pdf(wo, wi, mode)
    }
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.0.pdf_w(wo, wi)
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.0.sample(wo, u_lobe, u_dir, mode)
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
    fn transmits(&self) -> bool {
        self.0.transmits()
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        self.0.visit_params("normalmap", FrameRule::NormalMap, v);
    }
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.0.diffuse_reflectance(wo)
    }
}
