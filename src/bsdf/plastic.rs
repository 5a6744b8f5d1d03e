//! Mitsuba's `plastic`: a diffuse base under a smooth dielectric coating (Mitsuba 3.9.1
//! src/bsdfs/plastic.cpp; Weidlich & Wilkie 2007 for the layering, the internal scattering as in Mitsuba).
//! Light reflects off the coating by Fresnel, `F(cos θo)` (a delta lobe), or enters, scatters off the
//! base and leaves, which gives the non-delta lobe
//!
//! `f(wo, wi) = R' · (1 − F(cos θo))·(1 − F(cos θi)) / (η²·π)`,
//!
//! with `R' = R/(1 − F_dr)` (or `R/(1 − R·F_dr)` when `nonlinear`), `F_dr` the coating's diffuse Fresnel
//! reflectance seen from inside (`fresnel_diffuse_reflectance(1/η)`): the light the coating reflects back
//! onto the base, summed over its bounces. `η = int_ior/ext_ior`. One-sided, as Mitsuba's.
//!
//! Sampling chooses the coating with probability `p_s = F(cos θo)·w / (F·w + (1 − F)·(1 − w))`, `w` =
//! mean(specular_reflectance)/(mean(diffuse_reflectance) + mean(specular_reflectance)) (Mitsuba's
//! `specular_sampling_weight`), else the base with a cosine-weighted direction; the non-delta pdf is
//! `(1 − p_s)·cos θi/π`.
//!
//! ```toml
//! bsdf = { type = "plastic", diffuse_reflectance = [0.1, 0.27, 0.36], int_ior = 1.9 }
//! # defaults: diffuse_reflectance 0.5, specular_reflectance 1, int_ior "polypropylene" (1.49),
//! # ext_ior "air", nonlinear false
//! ```

use std::f32::consts::FRAC_1_PI;

use super::ior::{ior_or, AIR};
use super::{fresnel_dielectric, non_delta_sample, reflect_z, Bsdf, BsdfSample, Model, Plugin, TransportMode, ParamMut, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;

/// Mitsuba's default interior index of `plastic`: polypropylene.
pub(super) const POLYPROPYLENE: f32 = 1.49;

/// Mitsuba's `plastic`, with the factors that depend on its parameters alone.
#[derive(Clone, Debug, PartialEq)]
pub struct Plastic {
    pub eta: f32,
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    pub nonlinear: bool,
    /// `R'/(η²·π)`: the base's value before the two Fresnel transmissions.
    base_over_pi: Vec3,
    /// Mitsuba's `specular_sampling_weight`.
    specular_weight: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "plastic",
    keys: &["diffuse_reflectance", "specular_reflectance", "int_ior", "ext_ior", "nonlinear"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let eta = ior_or(&p, "int_ior", POLYPROPYLENE)? / ior_or(&p, "ext_ior", AIR)?;
    let diffuse_reflectance = p.reflectance_or("diffuse_reflectance", Vec3::splat(0.5))?;
    let specular_reflectance = p.reflectance_or("specular_reflectance", Vec3::ONE)?;
    let nonlinear = p.bool_or("nonlinear", false)?;
    Ok(Bsdf::Plastic(Plastic::new(eta, diffuse_reflectance, specular_reflectance, nonlinear)))
}

/// `R'/(η²·π)` with `R' = R/(1 − F_dr,int)`, or `R/(1 − R·F_dr,int)` when `nonlinear` (Mitsuba's plastic.cpp).
fn base_over_pi(eta: f32, diffuse_reflectance: Vec3, nonlinear: bool) -> Vec3 {
    internal_scattering(diffuse_reflectance, fresnel_diffuse_reflectance(1.0 / eta), nonlinear) * (FRAC_1_PI / (eta * eta))
}

/// The diffuse Fresnel reflectance `∫ F(cos θ)·2cos θ sin θ dθ` of an interface of relative index `eta`, by
/// the fits Mitsuba uses (`fresnel_diffuse_reflectance`, include/mitsuba/render/fresnel.h): Egan &
/// Hilgeman 1973 for `eta < 1`, `−1.4399η² + 0.7099η + 0.6681 + 0.0636/η`; d'Eon & Irving 2011 otherwise,
/// a quintic in `1/η` (relative error ≤ 0.2 % for η in [1, 10]).
#[must_use]
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let x = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * x + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        const C: [f32; 6] = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        C.iter().rev().fold(0.0, |acc, &c| acc * x + c)
    }
}

