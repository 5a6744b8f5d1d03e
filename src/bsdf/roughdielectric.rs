//! Mitsuba's `roughdielectric`: rough glass, a microfacet interface that reflects and refracts (Mitsuba 3.9.1
//! src/bsdfs/roughdielectric.cpp; Walter et al. 2007, "Microfacet Models for Refraction through Rough
//! Surfaces"). Both lobes are non-delta; the same on both sides (`wo.z > 0` is outside, the interior of
//! index `eta = int_ior/ext_ior` relative to the exterior is −z).
//!
//! With `η` the index of `wi`'s side over `wo`'s when they lie on opposite sides (`eta` for `wo` outside,
//! `1/eta` inside), the microfacet normal `m` of a pair is the half vector, on the +z side,
//! `m ∝ ±(wo + wi)` (reflection, Walter 2007 eq. 13) or `m ∝ ±(wo + η wi)` (refraction, eq. 16), and
//!
//! - reflection `f = R·F(wo·m)·D(m)·G1(wo, m)·G1(wi, m)/(4 |cos θo| |cos θi|)` (eq. 20),
//! - refraction `f = T·s·(1 − F(wo·m))·D(m)·G1(wo)·G1(wi)·η²·|wo·m||wi·m| / (|cos θo||cos θi| (wo·m + η wi·m)²)`
//!   (eq. 21), `s = 1/η²` for radiance and 1 for importance (Mitsuba's "missing term", the `1/η²` of
//!   `super::dielectric`: radiance transport is not symmetric under refraction, importance is),
//!
//! `F` the dielectric Fresnel reflectance, `R`/`T` `specular_reflectance`/`specular_transmittance`, and
//! `G1(v, m) = 0` unless `v·m` has the sign of `cos θv` (a microfacet is seen from the side of the surface
//! the direction lies on).
//!
//! Sampling (Mitsuba's `sample`): a normal `m` from the distribution for `wo` mirrored through the origin
//! to the +z side (visible normals, or `D(m)·cos θm` with Walter's roughness scaled by `1.2 − 0.2·√|cos θo|`,
//! Walter 2007 §5.3), then reflection with probability `F(wo·m)`, refraction otherwise. Its density is
//! `pdf_m(m)·F·1/(4|wi·m|)` or `pdf_m(m)·(1 − F)·η²|wi·m|/(wo·m + η wi·m)²` (the Jacobians of eqs. 14
//! and 17); a sample whose direction lands on the side the other lobe covers (reflected below the surface,
//! refracted back) is lost (`None`), as Mitsuba gives it weight 0, so `pdf_w` is exactly the density of
//! `sample` and integrates to at most 1. Nothing divides by a cosine: `G1/|cos|` comes from
//! [`Microfacet::g1_over_cos_unmasked`] of the direction mirrored to +z (`G1` depends on `tan²θ` alone).
//!
//! ```toml
//! bsdf = { type = "roughdielectric", distribution = "ggx", alpha = 0.05, int_ior = "water" }
//! # or alpha_u / alpha_v (anisotropic), sample_visible (default true); defaults as Mitsuba: beckmann, alpha
//! # 0.1, int_ior "bk7" (1.5046), ext_ior "air"; specular_reflectance, specular_transmittance RGB in [0, 1]
//! # (default 1)
//! ```

use super::ior::{relative_eta, AIR, BK7};
use super::microfacet::{self, Microfacet, MicrofacetType};
use super::{fresnel_dielectric, non_delta_sample, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `roughdielectric`. `distribution`, `specular_reflectance` and `specular_transmittance` are the
/// parameters Mitsuba lets a texture drive; nothing is derived from them at construction.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughDielectric {
    pub distribution: Microfacet,
    /// `int_ior / ext_ior`.
    pub eta: f32,
    pub specular_reflectance: Vec3,
    pub specular_transmittance: Vec3,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "roughdielectric",
    keys: &[
        "distribution",
        "alpha",
        "alpha_u",
        "alpha_v",
        "sample_visible",
        "int_ior",
        "ext_ior",
        "specular_reflectance",
        "specular_transmittance",
    ],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    Ok(Bsdf::RoughDielectric(RoughDielectric {
        distribution: microfacet::from_props(&p, MicrofacetType::Beckmann)?,
        eta: relative_eta(&p, BK7, AIR)?,
        specular_reflectance: p.reflectance_or("specular_reflectance", Vec3::ONE)?,
        specular_transmittance: p.reflectance_or("specular_transmittance", Vec3::ONE)?,
    }))
}

