//! Mitsuba 3's `principled`: the Disney principled BSDF (Mitsuba 3.9.1 src/bsdfs/principled.cpp, its terms in
//! `super::principled_lobes`; Burley 2012 and 2015). Four lobes, weighted by `brdf = (1 − metallic)(1 −
//! spec_trans)` and `bsdf = (1 − metallic)·spec_trans`:
//!
//! - the **main specular** lobe, GGX (anisotropic by `anisotropic`, `α = roughness²`, the shading frame's
//!   tangent along `α_u`) with Smith's separable masking, reflecting with the Fresnel factor of
//!   `principled_lobes::main_fresnel` (dielectric `F` of `η`, Schlick toward the base colour for the metallic
//!   share and toward its tint for `spec_tint`), on both sides of the surface;
//! - the **specular transmission**, the same microfacets refracting with `√base_color·bsdf·(1 − F)` as
//!   `roughdielectric` does (and its `1/η²` for radiance), present only when `spec_trans` is given and not the
//!   constant 0 (Mitsuba's `get_flag`);
//! - the **clearcoat**, `clearcoat·¼·F_schlick(0.04)·D_GTR1·G1(wo)·G1(wi)` (GTR1 of `α` 0.1 … 0.001 by
//!   `clearcoat_gloss`, GGX masking of α 0.25; no `1/(4 cos θo cos θi)`, as Mitsuba), front side only;
//! - the **diffuse** lobe (Burley's diffuse, retro-reflection, `flatness` toward a fake subsurface) and the
//!   sheen, front side only.
//!
//! From the front (`wo.z > 0`) sampling picks diffuse, clearcoat, transmission or specular reflection with
//! probabilities ∝ `brdf·r_d`, `¼·clearcoat·r_c`, `r_s·bsdf·(1 − F(wo·m))` and `r_s·(1 − bsdf·(1 − F))`
//! (`r_*` the sampling rates; the last two sum to `r_s`, so the diffuse and clearcoat probabilities do not
//! depend on the sampled normal `m`); from behind, reflection with `F` and transmission with `1 − F`, and
//! nothing when `bsdf = 0` (there Mitsuba's `pdf` is not 0 while its `sample` returns nothing: here `pdf_w` is
//! 0, the density of the sampler, as the module conventions require). The main normal is a GGX visible
//! normal for `wo` mirrored to +z; the clearcoat's a GTR1 normal (`D·cos θ`); the diffuse direction
//! cosine-weighted. `pdf_w` is the mixture, each lobe's normal density times its Jacobian; samples that
//! land on the wrong side are lost, as in Mitsuba.
//!
//! ```toml
//! bsdf = { type = "principled", base_color = [0.8, 0.3, 0.1], metallic = 0.7, roughness = 0.2, anisotropic = 0.5,
//!          spec_tint = 0.4, sheen = 0.3, sheen_tint = 0.2, clearcoat = 0.6, clearcoat_gloss = 0.3, spec_trans = 0.4 }
//! # defaults as Mitsuba: base_color 0.5, roughness 0.5, every weight 0, specular 0.5 (η = 1.5) or `eta`
//! # (not both), the sampling rates diffuse_reflectance_sampling_rate, main_specular_sampling_rate and
//! # clearcoat_sampling_rate 1. base_color and every weight in [0, 1], and textures for all of them (not for
//! # eta, specular or the rates).
//! ```

use std::f32::consts::FRAC_1_PI;

use super::microfacet::{Microfacet, MicrofacetType};
use super::principled_lobes::{clearcoat_g1, main_fresnel, schlick, schlick_angle_weight, specular_alphas, DiffuseTerms, Gtr1};
use super::roughdielectric::refract;
use super::{fresnel_dielectric, non_delta_sample, Bsdf, BsdfSample, Model, ParamMut, ParamVisitor, Plugin, TransportMode};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_cosine_hemisphere;

