//! Rough conductor: the Cook–Torrance microfacet BRDF, one-sided (reflects on the +z side only; wrap it in
//! `twosided` for both), following Mitsuba 3's `roughconductor` (our reference renderer):
//!
//! `f(wo, wi) = R · F(wo·h) · D(h) · G1(wo) · G1(wi) / (4 cos θo cos θi)`, `h = normalize(wo + wi)`
//! (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 20),
//! with the **separable** Smith masking–shadowing `G2 = G1(wo)·G1(wi)` as Mitsuba uses (not the
//! height-correlated form), `F` the conductor Fresnel term (1 when `eta_k` is `None`), `D` and `G1` of the
//! chosen distribution (Beckmann or GGX, [`super::microfacet`]).
//!
//! Sampling draws a normal `m` (visible normals `D_wo(m) = G1(wo)·max(0, wo·m)·D(m)/cos θo` or `D(m)·cos θm`)
//! and reflects `wo` about it, so `pdf_w(wi) = pdf_m(h)/(4 |wo·h|)` (reflection Jacobian, Walter 2007
//! eq. 14): `D(h)·G1(wo)/(4 cos θo)` for visible normals (Heitz 2018 eq. 17). Samples below the horizon are
//! lost (`None`), so `pdf_w` integrates to less than one at grazing incidence — the same choice as Mitsuba.
//!
//! To stay finite at grazing angles nothing divides by a cosine: with `[G1/cos](v)` from the distribution,
//! `f = R·F·D·[G1/cos](wo)·[G1/cos](wi)/4` and `pdf_w = D·[G1/cos](wo)/4`.

//!
//! ```toml
//! bsdf = { type = "roughconductor", alpha = 0.2, distribution = "ggx", material = "Cu" }
//! ```
//!
//! `alpha` (default 0.1, > 0) or `alpha_u` and `alpha_v` (anisotropic: along the shading frame's tangent and
//! bitangent), `distribution` ("beckmann", Mitsuba's default, or "ggx"), `sample_visible` (default true) —
//! the keys of [`super::microfacet`] — and the keys of `conductor` (`specular_reflectance`, `material` or
//! `eta` + `k`).

use super::conductor::{self, fresnel_conductor_rgb};
use super::microfacet::{self, Microfacet, MicrofacetType};
use super::{non_delta_sample, Bsdf, BsdfSample, Model, Plugin, TransportMode, ParamMut, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use std::f32::consts::PI;

/// Mitsuba's `roughconductor` (Beckmann or GGX, isotropic or anisotropic, [`Microfacet`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughConductor {
    pub distribution: Microfacet,
    pub specular_reflectance: Vec3,
    pub eta_k: Option<(Vec3, Vec3)>,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "roughconductor",
    keys: &["alpha", "alpha_u", "alpha_v", "distribution", "sample_visible", "specular_reflectance", "material", "eta", "k"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let (specular_reflectance, eta_k) = conductor::reflection(&p)?;
    Ok(Bsdf::RoughConductor(RoughConductor {
        distribution: microfacet::from_props(&p, MicrofacetType::Beckmann)?,
        specular_reflectance,
        eta_k,
    }))
}

impl Model for RoughConductor {
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> Vec3 {
        f(&self.distribution, self.specular_reflectance, self.eta_k, wo, wi)
    }
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3, _: TransportMode) -> (Vec3, f32) {
        f_pdf(&self.distribution, self.specular_reflectance, self.eta_k, wo, wi)
    }
    #[inline]
    fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
        pdf_w(&self.distribution, wo, wi)
    }
    #[inline]
    fn sample(&self, wo: Vec3, _: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        non_delta_sample(self, wo, sample_wi(&self.distribution, wo, u_dir)?, mode)
    }
    fn has_non_delta(&self) -> bool {
        self.specular_reflectance.max_element() > 0.0
    }
    fn anisotropic(&self) -> bool {
        self.distribution.is_anisotropic()
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
        self.distribution.visit_params(v);
    }
}

