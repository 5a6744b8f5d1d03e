//! Mitsuba 3's `principledthin`: the thin Disney principled BSDF (Mitsuba 3.9.1 src/bsdfs/principledthin.cpp;
//! Burley 2015, "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering"), a surface with no
//! inside: both sides scatter alike (a configuration with `wo` below is mirrored through the origin, as
//! Mitsuba's `mulsign(si.wi, cos θi)`), and what crosses goes on unbent. Four lobes, the terms shared with
//! `principled` taken from `super::principled_lobes`:
//!
//! - the **specular reflection**, `spec_trans·F·D·G/(4 cos θo cos θi)`, GGX of `roughness` and `anisotropic`
//!   (Mitsuba's `calc_dist_params`), `F` the dielectric Fresnel reflectance of `eta` at the half vector blended
//!   by `spec_tint` toward Schlick's approximation of the tinted `R₀(η)` (Mitsuba's `thin_fresnel`:
//!   `principled_lobes::main_fresnel` without a metallic share);
//! - the **specular transmission**, `spec_trans·base_color·(1 − F)·D′·G′/(4 cos θo cos θi)`, the half vector
//!   that of `wo` and `wi` mirrored through the tangent plane, the GGX distribution of the roughness scaled by
//!   `0.65·η − 0.35` (Burley 2015 fig. 15);
//! - the **diffuse reflection** of `principled` (Burley's diffuse, retro-reflection, `flatness` toward the fake
//!   subsurface, the sheen), weighted by `(1 − spec_trans)(1 − diff_trans/2)`;
//! - the **diffuse transmission**, Lambertian, `(1 − spec_trans)·diff_trans/2·base_color/π`.
//!
//! Sampling picks specular reflection, specular transmission, diffuse reflection or diffuse transmission with
//! probabilities ∝ `spec_trans·r_sr/2`, `spec_trans·r_st/2`, `(1 − spec_trans)(1 − diff_trans/2)·r_dr` and
//! `(1 − spec_trans)·diff_trans/2·r_dt` (`r_*` the four sampling rates); the specular lobes draw a GGX visible
//! normal (the transmission's direction is the reflection mirrored through the tangent plane), the diffuse ones a
//! cosine-weighted direction on their side. `pdf_w` is that mixture; samples that land on the wrong side or on
//! a microfacet that cannot connect the pair are lost, as in Mitsuba. Nothing refracts (η = 1 across the
//! surface), so radiance and importance transport alike. The reflection is reciprocal; the specular
//! transmission, as Mitsuba's, is not where only one of the pair sees the microfacet from the side it needs
//! (`mac_mic_compatibility` is not symmetric across the sheet).
//!
//! ```toml
//! bsdf = { type = "principledthin", base_color = [0.7, 0.1, 0.1], roughness = 0.15, spec_tint = 0.1,
//!          anisotropic = 0.5, spec_trans = 0.8, diff_trans = 0.3, eta = 1.33 }
//! # defaults as Mitsuba: base_color 0.5, roughness 0.5, eta 1.5, every weight 0, the sampling rates
//! # specular_reflectance_sampling_rate, specular_transmittance_sampling_rate,
//! # diffuse_reflectance_sampling_rate and diffuse_transmittance_sampling_rate 1. base_color and every weight
//! # in [0, 1], diff_trans in [0, 2], eta > 0; textures for all of them but the rates.
//! ```

use std::f32::consts::FRAC_1_PI;