/// Mitsuba's `principled`. The public fields are its parameters (those a texture may drive: every one but
/// `eta` and the sampling rates); the main lobe's distribution is derived from `roughness` and `anisotropic`.
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    pub base_color: Vec3,
    pub roughness: f32,
    pub anisotropic: f32,
    pub metallic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    /// Interior over exterior index (`eta`, or from `specular`).
    pub eta: f32,
    /// `diffuse_reflectance_sampling_rate`, `main_specular_sampling_rate`, `clearcoat_sampling_rate`.
    pub rates: SamplingRates,
    /// Whether the transmission lobe exists (Mitsuba's `m_has_spec_trans`: `spec_trans` given as a texture
    /// or as a number other than 0).
    pub has_spec_trans: bool,
    /// Derived from `roughness` and `anisotropic`: GGX, visible normals.
    distribution: Microfacet,
}

/// The relative sampling rates of the lobes (Mitsuba's, default 1 each).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingRates {
    pub diffuse: f32,
    pub specular: f32,
    pub clearcoat: f32,
}

impl Default for SamplingRates {
    fn default() -> Self {
        Self { diffuse: 1.0, specular: 1.0, clearcoat: 1.0 }
    }
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "principled",
    keys: &[
        "base_color",
        "roughness",
        "anisotropic",
        "metallic",
        "spec_trans",
        "eta",
        "specular",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "flatness",
        "clearcoat",
        "clearcoat_gloss",
        "diffuse_reflectance_sampling_rate",
        "main_specular_sampling_rate",
        "clearcoat_sampling_rate",
    ],
    nested: &[],
    build,
};

/// Mitsuba's default `specular` (η = 1.5).
const DEFAULT_SPECULAR: f32 = 0.5;

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
    // Mitsuba's `get_flag`: a texture, or a number other than 0.
    let has_spec_trans = p.is_textured("spec_trans") || spec_trans != 0.0;
    let eta = match (p.has("eta"), p.has("specular")) {
        (true, true) => return Err(PropError::new("specular", "give either `eta` or `specular`, not both (as Mitsuba)")),
        (true, false) => {
            let eta = p.positive_or("eta", 1.5, "the relative index eta")?;
            // η = 1 cannot refract (Mitsuba's constructor).
            if has_spec_trans && eta == 1.0 {
                1.001
            } else {
                eta
            }
        }
        (false, _) => {
            let specular = unit("specular", DEFAULT_SPECULAR)?;
            eta_of_specular(if has_spec_trans && specular == 0.0 { 1e-3 } else { specular })
        }
    };
    let rates = SamplingRates {
        diffuse: rate("diffuse_reflectance_sampling_rate")?,
        specular: rate("main_specular_sampling_rate")?,
        clearcoat: rate("clearcoat_sampling_rate")?,
    };
    Ok(Bsdf::Principled(Principled {
        base_color: p.reflectance_or("base_color", Vec3::splat(0.5))?,
        roughness: unit("roughness", 0.5)?,
        anisotropic: unit("anisotropic", 0.0)?,
        metallic: unit("metallic", 0.0)?,
        spec_trans,
        spec_tint: unit("spec_tint", 0.0)?,
        sheen: unit("sheen", 0.0)?,
        sheen_tint: unit("sheen_tint", 0.0)?,
        flatness: unit("flatness", 0.0)?,
        clearcoat: unit("clearcoat", 0.0)?,
        clearcoat_gloss: unit("clearcoat_gloss", 0.0)?,
        eta,
        rates,
        has_spec_trans,
        distribution: distribution(0.5, 0.0),
    }
    .derived()))
}

/// The index of Mitsuba's `specular` parameter: `2/(1 − √(0.08·specular)) − 1` (R₀ = 0.08·specular).
fn eta_of_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

/// The main lobes' GGX distribution for these parameters.
pub(super) fn distribution(roughness: f32, anisotropic: f32) -> Microfacet {
    let (alpha_u, alpha_v) = specular_alphas(roughness, anisotropic);
    Microfacet { kind: MicrofacetType::Ggx, alpha_u, alpha_v, sample_visible: true }
}