/// Both directions strictly above the surface (one-sided reflection).
#[inline]
fn upper(wo: Vec3, wi: Vec3) -> bool {
    wo.z > 0.0 && wi.z > 0.0
}

/// `pdf_m(h)/(4 |wo·h|)`, sharing `D(h)` and `[G1/cos](wo)` with the caller.
#[inline]
fn pdf_from(md: &Microfacet, d: f32, g1o: f32, wo: Vec3, h: Vec3) -> f32 {
    if md.sample_visible {
        0.25 * d * g1o
    } else {
        0.25 * d * h.z / wo.dot(h)
    }
}

/// `R·F(wo·h)·D(h)·G1(wo)·G1(wi)/(4 cos θo cos θi)`.
#[must_use]
pub(super) fn f(md: &Microfacet, specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3, wi: Vec3) -> Vec3 {
    f_pdf(md, specular_reflectance, eta_k, wo, wi).0
}

/// `(f, pdf_w)` in one evaluation: the half vector, `D(h)` and `G1(wo)` are shared (the density-estimation
/// loop needs both for every photon).
#[must_use]
pub(super) fn f_pdf(md: &Microfacet, specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    if !upper(wo, wi) {
        return (Vec3::ZERO, 0.0);
    }
    f_pdf_upper(md, specular_reflectance, eta_k, wo, wi, md.g1_over_cos_unmasked(wo))
}

/// [`f_pdf`] for `wo.z > 0`, given `g1o_unmasked = md.g1_over_cos_unmasked(wo)` (the part of `G1(wo)/cos θo`
/// that does not depend on `wi`, computed once per `wo` by `super::at_wo`).
#[inline]
#[must_use]
pub(super) fn f_pdf_upper(
    md: &Microfacet,
    specular_reflectance: Vec3,
    eta_k: Option<(Vec3, Vec3)>,
    wo: Vec3,
    wi: Vec3,
    g1o_unmasked: f32,
) -> (Vec3, f32) {
    if !upper(wo, wi) {
        return (Vec3::ZERO, 0.0);
    }
    let Some(h) = (wo + wi).try_normalize() else {
        return (Vec3::ZERO, 0.0);
    };
    let d = md.d(h);
    let g1o = if wo.dot(h) <= 0.0 { 0.0 } else { g1o_unmasked };
    let pdf = pdf_from(md, d, g1o, wo, h);
    let g = g1o * md.g1_over_cos(wi, h);
    if g == 0.0 {
        return (Vec3::ZERO, pdf);
    }
    let fresnel = eta_k.map_or(Vec3::ONE, |(eta, k)| fresnel_conductor_rgb(wo.dot(h), eta, k));
    (specular_reflectance * fresnel * (0.25 * d * g), pdf)
}

/// A GGX lobe without Fresnel (`eta_k = None`) prepared for one `wo` (`wo.z > 0`), evaluated by
/// [`GgxAtWo::f_pdf`] without branches so that a loop over many `wi` vectorises (`super::at_wo`).
#[derive(Clone, Copy, Debug)]
pub(super) struct GgxAtWo {
    /// The clamped α ([`Microfacet::alphas`]) and α².
    alpha: f32,
    a2: f32,
    sample_visible: bool,
    specular_reflectance: Vec3,
    wo: Vec3,
    /// `G1(wo)/cos θo` before the `wo·h > 0` test.
    g1o_unmasked: f32,
}

impl GgxAtWo {
    /// `None` unless the lobe is isotropic GGX without Fresnel and `wo.z > 0`.
    pub(super) fn new(md: &Microfacet, specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3, g1o_unmasked: f32) -> Option<Self> {
        if md.kind != MicrofacetType::Ggx || !md.is_isotropic() || eta_k.is_some() || wo.z <= 0.0 {
            return None;
        }
        let alpha = md.alphas().0;
        Some(Self { alpha, a2: alpha * alpha, sample_visible: md.sample_visible, specular_reflectance, wo, g1o_unmasked })
    }

