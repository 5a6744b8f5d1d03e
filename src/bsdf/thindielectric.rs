//! Mitsuba's `thindielectric`: a pane of glass so thin that light leaves it where it entered and in its
//! own direction (windows, soap films). The pane's reflectance sums the light reflected after any number of
//! internal bounces, `R' = R + T²R·Σ(R²)ⁿ = 2R/(1 + R)` with `R` the Fresnel reflectance of one interface
//! at `|cos θo|` (`fresnel_dielectric`), and passes the rest straight through, `T' = 1 − R'` (Mitsuba 3.9.1
//! src/bsdfs/thindielectric.cpp; Beckmann's thin-slab sum). Two delta lobes, chosen with probabilities `R'`
//! and `T'`, so both have weight 1 (times `specular_reflectance` or `specular_transmittance`). The same on
//! both sides; the passing lobe does not bend, so radiance needs no `1/η²`.
//!
//! ```toml
//! bsdf = { type = "thindielectric", int_ior = 1.5, ext_ior = "air" }   # as `dielectric`; defaults bk7 / air
//! # specular_reflectance, specular_transmittance: RGB in [0, 1], default 1
//! ```

use super::ior::{ior_or, AIR, BK7};
use super::{fresnel_dielectric, reflect_z, Bsdf, BsdfSample, Model, Plugin, TransportMode, ParamMut, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `thindielectric`: `eta = int_ior / ext_ior` of the pane.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinDielectric {
    pub eta: f32,
    pub specular_reflectance: Vec3,
    pub specular_transmittance: Vec3,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "thindielectric",
    keys: &["int_ior", "ext_ior", "specular_reflectance", "specular_transmittance"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    Ok(Bsdf::ThinDielectric(ThinDielectric {
        eta: ior_or(&p, "int_ior", BK7)? / ior_or(&p, "ext_ior", AIR)?,
        specular_reflectance: p.reflectance_or("specular_reflectance", Vec3::ONE)?,
        specular_transmittance: p.reflectance_or("specular_transmittance", Vec3::ONE)?,
    }))
}

impl ThinDielectric {
    /// The pane's reflectance `R' = 2R/(1 + R)` at `|cos θo|`.
    #[must_use]
    pub fn reflectance(&self, cos_theta_o: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta_o.abs(), self.eta).0;
        r * 2.0 / (1.0 + r)
    }
}

impl Model for ThinDielectric {
    /// Reflection when `u_lobe < R'`, else straight through (`wi = −wo`).
    fn sample(&self, wo: Vec3, u_lobe: f32, _: Vec2, _: TransportMode) -> Option<BsdfSample> {
        if !(self.eta > 0.0 && self.eta.is_finite()) {
            return None;
        }
        let r = self.reflectance(wo.z);
        let (wi_local, weight, pdf_w) = if u_lobe < r {
            (reflect_z(wo), self.specular_reflectance, r)
        } else {
            (-wo, self.specular_transmittance, 1.0 - r)
        };
        (pdf_w > 0.0).then_some(BsdfSample { wi_local, weight, pdf_w, delta: true, pass_through: false })
    }
    fn chooses_lobe(&self) -> bool {
        true
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
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
        v.param("specular_transmittance", ParamMut::Rgb(&mut self.specular_transmittance));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pane(eta: f32) -> Bsdf {
        Bsdf::ThinDielectric(ThinDielectric { eta, specular_reflectance: Vec3::ONE, specular_transmittance: Vec3::ONE })
    }

    #[test]
    fn reflects_the_thin_slab_sum_and_passes_the_rest_unbent_on_both_sides() {
        let glass = ThinDielectric { eta: 1.5, specular_reflectance: Vec3::ONE, specular_transmittance: Vec3::ONE };
        // Normal incidence: R = ((η − 1)/(η + 1))² = 0.04, R' = 0.08/1.04.
        assert!((glass.reflectance(1.0) - 0.08 / 1.04).abs() < 1e-6);
        let b = pane(1.5);
        for wo in [Vec3::new(0.3, -0.2, 0.9).normalize(), Vec3::new(-0.5, 0.1, -0.7).normalize()] {
            let r = glass.reflectance(wo.z);
            let refl = b.sample(wo, 0.5 * r, Vec2::ZERO, TransportMode::Radiance).unwrap();
            assert_eq!((refl.wi_local, refl.weight, refl.pdf_w, refl.delta), (Vec3::new(-wo.x, -wo.y, wo.z), Vec3::ONE, r, true));
            let pass = b.sample(wo, r + 0.5 * (1.0 - r), Vec2::ZERO, TransportMode::Radiance).unwrap();
            assert_eq!((pass.wi_local, pass.weight, pass.pdf_w), (-wo, Vec3::ONE, 1.0 - r));
            assert_eq!(b.f(wo, -wo, TransportMode::Radiance), Vec3::ZERO);
            assert_eq!(b.pdf_w(wo, -wo), 0.0);
        }
        // A pane of the surrounding medium's index is invisible: everything passes.
        let s = pane(1.0).sample(Vec3::new(0.0, 0.6, 0.8), 0.0, Vec2::ZERO, TransportMode::Importance).unwrap();
        assert_eq!((s.wi_local, s.pdf_w), (Vec3::new(0.0, -0.6, -0.8), 1.0));
    }

    #[test]
    fn the_lobes_carry_the_panes_colours() {
        let b = Bsdf::ThinDielectric(ThinDielectric {
            eta: 1.5,
            specular_reflectance: Vec3::new(0.5, 0.5, 0.5),
            specular_transmittance: Vec3::new(0.2, 0.4, 0.6),
        });
        let wo = Vec3::Z;
        assert_eq!(b.sample(wo, 0.0, Vec2::ZERO, TransportMode::Radiance).unwrap().weight, Vec3::splat(0.5));
        assert_eq!(b.sample(wo, 0.99, Vec2::ZERO, TransportMode::Radiance).unwrap().weight, Vec3::new(0.2, 0.4, 0.6));
        assert!(b.has_delta() && b.transmits() && b.chooses_lobe() && !b.has_non_delta());
    }
}