/// `v` mirrored through the tangent plane to the +z side (`G1` depends on `tan²θ` alone).
#[inline]
pub(super) fn up(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, v.z.abs())
}

/// `wo` mirrored through the origin to the +z side, as the visible normals are drawn (Mitsuba's
/// `mulsign(si.wi, cos θi)`).
#[inline]
pub(super) fn toward_z(wo: Vec3) -> Vec3 {
    if wo.z > 0.0 {
        wo
    } else {
        -wo
    }
}

/// The lobe probabilities at `wo` given the dielectric Fresnel reflectance `f` of the main lobe's normal
/// (Mitsuba's `sample` and `pdf`): (diffuse, clearcoat, transmission, reflection), normalised; `None` where
/// nothing is sampled.
struct LobeChoice {
    diffuse: f32,
    clearcoat: f32,
    transmission: f32,
    reflection: f32,
}

impl Principled {
    /// A principled BSDF of these parameters, its distribution derived.
    #[must_use]
    pub fn derived(mut self) -> Self {
        self.distribution = distribution(self.roughness, self.anisotropic);
        self
    }

    /// `(1 − metallic)(1 − spec_trans)` and `(1 − metallic)·spec_trans` (0 without the transmission lobe).
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let bsdf = if self.has_spec_trans { (1.0 - self.metallic) * self.spec_trans } else { 0.0 };
        ((1.0 - self.metallic) * (1.0 - self.spec_trans), bsdf)
    }

    /// The probabilities of the lobes from `wo` (front side or not) for the dielectric reflectance `f`.
    fn choice(&self, front: bool, f: f32, brdf: f32, bsdf: f32) -> Option<LobeChoice> {
        let r = &self.rates;
        let (reflection, transmission, clearcoat, diffuse) = if front {
            (r.specular * (1.0 - bsdf * (1.0 - f)), if self.has_spec_trans { r.specular * bsdf * (1.0 - f) } else { 0.0 }, 0.25 * self.clearcoat * r.clearcoat, brdf * r.diffuse)
        } else if bsdf > 0.0 {
            (f, 1.0 - f, 0.0, 0.0)
        } else {
            return None; // nothing crosses: Mitsuba's sample refuses a `wo` below the surface
        };
        let total = reflection + transmission + clearcoat + diffuse;
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let k = 1.0 / total;
        Some(LobeChoice { diffuse: diffuse * k, clearcoat: clearcoat * k, transmission: transmission * k, reflection: reflection * k })
    }
}

/// Whether a microfacet `m` (+z side) can connect `wo` and `wi`: both see its front for a reflection, `wi`
/// its back for a refraction, the front being the side `wo` comes from (Mitsuba's `mac_mic_compatibility`).
#[inline]
pub(super) fn compatible(m: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let m = if wo.z > 0.0 { m } else { -m };
    wo.dot(m) > 0.0 && if reflection { wi.dot(m) > 0.0 } else { wi.dot(m) < 0.0 }
}

impl Model for Principled {
    fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        let front = wo.z > 0.0;
        let reflect = wo.z * wi.z > 0.0;
        let (brdf, bsdf) = self.weights();
        // The half vector of the pair (Walter 2007 eqs. 13, 16), on the +z side.
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let Some(h) = (wo + wi * if reflect { 1.0 } else { eta_path }).try_normalize() else {
            return (Vec3::ZERO, 0.0);
        };
        let h = if h.z < 0.0 { -h } else { h };
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let f_d = fresnel_dielectric(wo_h, self.eta).0;
        let compatible = compatible(h, wo, wi, reflect);
        let md = &self.distribution;
        let d = md.d(h);
        let g = md.g1_over_cos_unmasked(up(wo)) * md.g1_over_cos_unmasked(up(wi));