use super::microfacet::Microfacet;
use super::principled::{compatible, distribution, up};
use super::principled_lobes::{main_fresnel, DiffuseTerms};
use super::{fresnel_dielectric, non_delta_sample, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;

/// Mitsuba's `principledthin`. The public fields are its parameters (a texture may drive any but the sampling
/// rates); the two GGX distributions are derived from `roughness`, `anisotropic` and `eta`.
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThin {
    pub base_color: Vec3,
    pub roughness: f32,
    pub anisotropic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    /// `diff_trans` as written, in `[0, 2]` (the lobes read half of it).
    pub diff_trans: f32,
    /// The index of the thin sheet relative to its surroundings.
    pub eta: f32,
    pub rates: ThinSamplingRates,
    /// Whether the specular transmission lobe exists (Mitsuba's `m_has_spec_trans`: `spec_trans` given as a
    /// texture or as a number other than 0); likewise for the diffuse transmission.
    pub has_spec_trans: bool,
    pub has_diff_trans: bool,
    /// Derived: the reflection's GGX distribution, and the transmission's of the scaled roughness.
    reflection: Microfacet,
    transmission: Microfacet,
}

/// The relative sampling rates of the four lobes (Mitsuba's, default 1 each).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinSamplingRates {
    pub specular_reflectance: f32,
    pub specular_transmittance: f32,
    pub diffuse_reflectance: f32,
    pub diffuse_transmittance: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "principledthin",
    keys: &[
        "base_color",
        "roughness",
        "anisotropic",
        "spec_trans",
        "eta",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "flatness",
        "diff_trans",
        "specular_reflectance_sampling_rate",
        "specular_transmittance_sampling_rate",
        "diffuse_reflectance_sampling_rate",
        "diffuse_transmittance_sampling_rate",
    ],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let unit = |key: &str, default: f32| p.in_range_or(key, default, 0.0, 1.0, key);
    let rate = |key: &str| {
        let r = p.float_or(key, 1.0)?;
        if r < 0.0 {
            return Err(PropError::new(key, format!("a sampling rate must be ≥ 0, got {r}")));
        }
        Ok(r)
    };
    let spec_trans = unit("spec_trans", 0.0)?;
    let diff_trans = p.in_range_or("diff_trans", 0.0, 0.0, 2.0, "diff_trans")?;
    let rates = ThinSamplingRates {
        specular_reflectance: rate("specular_reflectance_sampling_rate")?,
        specular_transmittance: rate("specular_transmittance_sampling_rate")?,
        diffuse_reflectance: rate("diffuse_reflectance_sampling_rate")?,
        diffuse_transmittance: rate("diffuse_transmittance_sampling_rate")?,
    };
    Ok(Bsdf::PrincipledThin(
        PrincipledThin {
            base_color: p.reflectance_or("base_color", Vec3::splat(0.5))?,
            roughness: unit("roughness", 0.5)?,
            anisotropic: unit("anisotropic", 0.0)?,
            spec_trans,
            spec_tint: unit("spec_tint", 0.0)?,
            sheen: unit("sheen", 0.0)?,
            sheen_tint: unit("sheen_tint", 0.0)?,
            flatness: unit("flatness", 0.0)?,
            diff_trans,
            eta: p.positive_or("eta", 1.5, "the relative index eta")?,
            rates,
            // Mitsuba's `get_flag`: a texture, or a number other than 0.
            has_spec_trans: p.is_textured("spec_trans") || spec_trans != 0.0,
            has_diff_trans: p.is_textured("diff_trans") || diff_trans != 0.0,
            reflection: distribution(0.5, 0.0),
            transmission: distribution(0.5, 0.0),
        }
        .derived(),
    ))
}

/// The lobe probabilities (Mitsuba's `sample` and `pdf`), normalised.
struct LobeChoice {
    spec_reflect: f32,
    spec_trans: f32,
    diffuse_reflect: f32,
    diffuse_trans: f32,
}

impl PrincipledThin {
    /// A thin principled BSDF of these parameters, its distributions derived.
    #[must_use]
    pub fn derived(mut self) -> Self {
        self.reflection = distribution(self.roughness, self.anisotropic);
        // Burley 2015 fig. 15: the transmission's roughness scaled by the index.
        self.transmission = distribution((0.65 * self.eta - 0.35) * self.roughness, self.anisotropic);
        self
    }

