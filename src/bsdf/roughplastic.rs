//! Mitsuba's `roughplastic`: a diffuse base under a rough dielectric coating (Mitsuba 3.9.1
//! src/bsdfs/roughplastic.cpp), the rough counterpart of [`super::plastic`]. One-sided, as Mitsuba's:
//!
//! `f(wo, wi) = R_s·F(wo·h)·D(h)·G1(wo)·G1(wi)/(4 cos θo cos θi) + R'·T(cos θo)·T(cos θi)/(η²·π)`,
//!
//! the coating's microfacet reflection (as `roughconductor`'s, with the dielectric Fresnel term of
//! `η = int_ior/ext_ior`; isotropic only, as Mitsuba), and the base: `T(μ)` the rough coating's
//! transmittance and `R' = R/(1 − R_int)` (or `R/(1 − R·R_int)` when `nonlinear`) with `R_int` its diffuse
//! reflectance from inside, both precomputed by integrating the microfacet model ([`RoughCoating`]).
//!
//! Sampling chooses the coating with probability `p_s = (1 − T(cos θo))·w / ((1 − T)·w + T·(1 − w))`, `w`
//! Mitsuba's `specular_sampling_weight` (as `plastic`'s), and samples `roughconductor`'s distribution of
//! reflected normals; else a cosine-weighted direction. `pdf_w = p_s·pdf_spec + (1 − p_s)·cos θi/π`, the
//! mixture as sampled (samples reflected below the surface are lost: `∫pdf_w ≤ 1`).
//!
//! ```toml
//! bsdf = { type = "roughplastic", distribution = "ggx", alpha = 0.2, diffuse_reflectance = [0.1, 0.27, 0.36] }
//! # defaults as Mitsuba: distribution "beckmann", alpha 0.1, sample_visible true, int_ior "polypropylene"
//! # (1.49), ext_ior "air", diffuse_reflectance 0.5, specular_reflectance 1, nonlinear false
//! ```

use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

use super::ior::{relative_eta, AIR};
use super::microfacet::{self, Microfacet, MicrofacetType};
use super::plastic::{internal_scattering, specular_sampling_weight, POLYPROPYLENE};
use super::rough_coating::RoughCoating;
use super::{fresnel_dielectric, non_delta_sample, roughconductor, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;

/// Mitsuba's `roughplastic`. `diffuse_reflectance`, `specular_reflectance` and the distribution's α are the
/// parameters a texture may drive; the private fields are derived from them at construction.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    /// Isotropic (`alpha_u == alpha_v`).
    pub distribution: Microfacet,
    pub eta: f32,
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    pub nonlinear: bool,
    /// Derived from `distribution` (type, α) and `eta`: `T(μ)` and `R_int`.
    coating: Arc<RoughCoating>,
    /// Derived from `diffuse_reflectance`, `R_int` and `nonlinear`: `R'/(η²·π)`.
    base_over_pi: Vec3,
    /// Derived from `diffuse_reflectance` and `specular_reflectance` (Mitsuba: from their textures' means):
    /// Mitsuba's `specular_sampling_weight`.
    specular_weight: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "roughplastic",
    keys: &[
        "distribution",
        "alpha",
        "alpha_u",
        "alpha_v",
        "sample_visible",
        "int_ior",
        "ext_ior",
        "diffuse_reflectance",
        "specular_reflectance",
        "nonlinear",
    ],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let distribution = microfacet::from_props(&p, MicrofacetType::Beckmann)?;
    if distribution.alpha_u != distribution.alpha_v {
        return Err(PropError::new("alpha_u", "roughplastic does not support anisotropic roughness (alpha_u ≠ alpha_v), as in Mitsuba"));
    }
    let eta = relative_eta(&p, POLYPROPYLENE, AIR)?;
    let diffuse_reflectance = p.reflectance_or("diffuse_reflectance", Vec3::splat(0.5))?;
    let specular_reflectance = p.reflectance_or("specular_reflectance", Vec3::ONE)?;
    let nonlinear = p.bool_or("nonlinear", false)?;
    Ok(Bsdf::RoughPlastic(RoughPlastic::new(distribution, eta, diffuse_reflectance, specular_reflectance, nonlinear)))
}