        let mut f = Vec3::ZERO;
        if reflect && compatible && f_d > 0.0 {
            f += main_fresnel(f_d, wo_h, self.eta, front, self.metallic, self.spec_tint, bsdf, self.base_color) * (0.25 * d * g);
        }
        // |∂ωh/∂ωi| of the refraction: η²|wi·h|/(wo·h + η wi·h)².
        let denom = wo_h + eta_path * wi_h;
        let jacobian_t = eta_path * eta_path * wi_h.abs() / (denom * denom);
        if !reflect && self.has_spec_trans && bsdf > 0.0 && compatible && f_d < 1.0 {
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta_path * eta_path),
                TransportMode::Importance => 1.0,
            };
            f += self.base_color.powf(0.5) * (bsdf * scale * (1.0 - f_d) * d * g * wo_h.abs() * jacobian_t);
        }
        if front && reflect {
            if compatible && self.clearcoat > 0.0 {
                let f_cc = schlick(Vec3::splat(0.04), schlick_angle_weight(wo_h, self.eta)).x;
                let d_cc = Gtr1::for_gloss(self.clearcoat_gloss).d(h);
                f += Vec3::splat(self.clearcoat * 0.25 * f_cc * d_cc * clearcoat_g1(wo, h) * clearcoat_g1(wi, h));
            }
            if brdf > 0.0 {
                let terms = DiffuseTerms {
                    base_color: self.base_color,
                    roughness: self.roughness,
                    flatness: self.flatness,
                    sheen: self.sheen,
                    sheen_tint: self.sheen_tint,
                    sheen_weight: 1.0 - self.metallic,
                    brdf,
                };
                f += terms.f(wo, wi, h);
            }
        }

        let Some(p) = self.choice(front, f_d, brdf, bsdf) else {
            return (f, 0.0);
        };
        let mut pdf = 0.0;
        if reflect {
            let jacobian_r = 0.25 / wi_h.abs();
            if compatible {
                pdf += p.reflection * md.pdf_normal(toward_z(wo), h) * jacobian_r;
                if p.clearcoat > 0.0 {
                    pdf += p.clearcoat * Gtr1::for_gloss(self.clearcoat_gloss).pdf(h) * jacobian_r;
                }
            }
            pdf += p.diffuse * wi.z * FRAC_1_PI;
        } else if compatible && p.transmission > 0.0 {
            pdf += p.transmission * md.pdf_normal(toward_z(wo), h) * jacobian_t;
        }
        (f, if pdf.is_finite() { pdf } else { 0.0 })
    }

    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.f_pdf(wo, wi, TransportMode::Importance).1
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let front = wo.z > 0.0;
        let (brdf, bsdf) = self.weights();
        let m = self.distribution.sample_normal(toward_z(wo), u_dir);
        let wo_m = wo.dot(m);
        let (f_d, cos_t, _, eta_ti) = fresnel_dielectric(wo_m, self.eta);
        let p = self.choice(front, f_d, brdf, bsdf)?;
        // Mitsuba's order along u_lobe: diffuse, clearcoat, transmission, reflection. A direction on the side
        // the lobe does not scatter to, or a microfacet that cannot connect the pair, is lost.
        let (wi, reflection) = if u_lobe < p.diffuse {
            (square_to_cosine_hemisphere(u_dir), true)
        } else if u_lobe < p.diffuse + p.clearcoat {
            let m_cc = Gtr1::for_gloss(self.clearcoat_gloss).sample(u_dir);
            let wi = 2.0 * wo.dot(m_cc) * m_cc - wo;
            if !compatible(m_cc, wo, wi, true) {
                return None;
            }
            (wi, true)
        } else if u_lobe < p.diffuse + p.clearcoat + p.transmission {
            (refract(wo, m, wo_m, cos_t, eta_ti), false)
        } else {
            (2.0 * wo_m * m - wo, true)
        };
        let wi = wi.try_normalize()?;
        let main_lobe = u_lobe >= p.diffuse + p.clearcoat;
        if (wi.z * wo.z > 0.0) != reflection || (main_lobe && !compatible(m, wo, wi, reflection)) {
            return None;
        }
        non_delta_sample(self, wo, wi, mode)
    }

    fn chooses_lobe(&self) -> bool {
        true
    }

    /// The main specular lobe reflects on every principled surface.
    fn has_non_delta(&self) -> bool {
        true
    }
    fn anisotropic(&self) -> bool {
        self.distribution.is_anisotropic()
    }

    fn transmits(&self) -> bool {
        self.has_spec_trans
    }

    /// Mitsuba's `eval_diffuse_reflectance` of `principled`: the base colour.
    fn diffuse_reflectance(&self, _wo: Vec3) -> Vec3 {
        self.base_color
    }

    /// Mitsuba's `principled` takes a texture for each of these.
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("base_color", ParamMut::Rgb(&mut self.base_color));
        v.param("roughness", ParamMut::Float(&mut self.roughness));
        v.param("anisotropic", ParamMut::Float(&mut self.anisotropic));
        v.param("metallic", ParamMut::Float(&mut self.metallic));
        v.param("spec_trans", ParamMut::Float(&mut self.spec_trans));
        v.param("spec_tint", ParamMut::Float(&mut self.spec_tint));
        v.param("sheen", ParamMut::Float(&mut self.sheen));
        v.param("sheen_tint", ParamMut::Float(&mut self.sheen_tint));
        v.param("flatness", ParamMut::Float(&mut self.flatness));
        v.param("clearcoat", ParamMut::Float(&mut self.clearcoat));
        v.param("clearcoat_gloss", ParamMut::Float(&mut self.clearcoat_gloss));
    }

    /// The distribution from the (textured) roughness and anisotropy.
    fn params_changed(&mut self) {
        self.distribution = distribution(self.roughness, self.anisotropic);
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The principled BSDF a scene file's table (TOML) describes, through the plugin's constructor.
    pub(crate) fn parse(text: &str) -> Bsdf {
        let table: toml::Table = text.parse().unwrap();
        build(Props::new(&table, PLUGIN.keys, Vec::new())).unwrap_or_else(|e| panic!("{text}: {e}"))
    }

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    /// The parameter sets of [`MITSUBA`], as scene-file tables.
    const SETS: [(&str, &str); 6] = [
        ("diffuse", "base_color = [0.8, 0.4, 0.2]\nroughness = 0.7"),
        ("metal", "base_color = [0.9, 0.6, 0.3]\nmetallic = 1.0\nroughness = 0.3"),
        ("aniso", "base_color = 0.5\nmetallic = 0.6\nroughness = 0.4\nanisotropic = 0.8\nspec_tint = 0.5"),
        ("glass", "base_color = [0.9, 0.9, 0.7]\nspec_trans = 0.9\nroughness = 0.2\neta = 1.5"),
        ("coat", "base_color = [0.2, 0.4, 0.8]\nclearcoat = 0.8\nclearcoat_gloss = 0.6\nroughness = 0.5\nsheen = 0.7\nsheen_tint = 0.5\nflatness = 0.4\nspecular = 0.8"),
        (
            "all",
            "base_color = 1.0\nmetallic = 0.7\nspecular = 0.6\nroughness = 0.2\nspec_tint = 0.4\nanisotropic = 0.5\nsheen = 0.3\nsheen_tint = 0.2\nclearcoat = 0.6\nclearcoat_gloss = 0.3\nspec_trans = 0.4",
        ),
    ];

    /// Mitsuba 3.9.1's `principled` (scalar_rgb, `mi.load_dict` of the sets above, `si.wi` = our `wo`, the
    /// shading frame the identity): `eval` divided by `|cos θ|` of the other direction, in radiance and in
    /// importance mode, and `pdf`: (set, θo, φo, θi, φi, f radiance, f importance, pdf).
    #[allow(clippy::type_complexity)]
    pub(crate) const MITSUBA: [(&str, f32, f32, f32, f32, [f32; 3], [f32; 3], f32); 16] = [
        ("diffuse", 30.0, 0.0, 40.0, 3.0, [2.7376691e-01, 1.4640110e-01, 8.2718190e-02], [2.7376691e-01, 1.4640110e-01, 8.2718190e-02], 2.9828638e-01),
        ("diffuse", 70.0, 0.5, 20.0, 2.0, [2.7510392e-01, 1.4085677e-01, 7.3733196e-02], [2.7510392e-01, 1.4085677e-01, 7.3733196e-02], 2.2229329e-01),
        ("metal", 30.0, 0.0, 35.0, 3.2, [7.6545138e+00, 5.1032752e+00, 2.5520364e+00], [7.6545138e+00, 5.1032752e+00, 2.5520364e+00], 6.9737382e+00),
        ("metal", 60.0, 1.0, 50.0, 4.0, [2.7624660e+00, 1.8555672e+00, 9.4866817e-01], [2.7624660e+00, 1.8555672e+00, 9.4866817e-01], 1.9756430e+00),
        ("aniso", 40.0, 0.3, 45.0, 3.0, [1.0979334e-01, 1.0979334e-01, 1.0979334e-01], [1.0979334e-01, 1.0979334e-01, 1.0979334e-01], 1.3925005e-01),
        ("aniso", 20.0, 1.2, 60.0, 5.0, [7.1535155e-02, 7.1535155e-02, 7.1535155e-02], [7.1535155e-02, 7.1535155e-02, 7.1535155e-02], 5.4443993e-02),
        ("glass", 30.0, 0.0, 40.0, 3.0, [9.0475584e-02, 9.0475584e-02, 8.4110473e-02], [9.0475584e-02, 9.0475584e-02, 8.4110473e-02], 1.6105810e-01),
        ("glass", 30.0, 0.0, 150.0, 3.0, [2.8071700e-02, 2.8071700e-02, 2.4756913e-02], [6.3161314e-02, 6.3161314e-02, 5.5703046e-02], 5.2423462e-02),
        ("glass", 140.0, 0.5, 20.0, 3.5, [1.8783042e-03, 1.8783042e-03, 1.6565086e-03], [8.3480161e-04, 8.3480161e-04, 7.3622584e-04], 9.1881573e-04),
        ("glass", 140.0, 0.5, 135.0, 3.8, [2.8003882e+00, 2.8003882e+00, 2.8003882e+00], [2.8003882e+00, 2.8003882e+00, 2.8003882e+00], 2.2010725e+00),
        ("coat", 30.0, 0.0, 32.0, 3.1, [3.5487275e-01, 4.1165198e-01, 5.2521042e-01], [3.5487275e-01, 4.1165198e-01, 5.2521042e-01], 1.4020052e+00),
        ("coat", 75.0, 0.0, 60.0, 2.5, [1.1653268e-01, 1.9527572e-01, 3.5276175e-01], [1.1653268e-01, 1.9527572e-01, 3.5276175e-01], 1.2073188e-01),
        ("all", 30.0, 0.0, 35.0, 3.0, [2.9882719e+00, 2.9882719e+00, 2.9882719e+00], [2.9882719e+00, 2.9882719e+00, 2.9882719e+00], 2.4680700e+00),
        ("all", 30.0, 0.0, 160.0, 3.3, [1.1437740e-01, 1.1437740e-01, 1.1437740e-01], [2.7874562e-01, 2.7874562e-01, 2.7874562e-01], 1.9696243e-01),
        ("all", 150.0, 1.0, 30.0, 4.0, [2.7743896e-03, 2.7743896e-03, 2.7743896e-03], [1.1384124e-03, 1.1384124e-03, 1.1384124e-03], 8.2169799e-03),
        ("all", 150.0, 1.0, 155.0, 4.2, [7.8133835e-02, 7.8133835e-02, 7.8133835e-02], [7.8133835e-02, 7.8133835e-02, 7.8133835e-02], 5.9015465e-01),
    ];

    pub(crate) fn set(name: &str) -> Bsdf {
        parse(SETS.iter().find(|(n, _)| *n == name).unwrap().1)
    }

    #[test]
    fn f_and_pdf_match_mitsuba() {
        let mut worst = 0.0f32;
        for (name, to, po, ti, pi, radiance, importance, want_pdf) in MITSUBA {
            let b = set(name);
            let (wo, wi) = (dir(to, po), dir(ti, pi));
            for (mode, want) in [(TransportMode::Radiance, radiance), (TransportMode::Importance, importance)] {
                let (f, pdf) = b.f_pdf(wo, wi, mode);
                let want = Vec3::from(want);
                let rel = ((f - want).abs() / want).max_element();
                worst = worst.max(rel);
                assert!(rel <= 2e-4, "{name} θo {to} θi {ti} {mode:?}: f {f} vs Mitsuba {want}");
                // Behind the surface without a transmitting share Mitsuba's pdf is not the sampler's (module doc).
                assert!((pdf - want_pdf).abs() <= 2e-4 * want_pdf, "{name} θo {to} θi {ti}: pdf {pdf} vs Mitsuba {want_pdf}");
            }
        }
        eprintln!("largest relative difference from Mitsuba's eval: {worst:e}");
    }

    fn err(text: &str) -> PropError {
        let table: toml::Table = text.parse().unwrap();
        build(Props::new(&table, PLUGIN.keys, Vec::new())).err().unwrap_or_else(|| panic!("{text}: accepted"))
    }

    fn of(b: Bsdf) -> Principled {
        let Bsdf::Principled(p) = b else { panic!("{b:?}") };
        p
    }

    /// Mitsuba's defaults and its rules for `eta`, `specular` and the transmission flag.
    #[test]
    fn keys_read_as_mitsuba_reads_them() {
        let p = of(parse(""));
        assert_eq!((p.base_color, p.roughness, p.metallic, p.spec_trans, p.clearcoat_gloss), (Vec3::splat(0.5), 0.5, 0.0, 0.0, 0.0));
        assert!((p.eta - 1.5).abs() < 1e-6 && !p.has_spec_trans && p.rates == SamplingRates::default());
        assert_eq!((p.distribution.alpha_u, p.distribution.alpha_v), (0.25, 0.25));
        // η = 1 or specular = 0 cannot refract: Mitsuba nudges them where the transmission lobe exists,
        // which `spec_trans = 0` (a number) does not make.
        assert_eq!(of(parse("eta = 1\nspec_trans = 0.5")).eta, 1.001);
        assert_eq!(of(parse("eta = 1\nspec_trans = 0")).eta, 1.0);
        assert!(!of(parse("spec_trans = 0")).has_spec_trans && of(parse("spec_trans = 0.1")).has_spec_trans);
        assert!((of(parse("specular = 0\nspec_trans = 1")).eta - eta_of_specular(1e-3)).abs() < 1e-7);
        assert_eq!(of(parse("specular = 0")).eta, 1.0);
        assert_eq!(err("eta = 1.5\nspecular = 0.5").key, "specular");
        assert_eq!(err("roughness = 1.5").key, "roughness");
        assert_eq!(err("base_color = [1, 2, 0]").key, "base_color");
        assert_eq!(err("clearcoat_sampling_rate = -1").key, "clearcoat_sampling_rate");
        assert_eq!(err("eta = 0").key, "eta");
        // A textured roughness: the distribution follows it.
        let mut b = parse("roughness = 0.2");
        b.visit_params(&mut SetFloat("roughness", 0.8));
        b.params_changed();
        let p = of(b);
        assert!((p.distribution.alpha_u - 0.64).abs() < 1e-6);
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