    /// `spec_trans` (0 without the lobe) and `diff_trans/2` (0 without the lobe), as the lobes read them.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        (if self.has_spec_trans { self.spec_trans } else { 0.0 }, if self.has_diff_trans { 0.5 * self.diff_trans } else { 0.0 })
    }

    fn choice(&self, spec_trans: f32, diff_trans: f32) -> Option<LobeChoice> {
        let r = &self.rates;
        let spec_reflect = spec_trans * r.specular_reflectance * 0.5;
        let spec_t = spec_trans * r.specular_transmittance * 0.5;
        let diffuse_reflect = r.diffuse_reflectance * (1.0 - spec_trans) * (1.0 - diff_trans);
        let diffuse_trans = r.diffuse_transmittance * (1.0 - spec_trans) * diff_trans;
        let total = spec_reflect + spec_t + diffuse_reflect + diffuse_trans;
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let k = 1.0 / total;
        Some(LobeChoice { spec_reflect: spec_reflect * k, spec_trans: spec_t * k, diffuse_reflect: diffuse_reflect * k, diffuse_trans: diffuse_trans * k })
    }
}

/// The configuration seen from the front: both directions mirrored through the origin when `wo` is below (the
/// sheet is symmetric; Mitsuba's `mulsign(·, cos θi)`), and the sign that undoes it.
#[inline]
fn from_front(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, f32) {
    if wo.z > 0.0 {
        (wo, wi, 1.0)
    } else {
        (-wo, -wi, -1.0)
    }
}

impl Model for PrincipledThin {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> (Vec3, f32) {
        let (wo, wi, _) = from_front(wo, wi);
        let reflect = wi.z > 0.0;
        let (spec_trans, diff_trans) = self.weights();
        // The half vector of wo and wi mirrored to wo's side: the transmission is a reflection turned over.
        let Some(h) = (wo + up(wi)).try_normalize() else {
            return (Vec3::ZERO, 0.0);
        };
        let compatible = compatible(h, wo, wi, reflect);
        let wo_h = wo.dot(h);
        let mut f = Vec3::ZERO;
        if spec_trans > 0.0 && compatible {
            let f_d = fresnel_dielectric(wo_h, self.eta).0;
            let md = if reflect { &self.reflection } else { &self.transmission };
            // D·G/(4 cos θo cos θi), G Smith's separable masking (both directions see h's front: `compatible`).
            let dg = 0.25 * md.d(h) * md.g1_over_cos_unmasked(wo) * md.g1_over_cos_unmasked(up(wi));
            f += if reflect {
                main_fresnel(f_d, wo_h, self.eta, true, 0.0, self.spec_tint, 0.0, self.base_color) * (spec_trans * dg)
            } else {
                self.base_color * (spec_trans * (1.0 - f_d) * dg)
            };
        }
        if reflect && spec_trans < 1.0 && diff_trans < 1.0 {
            let brdf = (1.0 - spec_trans) * (1.0 - diff_trans);
            let terms = DiffuseTerms {
                base_color: self.base_color,
                roughness: self.roughness,
                flatness: self.flatness,
                sheen: self.sheen,
                sheen_tint: self.sheen_tint,
                sheen_weight: brdf,
                brdf,
            };
            f += terms.f(wo, wi, h);
        }
        if !reflect && spec_trans < 1.0 && diff_trans > 0.0 {
            f += self.base_color * ((1.0 - spec_trans) * diff_trans * FRAC_1_PI);
        }