/// The base's reflectance `R` after the light the coating reflects back onto it (diffuse reflectance
/// `fdr_int` from inside) has bounced between them: `R/(1 − F_dr)`, or `R/(1 − R·F_dr)` when `nonlinear`
/// (Mitsuba's `plastic` and `roughplastic`).
#[must_use]
pub(super) fn internal_scattering(diffuse_reflectance: Vec3, fdr_int: f32, nonlinear: bool) -> Vec3 {
    let inner = if nonlinear { Vec3::ONE - diffuse_reflectance * fdr_int } else { Vec3::splat(1.0 - fdr_int) };
    diffuse_reflectance / inner
}

/// Mitsuba's `specular_sampling_weight` of `plastic` and `roughplastic`: `s/(d + s)` of the mean specular
/// and diffuse reflectances (0 when both are black).
#[must_use]
pub(super) fn specular_sampling_weight(diffuse_reflectance: Vec3, specular_reflectance: Vec3) -> f32 {
    let (d_mean, s_mean) = (diffuse_reflectance.element_sum() / 3.0, specular_reflectance.element_sum() / 3.0);
    if d_mean + s_mean > 0.0 {
        s_mean / (d_mean + s_mean)
    } else {
        0.0
    }
}

impl Plastic {
    #[must_use]
    pub fn new(eta: f32, diffuse_reflectance: Vec3, specular_reflectance: Vec3, nonlinear: bool) -> Self {
        let base_over_pi = base_over_pi(eta, diffuse_reflectance, nonlinear);
        let specular_weight = specular_sampling_weight(diffuse_reflectance, specular_reflectance);
        Self { eta, diffuse_reflectance, specular_reflectance, nonlinear, base_over_pi, specular_weight }
    }

    /// The coating's Fresnel reflectance at `cos θ > 0`.
    #[inline]
    fn fresnel(&self, cos_theta: f32) -> f32 {
        fresnel_dielectric(cos_theta, self.eta).0
    }

    /// The probability of sampling the coating's reflection, given its Fresnel term `f_o` at `wo`.
    #[inline]
    fn p_specular(&self, f_o: f32) -> f32 {
        let (s, d) = (f_o * self.specular_weight, (1.0 - f_o) * (1.0 - self.specular_weight));
        if s + d > 0.0 {
            s / (s + d)
        } else {
            0.0
        }
    }
}

