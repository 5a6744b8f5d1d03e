//! Mitsuba 0.6's `phong`: the modified, energy-normalised Phong model (Phong 1975, Lafortune & Willems
//! 1994; Mitsuba 0.6 src/bsdfs/phong.cpp, which Mitsuba 3 dropped). One-sided, as 0.6's (black unless `wo`
//! and `wi` are both above the surface):
//!
//! `f(wo, wi) = k·(R_s·(n + 2)/(2π)·max(0, wi·r(wo))ⁿ + R_d/π)`,
//!
//! `r(wo)` the mirror direction of `wo`, `n` the `exponent`; reciprocal, since `wi·r(wo) = wo·r(wi)`. The
//! lobe integrates to 1 against `cos θi` at normal incidence only: away from it part of the lobe falls below
//! the horizon and its cosine shrinks, so the specular albedo drops towards grazing (≈ `cos θo` far from
//! it, 0.6's documented energy loss); it never exceeds 1. `k` is 0.6's `ensureEnergyConservation`: when
//! the largest channel of `R_s + R_d` (of the textures' maxima) exceeds 1, both are scaled by `0.99/max`
//! (`BSDF::ensureEnergyConservation`, src/librender/bsdf.cpp), else `k = 1`.
//!
//! Sampling (0.6's `Phong::sample`): the glossy lobe with probability `w = Y(R̄_s)/(Y(R̄_d) + Y(R̄_s))`
//! (`m_specularSamplingWeight`: luminances of the mean reflectances), drawing `cos α = u^{1/(n+1)}` around
//! `r(wo)` (density `(n + 1)/(2π)·cos^n α`; directions below the surface are lost), else a cosine-weighted
//! direction; `pdf_w = w·(n + 1)/(2π)·max(0, wi·r(wo))ⁿ + (1 − w)·cos θi/π`.
//!
//! ```toml
//! bsdf = { type = "phong", exponent = 60, specular_reflectance = 0.3, diffuse_reflectance = [0.5, 0.2, 0.1] }
//! # defaults as Mitsuba 0.6: exponent 30, specular_reflectance 0.2, diffuse_reflectance 0.5,
//! # ensure_energy_conservation true; exponent and both reflectances may be textures
//! ```
//!
//! A textured `exponent` is read as a number (`eval_1`: an RGB bitmap's luminance; 0.6 averaged the channels).

use std::f32::consts::{FRAC_1_PI, PI};

use super::{non_delta_sample, reflect_z, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Frame, Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;
use crate::texture::luminance;

/// Mitsuba 0.6's `phong`. `exponent` and the reflectances are the parameters a texture may drive; the
/// energy scale and the sampling weight are derived at construction (from the textures' maxima and means,
/// as 0.6's `configure`).
#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    pub exponent: f32,
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    /// `k`: 0.6's `ensureEnergyConservation` scale of both reflectances.
    pub energy_scale: f32,
    /// 0.6's `m_specularSamplingWeight`.
    specular_weight: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "phong",
    keys: &["exponent", "specular_reflectance", "diffuse_reflectance", "ensure_energy_conservation"],
    nested: &[],
    build,
};

/// 0.6's default exponent.
const DEFAULT_EXPONENT: f32 = 30.0;

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let exponent = p.float_or("exponent", DEFAULT_EXPONENT)?;
    if exponent < 0.0 {
        return Err(PropError::new("exponent", format!("the Phong exponent must be ≥ 0, got {exponent}")));
    }
    let r = Reflectances::from_props(&p)?;
    Ok(Bsdf::Phong(Phong::new(exponent, r.diffuse, r.specular, r.energy_scale)))
}

/// The diffuse and specular reflectances of 0.6's `phong` and `ward` (`diffuse_reflectance` default 0.5,
/// `specular_reflectance` default 0.2) and their `ensure_energy_conservation` scale (default on).
pub(super) struct Reflectances {
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub energy_scale: f32,
}

impl Reflectances {
    pub(super) fn from_props(p: &Props<'_, Bsdf>) -> Result<Self, PropError> {
        let diffuse = p.reflectance_or("diffuse_reflectance", Vec3::splat(0.5))?;
        let specular = p.reflectance_or("specular_reflectance", Vec3::splat(0.2))?;
        let energy_scale = if p.bool_or("ensure_energy_conservation", true)? {
            let max = |key, constant| p.texture_max(key).unwrap_or(constant);
            energy_scale(max("specular_reflectance", specular) + max("diffuse_reflectance", diffuse))
        } else {
            1.0
        };
        Ok(Self { diffuse, specular, energy_scale })
    }
}

/// 0.6's `BSDF::ensureEnergyConservation(tex1, tex2, …, 1)`: `0.99/m` when the largest channel `m` of the
/// summed maxima exceeds 1, else 1.
#[must_use]
pub(super) fn energy_scale(summed_max: Vec3) -> f32 {
    let m = summed_max.max_element();
    if m > 1.0 {
        0.99 / m
    } else {
        1.0
    }
}