/// The microfacet normal of a pair of directions and what the formulas need of it.
struct Pair {
    m: Vec3,
    reflect: bool,
    /// `η`: the index of `wi`'s side over `wo`'s, for refraction (`eta` with `wo` outside, `1/eta` inside).
    eta_rel: f32,
    wo_m: f32,
    wi_m: f32,
}

impl RoughDielectric {
    /// The distribution normals are drawn from for `wo`: Walter's widened one without visible normals.
    #[inline]
    fn sampling_distribution(&self, cos_theta_o: f32) -> Microfacet {
        if self.distribution.sample_visible {
            self.distribution
        } else {
            self.distribution.scaled(1.2 - 0.2 * cos_theta_o.abs().sqrt())
        }
    }

    /// The half vector of `(wo, wi)` on the +z side, or `None` where a microfacet cannot connect them (the
    /// sides `wo·m`, `wi·m` disagree with `cos θo`, `cos θi`: `G1 = 0`).
    #[inline]
    fn pair(&self, wo: Vec3, wi: Vec3) -> Option<Pair> {
        let reflect = wo.z * wi.z > 0.0;
        let eta_rel = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let m = if reflect { wo + wi } else { wo + wi * eta_rel }.try_normalize()?;
        let m = if m.z < 0.0 { -m } else { m };
        let (wo_m, wi_m) = (wo.dot(m), wi.dot(m));
        (wo_m * wo.z > 0.0 && wi_m * wi.z > 0.0).then_some(Pair { m, reflect, eta_rel, wo_m, wi_m })
    }
}

/// `w` refracted at the microfacet `m` (Mitsuba's `refract`): `(w·m·η_ti + cos θt)·m − η_ti·w`, with
/// `w_m = w·m` and `(cos θt, η_ti)` from [`fresnel_dielectric`]`(w·m, η)` (`cos θt` signed) (Walter 2007
/// eq. 40).
#[inline]
pub(super) fn refract(w: Vec3, m: Vec3, w_m: f32, cos_t: f32, eta_ti: f32) -> Vec3 {
    (w_m * eta_ti + cos_t) * m - eta_ti * w
}

/// `v` on the +z side (`G1` and the visible normals are written there).
#[inline]
fn up(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, v.z.abs())
}