impl RoughPlastic {
    /// The BSDF of these parameters (`distribution` isotropic: its `alpha_u` is the roughness).
    #[must_use]
    pub fn new(distribution: Microfacet, eta: f32, diffuse_reflectance: Vec3, specular_reflectance: Vec3, nonlinear: bool) -> Self {
        let distribution = Microfacet { alpha_v: distribution.alpha_u, ..distribution };
        let coating = RoughCoating::get(distribution.kind, distribution.alpha_u, eta);
        let base_over_pi = base_over_pi(eta, &coating, diffuse_reflectance, nonlinear);
        let specular_weight = specular_sampling_weight(diffuse_reflectance, specular_reflectance);
        Self { distribution, eta, diffuse_reflectance, specular_reflectance, nonlinear, coating, base_over_pi, specular_weight }
    }

    /// The probability of sampling the coating, given its transmittance `t_o` at `wo`.
    #[inline]
    fn p_specular(&self, t_o: f32) -> f32 {
        let (s, d) = ((1.0 - t_o) * self.specular_weight, t_o * (1.0 - self.specular_weight));
        if s + d > 0.0 {
            s / (s + d)
        } else {
            0.0
        }
    }
}

/// `R'/(η²·π)`: the diffuse base after its internal scattering under the coating (plastic's rule with the
/// rough coating's internal reflectance; Mitsuba's roughplastic.cpp).
fn base_over_pi(eta: f32, coating: &RoughCoating, diffuse_reflectance: Vec3, nonlinear: bool) -> Vec3 {
    internal_scattering(diffuse_reflectance, coating.internal_reflectance, nonlinear) * (FRAC_1_PI / (eta * eta))
}