/// 0.6's `m_specularSamplingWeight` of `phong` and `ward`: `Y(s)/(Y(d) + Y(s))` of the mean reflectances'
/// luminances (0 when both are black, where 0.6 divides by zero; nothing is sampled then).
#[must_use]
pub(super) fn specular_sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
    let (d, s) = (luminance(diffuse), luminance(specular));
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.0
    }
}

impl Phong {
    /// The BSDF of these parameters (`energy_scale`: see [`Phong::energy_scale`]; the sampling weight is
    /// derived from the reflectances given here).
    #[must_use]
    pub fn new(exponent: f32, diffuse_reflectance: Vec3, specular_reflectance: Vec3, energy_scale: f32) -> Self {
        let specular_weight = specular_sampling_weight(diffuse_reflectance, specular_reflectance);
        Self { exponent, diffuse_reflectance, specular_reflectance, energy_scale, specular_weight }
    }

    /// The exponent as evaluated: a texture may give a negative value, read as 0 (a uniform lobe).
    #[inline]
    fn n(&self) -> f32 {
        self.exponent.max(0.0)
    }
}

/// `cos α = wi·r(wo)`, the cosine between `wi` and the mirror direction of `wo`.
#[inline]
fn cos_alpha(wo: Vec3, wi: Vec3) -> f32 {
    wi.dot(reflect_z(wo))
}

