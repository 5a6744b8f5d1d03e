//! Mitsuba 3's `pplastic` (src/bsdfs/pplastic.cpp, v3.9.1), its polarised plastic (Baek et al. 2018), as its
//! RGB variants evaluate it: without polarisation its Mueller matrices reduce to Fresnel reflectances, and the
//! BSDF is a rough specular lobe added to an attenuated Lambertian one (no coating model, unlike
//! [`super::roughplastic`]). One-sided, as Mitsuba's:
//!
//! `f(wo, wi) = R_s·F(wo·h)·D(h)·G1(wo)·G1(wi)/(4 cos θo cos θi) + R_d·(1 − F(cos θo))·(1 − F(cos θi))/π`,
//!
//! `F` the dielectric Fresnel reflectance of `η` (`eta`, or `int_ior/ext_ior`), `D` and `G1` the microfacet
//! distribution's (Beckmann by default, GGX; isotropic or anisotropic, [`super::microfacet`]). Sampling
//! chooses the specular lobe with Mitsuba's fixed probability `w = s/(d + s)` of the reflectances' means
//! ([`super::plastic`]'s `specular_sampling_weight`) and samples `roughconductor`'s distribution of reflected
//! normals, else a cosine-weighted direction: `pdf_w = w·pdf_spec + (1 − w)·cos θi/π` (samples reflected
//! below the surface are lost, `∫pdf_w ≤ 1`, as Mitsuba).
//!
//! ```toml
//! bsdf = { type = "pplastic", diffuse_reflectance = [0.05, 0.03, 0.1], alpha = 0.06 }
//! # defaults as Mitsuba: distribution "beckmann", alpha 0.1, sample_visible true, int_ior "polypropylene"
//! # (1.49), ext_ior "air" (or eta = int_ior/ext_ior instead of both), diffuse_reflectance 0.5,
//! # specular_reflectance 1
//! ```

use std::f32::consts::FRAC_1_PI;