        let Some(p) = self.choice(spec_trans, diff_trans) else {
            return (f, 0.0);
        };
        let mut pdf = 0.0;
        if compatible {
            // |∂h/∂wi| = 1/(4|wi′·h|), wi′ = wi mirrored to wo's side.
            let jacobian = 0.25 / up(wi).dot(h).abs();
            pdf += if reflect {
                p.spec_reflect * self.reflection.pdf_normal(wo, h)
            } else {
                p.spec_trans * self.transmission.pdf_normal(wo, h)
            } * jacobian;
        }
        pdf += if reflect { p.diffuse_reflect } else { p.diffuse_trans } * wi.z.abs() * FRAC_1_PI;
        (f, if pdf.is_finite() { pdf } else { 0.0 })
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Importance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let (wo_f, _, sign) = from_front(wo, Vec3::Z);
        let (spec_trans, diff_trans) = self.weights();
        let p = self.choice(spec_trans, diff_trans)?;
        // Mitsuba's order along u_lobe: specular reflection, specular transmission, diffuse reflection, diffuse
        // transmission.
        let wi = if u_lobe < p.spec_reflect + p.spec_trans {
            let reflection = u_lobe < p.spec_reflect;
            let md = if reflection { &self.reflection } else { &self.transmission };
            let m = md.sample_normal(wo_f, u_dir);
            let r = (2.0 * wo_f.dot(m) * m - wo_f).try_normalize()?;
            // Reflected above; the transmission turned over to the other side.
            if r.z <= 0.0 {
                return None;
            }
            let wi = if reflection { r } else { Vec3::new(r.x, r.y, -r.z) };
            if !compatible(m, wo_f, wi, reflection) {
                return None;
            }
            wi
        } else if u_lobe < p.spec_reflect + p.spec_trans + p.diffuse_reflect {
            square_to_cosine_hemisphere(u_dir)
        } else if p.diffuse_trans > 0.0 {
            -square_to_cosine_hemisphere(u_dir)
        } else {
            return None;
        };
        non_delta_sample(self, wo, wi * sign, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    /// The diffuse reflection or the specular lobes: some lobe always has weight.
    fn has_non_delta(&self) -> bool {
        true
    }
    fn anisotropic(&self) -> bool {
        self.reflection.is_anisotropic() || self.transmission.is_anisotropic()
    }

    fn transmits(&self) -> bool {
        self.has_spec_trans || self.has_diff_trans
    }

    /// Mitsuba's `eval_diffuse_reflectance` of `principledthin`: the base colour.
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.base_color
    }

    /// Mitsuba's `principledthin` takes a texture for each of these (`eta` unbounded there, > 0 here).
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("base_color", ParamMut::Rgb(&mut self.base_color));
        v.param("roughness", ParamMut::Float(&mut self.roughness));
        v.param("anisotropic", ParamMut::Float(&mut self.anisotropic));
        v.param("spec_trans", ParamMut::Float(&mut self.spec_trans));
        v.param("eta", ParamMut::Float(&mut self.eta));
        v.param("spec_tint", ParamMut::Float(&mut self.spec_tint));
        v.param("sheen", ParamMut::Float(&mut self.sheen));
        v.param("sheen_tint", ParamMut::Float(&mut self.sheen_tint));
        v.param("flatness", ParamMut::Float(&mut self.flatness));
        v.param("diff_trans", ParamMut::Float(&mut self.diff_trans));
    }