impl Model for Phong {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let n = self.n();
        let c = cos_alpha(wo, wi);
        let lobe = if c > 0.0 { c.powf(n) * (0.5 * FRAC_1_PI) } else { 0.0 };
        let f = (self.specular_reflectance * ((n + 2.0) * lobe) + self.diffuse_reflectance * FRAC_1_PI) * self.energy_scale;
        let w = self.specular_weight;
        (f, w * (n + 1.0) * lobe + (1.0 - w) * wi.z * FRAC_1_PI)
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Radiance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.specular_weight {
            // A direction at angle α from r(wo), cos α = u^{1/(n+1)}, uniform in azimuth.
            let e = 1.0 / (self.n() + 1.0);
            let cos_a = u_dir.y.powf(e);
            let sin_a = (1.0 - u_dir.y.powf(2.0 * e)).max(0.0).sqrt();
            let (sin_p, cos_p) = (2.0 * PI * u_dir.x).sin_cos();
            let wi = Frame::from_normal(reflect_z(wo)).to_world(Vec3::new(sin_a * cos_p, sin_a * sin_p, cos_a));
            if wi.z <= 0.0 {
                return None;
            }
            wi
        } else {
            square_to_cosine_hemisphere(u_dir)
        };
        non_delta_sample(self, wo, wi, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    fn has_non_delta(&self) -> bool {
        self.energy_scale > 0.0 && (self.diffuse_reflectance.max_element() > 0.0 || self.specular_reflectance.max_element() > 0.0)
    }

    /// 0.6's `getDiffuseReflectance` of `phong`: its (scaled) diffuse reflectance.
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.diffuse_reflectance * self.energy_scale
    }

    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("exponent", ParamMut::Float(&mut self.exponent));
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
        v.param("diffuse_reflectance", ParamMut::Rgb(&mut self.diffuse_reflectance));
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::props::Textured;
    use crate::sampler::Sampler;

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    /// The mean of the sample weights' red channel at `wo` over `n` samples (a lost sample counts 0), and
    /// its standard error.
    pub(in crate::bsdf) fn sampled_albedo(b: &Bsdf, wo: Vec3, n: u64) -> (f64, f64) {
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let mut s = Sampler::for_key(45, i, 0);
            if let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) {
                let w = f64::from(smp.weight.x);
                sum += w;
                sum2 += w * w;
            }
        }
        let mean = sum / n as f64;
        (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }

    /// Generated by `scripts/phong-ward-albedo.py`: (exponent, θo in degrees, albedo of the glossy lobe).
    const PHONG_ALBEDO: &[(f32, f32, f64)] = &[
        (0.0, 0.0, 1.0000000),
        (0.0, 30.0, 0.9330127),
        (0.0, 60.0, 0.7500000),
        (0.0, 80.0, 0.5868241),
        (0.0, 89.0, 0.5087262),
        (1.0, 0.0, 1.0000004),
        (1.0, 30.0, 0.8808429),
        (1.0, 60.0, 0.6089979),
        (1.0, 80.0, 0.4099453),
        (1.0, 89.0, 0.3270846),
        (10.0, 0.0, 1.0000033),
        (10.0, 30.0, 0.8660306),
        (10.0, 60.0, 0.5047365),
        (10.0, 80.0, 0.2280562),
        (10.0, 89.0, 0.1319600),
        (30.0, 0.0, 1.0000021),
        (30.0, 30.0, 0.8660272),
        (30.0, 60.0, 0.5000734),
        (30.0, 80.0, 0.1895973),
        (30.0, 89.0, 0.0812876),
        (200.0, 0.0, 1.0000004),
        (200.0, 30.0, 0.8660258),
        (200.0, 60.0, 0.5000002),
        (200.0, 80.0, 0.1737984),
        (200.0, 89.0, 0.0377539),
        (2000.0, 0.0, 1.0000000),
        (2000.0, 30.0, 0.8660254),
        (2000.0, 60.0, 0.5000000),
        (2000.0, 80.0, 0.1736482),
        (2000.0, 89.0, 0.0202325),
    ];

    /// The mean sample weight of the glossy lobe alone (specular 1, diffuse 0) is its directional albedo by
    /// an independent quadrature of 0.6's formula; with both lobes (specular 0.6, diffuse 0.3) it is
    /// `0.6·E + 0.3`, so the lobe choice is weighed right too. And what the table says of 0.6's model: the
    /// glossy albedo is 1 at normal incidence for every exponent (`(n+2)/(n+1)·E[cos α]`), never above 1,
    /// and lost towards grazing (≈ cos θo for a sharp lobe).
    #[test]
    fn albedo_matches_quadrature() {
        let mut worst = 0.0f64;
        for &(n, t, e) in PHONG_ALBEDO {
            let wo = dir(t, 0.7);
            for (kd, ks) in [(0.0f32, 1.0f32), (0.3, 0.6)] {
                let b = Bsdf::Phong(Phong::new(n, Vec3::splat(kd), Vec3::splat(ks), 1.0));
                let (mean, se) = sampled_albedo(&b, wo, 100_000);
                let want = f64::from(ks) * e + f64::from(kd);
                worst = worst.max((mean - want).abs() / se.max(1e-9));
                assert!((mean - want).abs() <= 5.0 * se + 2e-5, "n {n} θo {t} kd {kd} ks {ks}: sampled {mean} ± {se} vs quadrature {want}");
            }
            assert!(e <= 1.0 + 1e-5, "n {n} θo {t}: E {e}");
            if t == 0.0 {
                assert!((e - 1.0).abs() < 1e-5, "n {n}: E(0) = {e}");
            }
            if t >= 80.0 {
                assert!(e < 0.6, "n {n} θo {t}: E {e}");
            }
        }
        eprintln!("phong: the largest |sampled − quadrature|/σ: {worst:.2}");
    }

    fn build_from(text: &str, textured: Vec<(&str, Textured)>) -> Result<Phong, PropError> {
        let table: toml::Table = text.parse().unwrap();
        match (PLUGIN.build)(Props::new(&table, PLUGIN.keys, Vec::new()).with_textures(textured))? {
            Bsdf::Phong(p) => Ok(p),
            other => panic!("{other:?}"),
        }
    }

    /// 0.6's defaults, its `ensureEnergyConservation` (from the textures' maxima), its luminance-weighted
    /// lobe choice, and the exponent's check.
    #[test]
    fn keys_defaults_and_energy_scale_follow_mitsuba_06() {
        let p = build_from("", Vec::new()).unwrap();
        assert_eq!((p.exponent, p.specular_reflectance, p.diffuse_reflectance, p.energy_scale), (30.0, Vec3::splat(0.2), Vec3::splat(0.5), 1.0));
        assert!((p.specular_weight - 0.2 / 0.7).abs() < 1e-6);
        let p = build_from("specular_reflectance = 0.6\ndiffuse_reflectance = [0.7, 0.1, 0.1]", Vec::new()).unwrap();
        assert!((p.energy_scale - 0.99 / 1.3).abs() < 1e-6 && (p.diffuse_reflectance(Vec3::Z).x - 0.7 * 0.99 / 1.3).abs() < 1e-6);
        let p = build_from("specular_reflectance = 0.6\ndiffuse_reflectance = 0.7\nensure_energy_conservation = false", Vec::new()).unwrap();
        assert_eq!(p.energy_scale, 1.0);
        // A textured reflectance: its maximum decides the scale, its mean the sampling weight.
        let t = Textured { mean: Vec3::splat(0.3), mean_1: 0.3, max: Vec3::new(0.9, 0.2, 0.2), min: Vec3::ZERO };
        let p = build_from("specular_reflectance = { type = \"bitmap\" }", vec![("specular_reflectance", t)]).unwrap();
        assert!((p.energy_scale - 0.99 / 1.4).abs() < 1e-6 && (p.specular_weight - 0.3 / 0.8).abs() < 1e-6);
        // Luminance weights: a green specular against a red diffuse.
        let w = specular_sampling_weight(Vec3::X, Vec3::Y);
        assert!((w - 0.715160 / (0.715160 + 0.212671)).abs() < 1e-6);
        assert_eq!(specular_sampling_weight(Vec3::ZERO, Vec3::ZERO), 0.0);
        assert!(build_from("exponent = -1", Vec::new()).unwrap_err().message.contains("≥ 0"));
        assert!(build_from("exponent = 0", Vec::new()).is_ok());
    }
}