use super::ior::{relative_eta, AIR};
use super::microfacet::{self, Microfacet, MicrofacetType};
use super::plastic::{specular_sampling_weight, POLYPROPYLENE};
use super::{fresnel_dielectric, non_delta_sample, roughconductor, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;

/// Mitsuba's `pplastic` in its RGB (unpolarised) form.
#[derive(Clone, Debug, PartialEq)]
pub struct PPlastic {
    pub distribution: Microfacet,
    /// `η = η_int/η_ext`.
    pub eta: f32,
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    /// Mitsuba's `specular_sampling_weight`, from the reflectances at construction (from their textures'
    /// means, as Mitsuba's `parameters_changed`).
    specular_weight: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "pplastic",
    keys: &["distribution", "alpha", "alpha_u", "alpha_v", "sample_visible", "int_ior", "ext_ior", "eta", "diffuse_reflectance", "specular_reflectance"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let distribution = microfacet::from_props(&p, MicrofacetType::Beckmann)?;
    // Mitsuba: `eta` replaces int_ior/ext_ior and is refused beside int_ior; beside ext_ior it is taken and
    // ext_ior left unread (its check names "ext_iot"), which is done here too.
    let eta = if p.has("eta") {
        if p.has("int_ior") {
            return Err(PropError::new("eta", "give either `eta` or `int_ior` and `ext_ior`, not both (as Mitsuba)"));
        }
        p.positive_or("eta", 1.0, "the relative index of refraction eta")?
    } else {
        relative_eta(&p, POLYPROPYLENE, AIR)?
    };
    let diffuse_reflectance = p.reflectance_or("diffuse_reflectance", Vec3::splat(0.5))?;
    let specular_reflectance = p.reflectance_or("specular_reflectance", Vec3::ONE)?;
    Ok(Bsdf::PPlastic(PPlastic::new(distribution, eta, diffuse_reflectance, specular_reflectance)))
}

impl PPlastic {
    #[must_use]
    pub fn new(distribution: Microfacet, eta: f32, diffuse_reflectance: Vec3, specular_reflectance: Vec3) -> Self {
        let specular_weight = specular_sampling_weight(diffuse_reflectance, specular_reflectance);
        Self { distribution, eta, diffuse_reflectance, specular_reflectance, specular_weight }
    }
}

impl Model for PPlastic {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let w = self.specular_weight;
        let t = |cos: f32| 1.0 - fresnel_dielectric(cos, self.eta).0;
        let diffuse = self.diffuse_reflectance * (t(wo.z) * t(wi.z) * FRAC_1_PI);
        let diffuse_pdf = (1.0 - w) * wi.z * FRAC_1_PI;
        let Some(h) = (wo + wi).try_normalize() else {
            return (diffuse, diffuse_pdf);
        };
        let md = &self.distribution;
        let d = md.d(h);
        let g1o = md.g1_over_cos(wo, h);
        // Mitsuba's pdf: 0 where h is on the far side of either direction.
        let spec_pdf = if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
            0.0
        } else if md.sample_visible {
            0.25 * d * g1o
        } else {
            0.25 * d * h.z / wo.dot(h)
        };
        let g = g1o * md.g1_over_cos(wi, h);
        let spec = if g == 0.0 { Vec3::ZERO } else { self.specular_reflectance * (fresnel_dielectric(wo.dot(h), self.eta).0 * 0.25 * d * g) };
        (spec + diffuse, w * spec_pdf + diffuse_pdf)
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Radiance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.specular_weight { roughconductor::sample_wi(&self.distribution, wo, u_dir)? } else { square_to_cosine_hemisphere(u_dir) };
        non_delta_sample(self, wo, wi, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    fn has_non_delta(&self) -> bool {
        self.diffuse_reflectance.max_element() > 0.0 || self.specular_reflectance.max_element() > 0.0
    }
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.diffuse_reflectance
    }
    /// Mitsuba's pplastic takes its reflectances and roughness as textures; the sampling weight stays the
    /// means'.
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("diffuse_reflectance", ParamMut::Rgb(&mut self.diffuse_reflectance));
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
        self.distribution.visit_params(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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

    /// Mitsuba 3.9.1's `eval` (divided by `cos θi`) and `pdf` of `pplastic` (scalar_rgb, `si.wi` = our `wo`,
    /// int_ior as given, ext_ior 1): (distribution, α_u, α_v, η, diffuse_reflectance, specular_reflectance,
    /// θo, φo, θi, φi, f, pdf).
    #[allow(clippy::type_complexity)]
    const MITSUBA_F: [(&str, f32, f32, f32, [f32; 3], [f32; 3], f32, f32, f32, f32, [f32; 3], f32); 6] = [
        ("beckmann", 0.1, 0.1, 1.49, [0.5, 0.5, 0.5], [1.0, 1.0, 1.0], 30.0, 0.0, 40.0, 3.0, [3.3242729e-01, 3.3242729e-01, 3.3242729e-01], 2.3646071e+00),
        ("beckmann", 0.1, 0.1, 1.49, [0.5, 0.5, 0.5], [1.0, 1.0, 1.0], 30.0, 0.0, 30.0, 3.14159265, [5.7342189e-01, 5.7342189e-01, 5.7342189e-01], 6.2177658e+00),
        ("ggx", 0.3, 0.3, 1.5, [0.9, 0.2, 0.05], [0.8, 0.7, 0.6], 60.0, 1.0, 55.0, 4.3, [3.6762890e-01, 1.6322303e-01, 1.0715546e-01], 8.4665596e-01),
        ("ggx", 0.06, 0.06, 1.49, [0.05, 0.03, 0.1], [1.0, 1.0, 1.0], 45.0, 0.5, 45.0, 3.6416, [2.1699423e+00, 2.1641829e+00, 2.1843410e+00], 2.9477749e+01),
        ("beckmann", 0.5, 0.5, 1.33, [0.2, 0.2, 0.2], [1.0, 1.0, 1.0], 75.0, 0.0, 20.0, 0.5, [5.0323319e-02, 5.0323319e-02, 5.0323319e-02], 9.2364602e-02),
        ("ggx", 0.1, 0.4, 1.7, [0.3, 0.6, 0.1], [1.0, 1.0, 1.0], 50.0, 0.7, 35.0, 4.0, [1.1123651e-01, 1.9224267e-01, 5.7232403e-02], 3.1263667e-01),
    ];

    #[test]
    fn f_and_pdf_match_mitsuba() {
        for (name, au, av, eta, d, s, to, po, ti, pi, want_f, want_pdf) in MITSUBA_F {
            let md = Microfacet { kind: kind(name), alpha_u: au, alpha_v: av, sample_visible: true };
            let b = Bsdf::PPlastic(PPlastic::new(md, eta, Vec3::from(d), Vec3::from(s)));
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            let (f, pdf) = b.f_pdf(wo, wi, TransportMode::Radiance);
            // Mitsuba's Beckmann G1 is Walter's rational fit (< 0.35 %).
            let tol = if name == "ggx" { 1e-4 } else { 4e-3 };
            let want = Vec3::from(want_f);
            assert!(((f - want).abs() - tol * want).max_element() <= 0.0, "{name} α {au}/{av} θo {to} θi {ti}: f {f} vs Mitsuba {want}");
            assert!((pdf - want_pdf).abs() <= tol * want_pdf, "{name} α {au}/{av} θo {to} θi {ti}: pdf {pdf} vs Mitsuba {want_pdf}");
        }
    }

    /// White furnace: the albedo never exceeds 1 (the specular lobe reflects at most `F`, the diffuse one
    /// `(1 − F)`), the sampler's mean weight equals `∫f cos θi` by quadrature, and each sample's weight is
    /// `f·cos θi/pdf_w` with `pdf_w` its exact value.
    #[test]
    fn white_furnace_and_sample_consistency() {
        let mut most = 0.0f64;
        for (name, au, av, visible, eta) in [("ggx", 0.05, 0.05, true, 1.49f32), ("beckmann", 0.1, 0.1, true, 1.49), ("beckmann", 0.5, 0.5, false, 1.33), ("ggx", 0.1, 0.4, true, 1.7)] {
            let md = Microfacet { kind: kind(name), alpha_u: au, alpha_v: av, sample_visible: visible };
            for d in [Vec3::ONE, Vec3::ZERO] {
                let b = Bsdf::PPlastic(PPlastic::new(md, eta, d, Vec3::ONE));
                for t in [0.0f32, 30.0, 60.0, 85.0] {
                    let wo = dir(t, 0.3);
                    let n = 200_000u64;
                    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                    for i in 0..n {
                        let mut s = crate::sampler::Sampler::for_key(45, i, 0);
                        if let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) {
                            let wi = smp.wi_local;
                            assert!(!smp.delta && !smp.pass_through && wi.z > 0.0);
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
                    let what = format!("{name} α {au}/{av} visible {visible} η {eta} R {} θo {t}", d.x);
                    assert!((mean - integral).abs() <= 5.0 * se + 3e-3 * integral, "{what}: sampled {mean} ± {se} vs ∫ {integral}");
                    assert!(integral <= 1.0 + 2e-3, "{what}: albedo ∫ {integral}");
                    if d == Vec3::ZERO {
                        // The specular lobe alone: at most the smooth surface's Fresnel reflectance plus what
                        // roughness spreads from other facets (shadowing only loses).
                        assert!(integral < f64::from(fresnel_dielectric(wo.z, eta).0) + 0.15, "{what}: ∫ {integral}");
                    }
                    most = most.max(integral);
                }
            }
        }
        eprintln!("largest pplastic albedo: {most}");
    }
}