    /// The distributions from the (textured) roughness, anisotropy and index.
    fn params_changed(&mut self) {
        *self = self.clone().derived();
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The thin principled BSDF a scene file's table (TOML) describes, through the plugin's constructor.
    pub(crate) fn parse(text: &str) -> Bsdf {
        let table: toml::Table = text.parse().unwrap();
        build(Props::new(&table, PLUGIN.keys, Vec::new())).unwrap_or_else(|e| panic!("{text}: {e}"))
    }

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    /// The parameter sets of [`MITSUBA`], as scene-file tables (`aniso` is Mitsuba's documentation example).
    pub(crate) const SETS: [(&str, &str); 5] = [
        ("diffuse", "base_color = [0.8, 0.4, 0.2]\nroughness = 0.7\nsheen = 0.5\nsheen_tint = 0.4\nflatness = 0.3"),
        ("difftrans", "base_color = [0.3, 0.6, 0.9]\nroughness = 0.4\ndiff_trans = 0.8"),
        ("glass", "base_color = [0.9, 0.9, 0.7]\nspec_trans = 0.9\nroughness = 0.3\neta = 1.5"),
        ("aniso", "base_color = [0.7, 0.1, 0.1]\nroughness = 0.15\nspec_tint = 0.1\nanisotropic = 0.5\nspec_trans = 0.8\ndiff_trans = 0.3\neta = 1.33"),
        (
            "rates",
            "base_color = [0.5, 0.5, 0.2]\nroughness = 0.5\nspec_trans = 0.5\ndiff_trans = 1.2\neta = 1.7\nspec_tint = 0.6\n\
             specular_reflectance_sampling_rate = 0.5\nspecular_transmittance_sampling_rate = 2.0\n\
             diffuse_transmittance_sampling_rate = 3.0\ndiffuse_reflectance_sampling_rate = 0.7",
        ),
    ];

    /// Mitsuba 3.9.1's `principledthin` (scalar_rgb, `mi.load_dict` of the sets above, `si.wi` = our `wo`, the
    /// shading frame the identity): `eval` divided by `|cos θ|` of the other direction (the same in radiance
    /// and importance mode) and `pdf`: (set, θo, φo, θi, φi, f, pdf).
    #[allow(clippy::type_complexity)]
    const MITSUBA: [(&str, f32, f32, f32, f32, [f32; 3], f32); 19] = [
        ("diffuse", 30.0, 0.0, 40.0, 3.0, [2.3693873e-01, 1.1849760e-01, 5.9277039e-02], 2.4383950e-01),
        ("diffuse", 70.0, 0.5, 20.0, 2.0, [2.6082426e-01, 1.3044064e-01, 6.5248825e-02], 2.9911345e-01),
        ("diffuse", 150.0, 0.5, 120.0, 2.0, [2.5078747e-01, 1.2540320e-01, 6.2711060e-02], 1.5915494e-01),
        ("difftrans", 30.0, 0.0, 40.0, 3.0, [5.7297409e-02, 1.1459482e-01, 1.7189221e-01], 1.4630371e-01),
        ("difftrans", 30.0, 0.0, 140.0, 3.0, [3.8197186e-02, 7.6394372e-02, 1.1459155e-01], 9.7535804e-02),
        ("difftrans", 160.0, 1.0, 20.0, 2.0, [3.8197190e-02, 7.6394379e-02, 1.1459155e-01], 1.1964538e-01),
        ("glass", 30.0, 0.0, 35.0, 3.2, [3.5147467e-01, 3.5147467e-01, 3.4510857e-01], 3.1642566e+00),
        ("glass", 30.0, 0.0, 150.0, 3.0, [1.2111843e+01, 1.2111843e+01, 9.4203234e+00], 6.0802698e+00),
        ("glass", 30.0, 0.0, 145.0, 0.1, [1.2899432e-03, 1.2899432e-03, 1.0032892e-03], 6.1158551e-04),
        ("glass", 140.0, 0.5, 35.0, 3.5, [3.3146541e+00, 3.3146541e+00, 2.5780642e+00], 1.5783769e+00),
        ("glass", 140.0, 0.5, 135.0, 3.8, [2.4999614e-01, 2.4999614e-01, 2.4363306e-01], 1.6715184e+00),
        ("aniso", 40.0, 0.3, 45.0, 3.0, [3.8192540e-02, 5.6910343e-03, 5.6910343e-03], 4.2583358e-02),
        ("aniso", 40.0, 0.3, 135.0, 3.3, [6.5725312e-02, 9.3893316e-03, 9.3893316e-03], 3.7354060e-02),
        ("aniso", 20.0, 1.2, 160.0, 4.0, [1.5691087e-01, 2.2415841e-02, 2.2415841e-02], 1.1188865e-01),
        ("aniso", 110.0, 1.2, 60.0, 5.0, [6.9458825e-03, 9.9226891e-04, 9.9226891e-04], 4.8734900e-03),
        ("rates", 30.0, 0.0, 35.0, 3.0, [8.7256156e-02, 8.7256156e-02, 4.8163723e-02], 1.1989576e-01),
        ("rates", 30.0, 0.0, 160.0, 3.3, [5.9602714e-01, 5.9602714e-01, 2.3841088e-01], 8.2617950e-01),
        ("rates", 150.0, 1.0, 30.0, 4.0, [1.0861636e+00, 1.0861636e+00, 4.3446544e-01], 1.3112657e+00),
        ("rates", 150.0, 1.0, 155.0, 4.2, [8.4348030e-02, 8.4348030e-02, 4.6149872e-02], 1.2736668e-01),
    ];

    pub(crate) fn set(name: &str) -> Bsdf {
        parse(SETS.iter().find(|(n, _)| *n == name).unwrap().1)
    }

    #[test]
    fn f_and_pdf_match_mitsuba() {
        let mut worst = 0.0f32;
        for (name, to, po, ti, pi, want, want_pdf) in MITSUBA {
            let b = set(name);
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let (f, pdf) = b.f_pdf(wo, wi, mode);
                let want = Vec3::from(want);
                let rel = ((f - want).abs() / want).max_element().max((pdf - want_pdf).abs() / want_pdf);
                worst = worst.max(rel);
                assert!(rel <= 2e-4, "{name} θo {to} θi {ti} {mode:?}: f {f} pdf {pdf} vs Mitsuba {want} {want_pdf}");
            }
        }
        eprintln!("largest relative difference from Mitsuba's eval and pdf: {worst:e}");
    }