impl Model for RoughDielectric {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        let Some(Pair { m, reflect, eta_rel, wo_m, wi_m }) = self.pair(wo, wi) else {
            return (Vec3::ZERO, 0.0);
        };
        let md = &self.distribution;
        let d = md.d(m);
        let f_r = fresnel_dielectric(wo_m, self.eta).0;
        let g1o = md.g1_over_cos_unmasked(up(wo));
        // Density of the normal: D_wo(m) = D·G1(wo)·|wo·m|/|cos θo|, or D_s(m)·cos θm.
        let pdf_m = if md.sample_visible { d * g1o * wo_m.abs() } else { self.sampling_distribution(wo.z).d(m) * m.z };
        let g = g1o * md.g1_over_cos_unmasked(up(wi));
        if reflect {
            let pdf = pdf_m * f_r / (4.0 * wi_m.abs());
            (self.specular_reflectance * (f_r * d * g * 0.25), pdf)
        } else {
            let denom = wo_m + eta_rel * wi_m;
            // |∂ωm/∂ωi| = η²|wi·m|/(wo·m + η wi·m)².
            let jacobian = eta_rel * eta_rel * wi_m.abs() / (denom * denom);
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta_rel * eta_rel),
                TransportMode::Importance => 1.0,
            };
            let f = self.specular_transmittance * (scale * (1.0 - f_r) * d * g * wo_m.abs() * jacobian);
            (f, pdf_m * (1.0 - f_r) * jacobian)
        }
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Importance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if !(self.eta > 0.0 && self.eta.is_finite()) {
            return None;
        }
        // The normal for wo mirrored through the origin to +z (Mitsuba's `mulsign(wi, cos θi)`).
        let wo_up = if wo.z > 0.0 { wo } else { -wo };
        let m = self.sampling_distribution(wo.z).sample_normal(wo_up, u_dir);
        let wo_m = wo.dot(m);
        if !(wo_m * wo.z > 0.0) {
            return None; // a normal facing away from wo (only D·cos sampling draws them): G1(wo, m) = 0
        }
        let (f_r, cos_t, _, eta_ti) = fresnel_dielectric(wo_m, self.eta);
        let reflect = u_lobe < f_r;
        let wi = if reflect {
            2.0 * wo_m * m - wo // Walter 2007 eq. 13
        } else {
            refract(wo, m, wo_m, cos_t, eta_ti)
        }
        .try_normalize()?;
        // A reflection below the surface or a refraction back to wo's side: G1(wi, m) = 0, lost.
        if (wi.z * wo.z > 0.0) != reflect {
            return None;
        }
        non_delta_sample(self, wo, wi, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    fn has_non_delta(&self) -> bool {
        self.specular_reflectance.max_element() > 0.0 || self.specular_transmittance.max_element() > 0.0
    }
    fn anisotropic(&self) -> bool {
        self.distribution.is_anisotropic()
    }

    fn transmits(&self) -> bool {
        true
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
        v.param("specular_transmittance", ParamMut::Rgb(&mut self.specular_transmittance));
        self.distribution.visit_params(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use crate::sampling::chi2::integrate_sphere;

    fn glass(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, sample_visible: bool, eta: f32) -> Bsdf {
        Bsdf::RoughDielectric(RoughDielectric {
            distribution: Microfacet { kind, alpha_u, alpha_v, sample_visible },
            eta,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
        })
    }

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    /// `Bsdf::eval` of Mitsuba 3.9.1 (scalar_rgb, `mi.load_dict` of a `roughdielectric`, `BSDFContext()` in
    /// radiance mode and `TransportMode.Importance`) divided by `|cos θ|` of the sampled direction, printed
    /// for these configurations: (distribution, α_u, α_v, int_ior, θo, φo, θi, φi, radiance, importance).
    /// Mitsuba's `si.wi` is our `wo`.
    const MITSUBA: [(&str, f32, f32, f32, f32, f32, f32, f32, f32, f32); 8] = [
        ("ggx", 0.3, 0.3, 1.5, 30.0, 0.0, 40.0, 3.0, 4.6185790e-02, 4.6185790e-02),
        ("ggx", 0.3, 0.3, 1.5, 30.0, 0.0, 160.0, 3.0, 8.0644692e+00, 1.8135007e+01),
        ("ggx", 0.1, 0.4, 1.33, 60.0, 1.0, 130.0, 4.5, 4.1172196e-02, 7.2789174e-02),
        ("ggx", 0.2, 0.2, 1.5, 140.0, 0.5, 20.0, 3.5, 5.4070197e-02, 2.4044520e-02),
        ("ggx", 0.2, 0.2, 1.5, 140.0, 0.5, 135.0, 3.8, 2.6364409e+00, 2.6364409e+00),
        ("beckmann", 0.3, 0.3, 1.5, 30.0, 0.0, 150.0, 3.0, 5.0751791e-01, 1.1412829e+00),
        ("beckmann", 0.5, 0.15, 1.5, 50.0, 2.0, 160.0, 5.3, 1.2967650e-02, 2.9161054e-02),
        ("beckmann", 0.2, 0.2, 1.5, 150.0, 0.2, 45.0, 3.34, 4.7812190e+01, 2.1261638e+01),
    ];

    #[test]
    fn f_matches_mitsuba() {
        for (name, au, av, eta, to, po, ti, pi, radiance, importance) in MITSUBA {
            let kind = if name == "ggx" { MicrofacetType::Ggx } else { MicrofacetType::Beckmann };
            let b = glass(kind, au, av, true, eta / super::AIR);
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            // Mitsuba's Beckmann G1 is Walter's rational fit (< 0.35 % each, two of them).
            let tol = if kind == MicrofacetType::Ggx { 2e-4 } else { 8e-3 };
            for (mode, want) in [(TransportMode::Radiance, radiance), (TransportMode::Importance, importance)] {
                let got = b.f(wo, wi, mode).x;
                assert!((got - want).abs() <= tol * want + 1e-6, "{name} ({au}, {av}) θo {to} θi {ti} {mode:?}: {got} vs Mitsuba {want}");
            }
        }
    }

    #[test]
    fn refraction_is_reciprocal_between_the_modes_and_reflection_symmetric() {
        let mut s = Sampler::for_key(41, 0, 0);
        let mut worst = 0.0f32;
        for b in [glass(MicrofacetType::Ggx, 0.2, 0.2, true, 1.5), glass(MicrofacetType::Beckmann, 0.1, 0.5, false, 1.33)] {
            for _ in 0..5000 {
                let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
                let wi = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
                // The adjoint: importance from wo to wi is radiance from wi to wo (Veach 1997 eq. 5.21). The
                // two evaluations rebuild the half vector from either end in f32, and F near total internal
                // reflection is steep (1 − F → 0 at grazing microfacet incidence): they agree to 1e-3 relative
                // where f > 10⁻³, and to 10⁻⁶ where it is smaller.
                let (a, c) = (b.f(wo, wi, TransportMode::Importance), b.f(wi, wo, TransportMode::Radiance));
                if a.x > 1e-3 {
                    worst = worst.max((a.x - c.x).abs() / a.x);
                }
                assert!((a - c).abs().max_element() <= 1e-3 * a.max_element() + 1e-6, "{b:?} {wo} {wi}: {a} vs {c}");
                if wo.z * wi.z > 0.0 {
                    assert_eq!(b.f(wo, wi, TransportMode::Radiance), b.f(wo, wi, TransportMode::Importance));
                    let (a, c) = (b.f(wo, wi, TransportMode::Radiance), b.f(wi, wo, TransportMode::Radiance));
                    assert!((a - c).abs().max_element() <= 1e-4 * a.max_element() + 1e-9, "{b:?} {wo} {wi}: {a} vs {c}");
                }
            }
        }
        eprintln!("largest relative difference of the adjoint pair: {worst:e}");
    }

    #[test]
    fn sample_weight_is_f_cos_over_pdf_and_pdf_is_pdf_w() {
        let cases = [
            glass(MicrofacetType::Ggx, 0.05, 0.05, true, 1.5),
            glass(MicrofacetType::Ggx, 0.3, 0.1, true, 1.33),
            glass(MicrofacetType::Beckmann, 0.4, 0.4, true, 1.5),
            glass(MicrofacetType::Beckmann, 0.2, 0.6, false, 1.5),
            glass(MicrofacetType::Ggx, 0.5, 0.5, false, 1.0 / 1.5),
        ];
        for (k, b) in cases.iter().enumerate() {
            let (mut reflected, mut refracted) = (0, 0);
            for i in 0..20_000u64 {
                let mut s = Sampler::for_key(42, k as u64, i);
                let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), mode) else { continue };
                    let wi = smp.wi_local;
                    assert!(!smp.delta && (wi.length() - 1.0).abs() < 1e-5);
                    assert_eq!(smp.pdf_w.to_bits(), b.pdf_w(wo, wi).to_bits(), "{b:?}");
                    let want = b.f(wo, wi, mode) * wi.z.abs() / smp.pdf_w;
                    assert!((smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6), "{b:?}: {} vs {want}", smp.weight);
                    if wi.z * wo.z > 0.0 {
                        reflected += 1;
                    } else {
                        refracted += 1;
                    }
                }
            }
            assert!(reflected > 500 && refracted > 5000, "{b:?}: {reflected} reflected, {refracted} refracted");
        }
    }

    /// White furnace in importance mode (no `1/η²`): the sampler's mean weight equals the integrated
    /// albedo `∫f|cos θi|`, at most 1, and about 1 − (what single scattering loses to shadowing) for smooth
    /// glass; in radiance mode the refracted part carries `1/η²` (the sampled and integrated values still
    /// agree).
    #[test]
    fn white_furnace() {
        let mut worst: (f32, String) = (0.0, String::new());
        for (kind, au, av, visible) in [
            (MicrofacetType::Ggx, 0.05, 0.05, true),
            (MicrofacetType::Ggx, 0.3, 0.3, true),
            (MicrofacetType::Beckmann, 0.3, 0.3, false),
            (MicrofacetType::Beckmann, 0.1, 0.5, true),
            (MicrofacetType::Ggx, 0.8, 0.8, true),
        ] {
            for eta in [1.5f32, 1.0 / 1.33] {
                let b = glass(kind, au, av, visible, eta);
                for t in [0.0f32, 40.0, 75.0, 110.0, 160.0] {
                    let wo = dir(t, 0.3);
                    for mode in [TransportMode::Importance, TransportMode::Radiance] {
                        let n = 200_000u64;
                        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                        for i in 0..n {
                            let mut s = Sampler::for_key(43, i, 0);
                            if let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), mode) {
                                let w = f64::from(smp.weight.x);
                                sum += w;
                                sum2 += w * w;
                            }
                        }
                        let mean = sum / n as f64;
                        let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                        let integral = integrate_sphere(|wi| b.f(wo, wi, mode).x * wi.z.abs());
                        let what = format!("{kind:?} α ({au}, {av}) visible {visible} η {eta} θo {t} {mode:?}");
                        assert!((mean - integral).abs() <= 5.0 * se + 3e-3 * integral, "{what}: sampled {mean} ± {se} vs ∫ {integral}");
                        if mode == TransportMode::Importance {
                            assert!(mean <= 1.0 + 5.0 * se && integral <= 1.0 + 2e-3, "{what}: albedo {mean} ∫ {integral}");
                            if au < 0.1 {
                                assert!(mean > 0.97, "{what}: albedo {mean}");
                            }
                            if integral as f32 > worst.0 {
                                worst = (integral as f32, what);
                            }
                        }
                    }
                }
            }
        }
        eprintln!("largest importance albedo: {} ({})", worst.0, worst.1);
    }

    #[test]
    fn lobes_flags_and_grazing() {
        let b = glass(MicrofacetType::Beckmann, 0.1, 0.1, true, 1.5);
        assert!(b.transmits() && b.chooses_lobe() && b.has_non_delta() && !b.has_delta());
        let black = Bsdf::RoughDielectric(RoughDielectric {
            distribution: Microfacet::isotropic(MicrofacetType::Ggx, 0.1, true),
            eta: 1.5,
            specular_reflectance: Vec3::ZERO,
            specular_transmittance: Vec3::ZERO,
        });
        assert!(!black.has_non_delta());
        // Coloured lobes: each sample carries its lobe's colour.
        let tinted = Bsdf::RoughDielectric(RoughDielectric {
            distribution: Microfacet::isotropic(MicrofacetType::Ggx, 0.1, true),
            eta: 1.5,
            specular_reflectance: Vec3::new(1.0, 0.5, 0.25),
            specular_transmittance: Vec3::new(0.2, 0.4, 0.8),
        });
        let wo = dir(20.0, 0.0);
        let r = tinted.sample(wo, 0.0, Vec2::new(0.3, 0.6), TransportMode::Importance).unwrap();
        let t = tinted.sample(wo, 0.99, Vec2::new(0.3, 0.6), TransportMode::Importance).unwrap();
        assert!(r.wi_local.z > 0.0 && (r.weight / r.weight.x - Vec3::new(1.0, 0.5, 0.25)).abs().max_element() < 1e-6);
        assert!(t.wi_local.z < 0.0 && (t.weight / t.weight.z - Vec3::new(0.25, 0.5, 1.0)).abs().max_element() < 1e-6);
    }
}