impl Model for Plastic {
    /// Its diffuse layer's reflectance (Mitsuba's `SmoothPlastic::eval_diffuse_reflectance`).
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.diffuse_reflectance
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let f_o = self.fresnel(wo.z);
        let f = self.base_over_pi * ((1.0 - f_o) * (1.0 - self.fresnel(wi.z)));
        (f, (1.0 - self.p_specular(f_o)) * wi.z * FRAC_1_PI)
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        (1.0 - self.p_specular(self.fresnel(wo.z))) * wi.z * FRAC_1_PI
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f_o = self.fresnel(wo.z);
        let p_s = self.p_specular(f_o);
        if u_lobe < p_s {
            // The coating's mirror reflection: throughput F·specular_reflectance, chosen with p_s.
            return Some(BsdfSample { wi_local: reflect_z(wo), weight: self.specular_reflectance * (f_o / p_s), pdf_w: p_s, delta: true, pass_through: false });
        }
        let wi = square_to_cosine_hemisphere(u_dir);
        if wi.z <= 0.0 {
            return None;
        }
        non_delta_sample(self, wo, wi, mode)
    }
    fn chooses_lobe(&self) -> bool {
        true
    }
    fn has_delta(&self) -> bool {
        self.specular_weight > 0.0
    }
    fn has_non_delta(&self) -> bool {
        self.diffuse_reflectance.max_element() > 0.0
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("diffuse_reflectance", ParamMut::Rgb(&mut self.diffuse_reflectance));
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
    }
    /// The base's factor from the (textured) diffuse reflectance. The specular sampling weight stays the
    /// one made from the parameters' means, as Mitsuba makes it from its textures' means (plastic.cpp).
    fn params_changed(&mut self) {
        self.base_over_pi = base_over_pi(self.eta, self.diffuse_reflectance, self.nonlinear);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diffuse_fresnel_reflectance_matches_the_integral() {
        // F_dr(η) = ∫₀^{π/2} F(cos θ)·2 cos θ sin θ dθ, by the midpoint rule in cos θ (F_dr = ∫₀¹ F(μ) 2μ dμ).
        for eta in [1.0f32, 1.2, 1.33, 1.49, 1.9, 2.5, 1.0 / 1.33, 1.0 / 1.49, 0.8] {
            let n = 200_000;
            let exact: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    f64::from(fresnel_dielectric(mu as f32, eta).0) * 2.0 * mu / n as f64
                })
                .sum();
            let fit = f64::from(fresnel_diffuse_reflectance(eta));
            // The fits' stated accuracy: 0.2 % (d'Eon & Irving), 0.6 % (Egan & Hilgeman, η in [1/2, 1]).
            let tol = if eta < 1.0 { 0.006 * exact + 2e-3 } else { 0.002 * exact + 3e-4 };
            assert!((fit - exact).abs() <= tol, "eta {eta}: fit {fit} vs ∫ {exact}");
        }
    }

    #[test]
    fn a_white_plastic_keeps_about_all_the_light_and_a_black_one_only_the_coating() {
        for eta in [1.3f32, 1.49, 1.9] {
            let white = Bsdf::Plastic(Plastic::new(eta, Vec3::ONE, Vec3::ONE, false));
            let black = Bsdf::Plastic(Plastic::new(eta, Vec3::ZERO, Vec3::ONE, false));
            for cos_o in [0.95f32, 0.6, 0.2] {
                let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                let albedo = |b: &Bsdf| {
                    let n = 400_000;
                    let mut s = crate::sampler::Sampler::for_key(5, u64::from(cos_o.to_bits()), 0);
                    (0..n).map(|_| b.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance).map_or(0.0, |x| f64::from(x.weight.x))).sum::<f64>() / f64::from(n)
                };
                // Coating F plus what enters, scatters and leaves: (1 − F)·(1 − F_dr(η))/(η²(1 − F_dr(1/η))) ≈ 1 − F.
                let a = albedo(&white);
                assert!((a - 1.0).abs() < 0.02, "eta {eta} cos {cos_o}: white albedo {a}");
                let f = f64::from(fresnel_dielectric(cos_o, eta).0);
                let b = albedo(&black);
                assert!((b - f).abs() < 1e-6, "eta {eta} cos {cos_o}: black albedo {b}, F {f}");
                assert!(!black.has_non_delta() && black.has_delta() && white.has_non_delta());
            }
        }
    }

    #[test]
    fn nonlinear_darkens_less_saturated_colours_as_mitsuba_writes_it() {
        let r = Vec3::new(0.9, 0.5, 0.1);
        let (lin, non) = (Plastic::new(1.5, r, Vec3::ONE, false), Plastic::new(1.5, r, Vec3::ONE, true));
        let fdr = fresnel_diffuse_reflectance(1.0 / 1.5);
        let want_lin = r / (1.0 - fdr) * (FRAC_1_PI / 2.25);
        let want_non = r / (Vec3::ONE - r * fdr) * (FRAC_1_PI / 2.25);
        assert!((lin.base_over_pi - want_lin).abs().max_element() < 1e-6);
        assert!((non.base_over_pi - want_non).abs().max_element() < 1e-6);
    }
}