    fn err(text: &str) -> PropError {
        let table: toml::Table = text.parse().unwrap();
        build(Props::new(&table, PLUGIN.keys, Vec::new())).err().unwrap_or_else(|| panic!("{text}: accepted"))
    }

    fn of(b: Bsdf) -> PrincipledThin {
        let Bsdf::PrincipledThin(p) = b else { panic!("{b:?}") };
        p
    }

    /// Mitsuba's defaults, its flags and the keys' checks.
    #[test]
    fn keys_read_as_mitsuba_reads_them() {
        let p = of(parse(""));
        assert_eq!((p.base_color, p.roughness, p.spec_trans, p.diff_trans, p.eta), (Vec3::splat(0.5), 0.5, 0.0, 0.0, 1.5));
        assert!(!p.has_spec_trans && !p.has_diff_trans && !Bsdf::PrincipledThin(p.clone()).transmits());
        assert_eq!((p.reflection.alpha_u, p.reflection.alpha_v), (0.25, 0.25));
        // (0.65·1.5 − 0.35)·0.5 = 0.3125, squared.
        assert!((p.transmission.alpha_u - 0.3125f32 * 0.3125).abs() < 1e-7);
        assert!(of(parse("diff_trans = 2")).has_diff_trans && of(parse("spec_trans = 0.1")).has_spec_trans);
        assert!(parse("diff_trans = 0.5").transmits());
        assert_eq!(err("diff_trans = 2.5").key, "diff_trans");
        assert_eq!(err("roughness = 1.5").key, "roughness");
        assert_eq!(err("base_color = [1, 2, 0]").key, "base_color");
        assert_eq!(err("diffuse_transmittance_sampling_rate = -1").key, "diffuse_transmittance_sampling_rate");
        assert_eq!(err("eta = 0").key, "eta");
        // A textured roughness or index: the distributions follow.
        let mut b = parse("roughness = 0.2\nspec_trans = 0.5");
        b.visit_params(&mut SetFloat("eta", 2.0));
        b.visit_params(&mut SetFloat("roughness", 0.8));
        b.params_changed();
        let p = of(b);
        assert!((p.reflection.alpha_u - 0.64).abs() < 1e-6);
        assert!((p.transmission.alpha_u - (0.95f32 * 0.8).powi(2)).abs() < 1e-6);
    }

    /// A visitor that sets the number `key` to a value.
    struct SetFloat(&'static str, f32);

    impl ParamVisitor for SetFloat {
        fn param(&mut self, key: &'static str, value: ParamMut<'_>) {
            if key == self.0 {
                value.set(|| unreachable!(), || self.1);
            }
        }
        fn nested(&mut self, _: &'static str, _: &mut Bsdf) {}
    }
}