    /// Bit for bit `f_pdf_upper(md, specular_reflectance, None, wo, wi, g1o_unmasked)`: the same operations
    /// in the same order (`Microfacet::d`, `Microfacet::g1_over_cos`, `pdf_from` written out for GGX), every
    /// case computed and the result selected.
    #[inline(always)]
    pub(super) fn f_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        let wo = self.wo;
        let h = wo + wi;
        let rcp = h.length_recip();
        let normalised = rcp.is_finite() & (rcp > 0.0);
        let h = h * rcp;
        // D(h) (Microfacet::d, GGX).
        let t = (h.x * h.x + h.y * h.y) / self.a2 + h.z * h.z;
        let d = if h.z <= 0.0 { 0.0 } else { 1.0 / (PI * self.a2 * t * t) };
        let wo_h = wo.dot(h);
        let g1o = if wo_h <= 0.0 { 0.0 } else { self.g1o_unmasked };
        let pdf = if self.sample_visible { 0.25 * d * g1o } else { 0.25 * d * h.z / wo_h };
        // G1(wi)/cos θi (Microfacet::g1_over_cos, GGX).
        let sin2 = wi.x * wi.x + wi.y * wi.y;
        let g1i_unmasked = 2.0 / (wi.z + (wi.z * wi.z + self.alpha * self.alpha * sin2).sqrt());
        let g1i = if wi.dot(h) <= 0.0 { 0.0 } else { g1i_unmasked };
        let g = g1o * g1i;
        // specular_reflectance · F (= 1) · (0.25·D·G); `x·1 = x` exactly.
        let f = if g == 0.0 { Vec3::ZERO } else { self.specular_reflectance * (0.25 * d * g) };
        let upper = (wo.z > 0.0) & (wi.z > 0.0);
        if upper & normalised {
            (f, pdf)
        } else {
            (Vec3::ZERO, 0.0)
        }
    }
}