impl Model for RoughPlastic {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let md = &self.distribution;
        let t_o = self.coating.transmittance(wo.z);
        let p_s = self.p_specular(t_o);
        let diffuse = self.base_over_pi * (t_o * self.coating.transmittance(wi.z));
        let diffuse_pdf = (1.0 - p_s) * wi.z * FRAC_1_PI;
        let Some(h) = (wo + wi).try_normalize() else {
            return (diffuse, diffuse_pdf);
        };
        // The coating: roughconductor's lobe with the dielectric Fresnel term.
        let d = md.d(h);
        let g1o = md.g1_over_cos(wo, h);
        let spec_pdf = if md.sample_visible { 0.25 * d * g1o } else { 0.25 * d * h.z / wo.dot(h) };
        let g = g1o * md.g1_over_cos(wi, h);
        let spec = if g == 0.0 { Vec3::ZERO } else { self.specular_reflectance * (fresnel_dielectric(wo.dot(h), self.eta).0 * 0.25 * d * g) };
        (spec + diffuse, p_s * spec_pdf + diffuse_pdf)
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Radiance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.p_specular(self.coating.transmittance(wo.z)) {
            roughconductor::sample_wi(&self.distribution, wo, u_dir)?
        } else {
            square_to_cosine_hemisphere(u_dir)
        };
        non_delta_sample(self, wo, wi, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    fn has_non_delta(&self) -> bool {
        self.diffuse_reflectance.max_element() > 0.0 || self.specular_reflectance.max_element() > 0.0
    }
    /// Mitsuba's `eval_diffuse_reflectance` of roughplastic: its diffuse reflectance.
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.diffuse_reflectance
    }
    /// Mitsuba's roughplastic takes its reflectances as textures, its roughness as a number.
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("diffuse_reflectance", ParamMut::Rgb(&mut self.diffuse_reflectance));
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
    }
    /// The base's factor from the (textured) diffuse reflectance; the sampling weight stays the means'.
    fn params_changed(&mut self) {
        self.base_over_pi = base_over_pi(self.eta, &self.coating, self.diffuse_reflectance, self.nonlinear);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::rough_coating::RES;
    use crate::sampling::chi2::integrate_sphere;

    fn kind(name: &str) -> MicrofacetType {
        if name == "ggx" {
            MicrofacetType::Ggx
        } else {
            MicrofacetType::Beckmann
        }
    }

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    /// How far our tables may be from Mitsuba's: the quadrature nodes fall on other normals for GGX (measured
    /// ≤ 3.2·10⁻⁴), and Mitsuba's Beckmann `G1` is Walter's rational fit (< 0.35 %; measured ≤ 1.8·10⁻³).
    fn table_tol(name: &str) -> f32 {
        if name == "ggx" {
            5e-4
        } else {
            2.5e-3
        }
    }

    /// Mitsuba 3.9.1's tables (scalar_rgb), recovered from its `roughplastic` `eval` with a black coating
    /// (`specular_reflectance` 0, `diffuse_reflectance` 0.5): `v = R'·T(μo)·T(μi)·μi/(η²π)`, linear and
    /// `nonlinear` (whose ratio gives `R_int`), at `μ = 1` and `μ = k/63`, k = 1, 8, 20, 40, 63 (the table's
    /// nodes). (distribution, α, η, R_int, T(k/63)).
    const MITSUBA_TABLES: [(&str, f32, f32, f32, [f32; 5]); 5] = [
        ("beckmann", 0.1, 1.4895874, 5.7466192e-01, [3.9237621e-01, 5.6944696e-01, 8.1124869e-01, 9.4163207e-01, 9.6132501e-01]),
        ("ggx", 0.3, 1.4995846, 4.1461461e-01, [6.5129630e-01, 7.3114432e-01, 8.2506052e-01, 9.1637355e-01, 9.5321566e-01]),
        ("ggx", 0.05, 1.8994738, 7.4267425e-01, [3.9568007e-01, 5.2980905e-01, 7.5830624e-01, 8.8162048e-01, 9.0371046e-01]),
        ("beckmann", 0.5, 1.3296317, 3.1293461e-01, [7.7992322e-01, 8.3526667e-01, 8.9597707e-01, 9.4957797e-01, 9.7895512e-01]),
        ("ggx", 0.3, 0.6666667, 5.3231687e-02, [7.0669759e-04, 2.3166555e-02, 6.6844156e-02, 2.4310366e-01, 8.5146177e-01]),
    ];

    #[test]
    fn coating_tables_match_mitsuba() {
        let (mut worst_r, mut worst_t) = (0.0f32, 0.0f32);
        for (name, alpha, eta, r_int, ts) in MITSUBA_TABLES {
            let c = RoughCoating::new(kind(name), alpha, eta);
            let dr = (c.internal_reflectance - r_int).abs();
            worst_r = worst_r.max(dr);
            assert!(dr <= table_tol(name), "{name} α {alpha} η {eta}: R_int {} vs Mitsuba {r_int}", c.internal_reflectance);
            for (k, t) in [1usize, 8, 20, 40, 63].into_iter().zip(ts) {
                let got = c.transmittance(k as f32 / (RES - 1) as f32);
                worst_t = worst_t.max((got - t).abs());
                assert!((got - t).abs() <= table_tol(name), "{name} α {alpha} η {eta} μ {k}/63: T {got} vs Mitsuba {t}");
            }
        }
        eprintln!("largest differences from Mitsuba's tables: R_int {worst_r:e}, T {worst_t:e}");
    }

    /// Mitsuba 3.9.1's `eval` (divided by `cos θi`) and `pdf` of `roughplastic` (scalar_rgb, `si.wi` = our
    /// `wo`): (distribution, α, int_ior, diffuse_reflectance, nonlinear, θo, φo, θi, φi, f, pdf).
    #[allow(clippy::type_complexity)]
    const MITSUBA_F: [(&str, f32, f32, [f32; 3], bool, f32, f32, f32, f32, [f32; 3], f32); 6] = [
        ("beckmann", 0.1, 1.49, [0.5, 0.5, 0.5], false, 30.0, 0.0, 40.0, 3.0, [3.4076994e-01, 3.4076994e-01, 3.4076994e-01], 4.9105471e-01),
        ("beckmann", 0.1, 1.49, [0.5, 0.5, 0.5], false, 30.0, 0.0, 70.0, 1.0, [1.3439061e-01, 1.3439061e-01, 1.3439061e-01], 1.0040796e-01),
        ("ggx", 0.3, 1.5, [0.9, 0.2, 0.05], true, 60.0, 1.0, 55.0, 4.3, [3.1889516e-01, 1.8072840e-01, 1.6177635e-01], 4.3988752e-01),
        ("ggx", 0.3, 1.5, [0.9, 0.2, 0.05], true, 10.0, 1.0, 80.0, 2.0, [1.5129534e-01, 2.6923788e-02, 9.8640002e-03], 5.2054144e-02),
        ("ggx", 0.05, 1.9, [0.1, 0.3, 0.6], false, 45.0, 0.5, 45.0, 3.6416, [6.8975214e+00, 6.9519589e+00, 7.0336152e+00], 1.2241369e+01),
        ("beckmann", 0.5, 1.33, [0.2, 0.2, 0.2], false, 75.0, 0.0, 20.0, 0.5, [4.6227640e-02, 4.6227640e-02, 4.6227640e-02], 1.9896536e-01),
    ];

    #[test]
    fn f_and_pdf_match_mitsuba() {
        for (name, alpha, int_ior, d, nonlinear, to, po, ti, pi, want_f, want_pdf) in MITSUBA_F {
            let b = Bsdf::RoughPlastic(RoughPlastic::new(
                Microfacet::isotropic(kind(name), alpha, true),
                int_ior / AIR,
                Vec3::from(d),
                Vec3::ONE,
                nonlinear,
            ));
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            let (f, pdf) = b.f_pdf(wo, wi, TransportMode::Radiance);
            // Mitsuba's Beckmann G1 is Walter's rational fit (< 0.35 %), and the tables differ by the quadrature.
            let tol = if name == "ggx" { 2e-3 } else { 8e-3 };
            let want = Vec3::from(want_f);
            assert!(((f - want).abs() - tol * want).max_element() <= 0.0, "{name} α {alpha} θo {to} θi {ti}: f {f} vs Mitsuba {want}");
            assert!((pdf - want_pdf).abs() <= tol * want_pdf, "{name} α {alpha} θo {to} θi {ti}: pdf {pdf} vs Mitsuba {want_pdf}");
        }
    }

    /// White furnace: a white base under a clear coating keeps at most all the light (the sampled albedo, and
    /// `∫f cos θi` by quadrature, which the sampler's mean must equal), a black base only what the coating
    /// reflects; and the weight of each sample is `f·cos θi/pdf_w` with `pdf_w` its exact value.
    #[test]
    fn white_furnace_and_sample_consistency() {
        let mut most = 0.0f64;
        for (name, alpha, visible, eta) in [("ggx", 0.05, true, 1.49f32), ("ggx", 0.3, true, 1.5), ("beckmann", 0.1, true, 1.49), ("beckmann", 0.5, false, 1.33), ("ggx", 0.3, true, 1.0 / 1.5)] {
            for (d, nonlinear) in [(Vec3::ONE, false), (Vec3::ONE, true), (Vec3::ZERO, false)] {
                let b = Bsdf::RoughPlastic(RoughPlastic::new(Microfacet::isotropic(kind(name), alpha, visible), eta, d, Vec3::ONE, nonlinear));
                for t in [0.0f32, 30.0, 60.0, 85.0] {
                    let wo = dir(t, 0.3);
                    let n = 200_000u64;
                    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                    for i in 0..n {
                        let mut s = crate::sampler::Sampler::for_key(44, i, 0);
                        if let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) {
                            let wi = smp.wi_local;
                            assert!(!smp.delta && wi.z > 0.0);
                            if i % 16 == 0 {
                                assert_eq!(smp.pdf_w.to_bits(), b.pdf_w(wo, wi).to_bits());
                                let want = b.f(wo, wi, TransportMode::Radiance) * wi.z / smp.pdf_w;
                                assert!((smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6));
                            }
                            let w = f64::from(smp.weight.x);
                            sum += w;
                            sum2 += w * w;
                        }
                    }
                    let mean = sum / n as f64;
                    let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                    let integral = integrate_sphere(|wi| b.f(wo, wi, TransportMode::Radiance).x * wi.z.abs());
                    let what = format!("{name} α {alpha} visible {visible} η {eta} R {} nonlinear {nonlinear} θo {t}", d.x);
                    assert!((mean - integral).abs() <= 5.0 * se + 3e-3 * integral, "{what}: sampled {mean} ± {se} vs ∫ {integral}");
                    assert!(integral <= 1.0 + 2e-3, "{what}: albedo ∫ {integral}");
                    if d == Vec3::ZERO {
                        // The coating alone: at most its Fresnel reflectance at wo (shadowing only loses).
                        let smooth = f64::from(fresnel_dielectric(wo.z, eta).0);
                        assert!(integral <= 1.0 - f64::from(RoughCoating::new(kind(name), alpha, eta).transmittance(wo.z)) + 0.02 && integral < smooth + 0.15, "{what}: ∫ {integral}");
                    }
                    most = most.max(integral);
                }
            }
        }
        eprintln!("largest roughplastic albedo: {most}");
    }
}