/// The density of [`sample_wi`].
#[must_use]
pub(super) fn pdf_w(md: &Microfacet, wo: Vec3, wi: Vec3) -> f32 {
    if !upper(wo, wi) {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    let g1o = if md.sample_visible { md.g1_over_cos(wo, h) } else { 0.0 };
    pdf_from(md, md.d(h), g1o, wo, h)
}

/// Reflects `wo` about a sampled normal; `None` below the horizon or for `wo` below the surface.
#[must_use]
pub(super) fn sample_wi(md: &Microfacet, wo: Vec3, u_dir: Vec2) -> Option<Vec3> {
    if wo.z <= 0.0 {
        return None;
    }
    let m = md.sample_normal(wo, u_dir);
    // A normal facing away from wo (only `D(m)·cos θm` sampling draws them) reflects nothing.
    if !md.sample_visible && wo.dot(m) <= 0.0 {
        return None;
    }
    // wi = 2(wo·m)m − wo (Walter 2007 eq. 13).
    let wi = (2.0 * wo.dot(m) * m - wo).normalize();
    if wi.z.is_nan() || wi.z <= 0.0 {
        return None;
    }
    Some(wi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::MicrofacetType;

    const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    fn md(kind: MicrofacetType, alpha: f32) -> Microfacet {
        Microfacet::isotropic(kind, alpha, true)
    }

    #[test]
    fn ggx_smith_g1_matches_the_tangent_form() {
        // G1 = 2/(1 + sqrt(1 + α² tan²θ)) (Walter 2007 eq. 34), as Mitsuba 3 `smith_g1` writes it.
        for alpha in ALPHAS {
            let m = md(MicrofacetType::Ggx, alpha);
            for theta in [0.0f32, 10.0, 45.0, 80.0, 89.0] {
                let v = dir(theta, 1.0);
                let tan2 = (theta.to_radians().tan()).powi(2);
                let want = 2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt());
                let got = m.g1_over_cos(v, Vec3::Z) * v.z;
                assert!((got - want).abs() < 1e-5, "alpha {alpha} θ {theta}: {got} vs {want}");
            }
            // Back-facing microfacet: masked.
            assert_eq!(m.g1_over_cos(dir(60.0, 0.0), dir(60.0, std::f32::consts::PI)), 0.0);
        }
    }

    #[test]
    fn f_matches_the_textbook_formula() {
        let r = Vec3::new(0.9, 0.7, 0.5);
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for alpha in ALPHAS {
                for (to, ti) in [(10.0f32, 20.0f32), (45.0, 70.0), (80.0, 5.0)] {
                    let (wo, wi) = (dir(to, 0.3), dir(ti, 2.0));
                    let h = (wo + wi).normalize();
                    let tan2 = |v: Vec3| f64::from(v.x * v.x + v.y * v.y) / f64::from(v.z * v.z);
                    let a = f64::from(alpha);
                    // Walter 2007 eqs. 25, 27 (Beckmann) and 33, 34 (GGX).
                    let (d, g1): (f64, Box<dyn Fn(Vec3) -> f64>) = match kind {
                        MicrofacetType::Ggx => (
                            1.0 / (std::f64::consts::PI * a * a * f64::from(h.z).powi(4) * (1.0 + tan2(h) / (a * a)).powi(2)),
                            Box::new(move |v| 2.0 / (1.0 + (1.0 + a * a * tan2(v)).sqrt())),
                        ),
                        MicrofacetType::Beckmann => (
                            (-tan2(h) / (a * a)).exp() / (std::f64::consts::PI * a * a * f64::from(h.z).powi(4)),
                            Box::new(move |v| {
                                let b = 1.0 / (a * tan2(v).sqrt());
                                2.0 / (1.0 + libm::erf(b) + (-b * b).exp() / (b * std::f64::consts::PI.sqrt()))
                            }),
                        ),
                    };
                    let want = r * (d * g1(wo) * g1(wi) / (4.0 * f64::from(wo.z) * f64::from(wi.z))) as f32;
                    let got = f(&md(kind, alpha), r, None, wo, wi);
                    assert!(((got - want).abs() - 1e-4 * want).max_element() <= 1e-30, "{kind:?} alpha {alpha}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn one_sided() {
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            let m = md(kind, 0.3);
            let (wo, wi) = (dir(30.0, 0.2), dir(40.0, 2.5));
            let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
            assert!(f(&m, Vec3::ONE, None, wo, wi).max_element() > 0.0 && pdf_w(&m, wo, wi) > 0.0);
            assert_eq!(f(&m, Vec3::ONE, None, flip(wo), flip(wi)), Vec3::ZERO);
            assert_eq!(pdf_w(&m, flip(wo), flip(wi)), 0.0);
            assert!(sample_wi(&m, flip(wo), Vec2::new(0.3, 0.6)).is_none());
        }
    }

    #[test]
    fn finite_at_grazing_and_tiny_alpha() {
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for sample_visible in [true, false] {
                for alpha in [0.0f32, 1e-7, 1e-4, 0.05, 1.0, 3.0] {
                    let m = Microfacet::isotropic(kind, alpha, sample_visible);
                    for z in [1e-30f32, 1e-20, 1e-7, 1e-3] {
                        let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
                        for u in [
                            Vec2::new(0.0, 0.0),
                            Vec2::new(0.5, 0.5),
                            Vec2::new(0.999_999, 0.25),
                            Vec2::new(0.3, 0.999_999),
                        ] {
                            if let Some(wi) = sample_wi(&m, wo, u) {
                                assert!(wi.is_finite() && wi.z > 0.0);
                                let (fv, p) = (f(&m, Vec3::ONE, None, wo, wi), pdf_w(&m, wo, wi));
                                assert!(fv.is_finite() && p.is_finite() && p >= 0.0, "{m:?} z {z}: {fv} {p}");
                            }
                        }
                        let wi = Vec3::new(-0.6, 0.0, 0.8);
                        assert!(f(&m, Vec3::ONE, None, wo, wi).is_finite() && pdf_w(&m, wo, wi).is_finite());
                    }
                }
            }
        }
    }
}
