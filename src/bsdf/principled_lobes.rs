//! The terms of Mitsuba 3's `principled` that no other BSDF here has (Mitsuba 3.9.1
//! src/bsdfs/principledhelpers.h; Burley 2012, "Physically Based Shading at Disney", and 2015, "Extending
//! the Disney BRDF to a BSDF with Integrated Subsurface Scattering"): Schlick's Fresnel as Mitsuba chooses
//! its angle, the blended Fresnel of the main specular lobe, the roughness mapping, the clearcoat's GTR1
//! distribution and masking, and the diffuse, retro-reflection, fake-subsurface and sheen terms.
//! `super::principled` and `super::principledthin` combine them into their BSDFs; all directions are in its local frame, `wo` the
//! direction the path arrives from (Mitsuba's `si.wi`), `wi` the other (Mitsuba's `wo`).

use std::f32::consts::{FRAC_1_PI, PI, TAU};

use crate::math::{Vec2, Vec3};
use crate::texture::luminance;

/// Schlick's weight `(1 − cos)⁵`, the cosine clamped to `[0, 1]` (Mitsuba's `schlick_weight`).
#[inline]
pub(super) fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The weight Schlick's approximation takes at a microfacet cosine `cos_m` (signed: negative inside) for
/// the relative index `eta`: `(1 − |cos θi|)⁵` when entering a denser medium (`η_it > 1`), else the
/// transmitted angle's `(1 − cos θt)⁵`, `cos θt` 0 beyond the critical angle (Mitsuba's `calc_schlick`).
#[inline]
pub(super) fn schlick_angle_weight(cos_m: f32, eta: f32) -> f32 {
    let (eta_it, eta_ti) = if cos_m >= 0.0 { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    if eta_it > 1.0 {
        schlick_weight(cos_m.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos_m * cos_m) * eta_ti * eta_ti;
        schlick_weight(cos_t2.max(0.0).sqrt())
    }
}

/// Schlick's `F = R₀ + (1 − R₀)·w` for the weight `w` of [`schlick_angle_weight`].
#[inline]
pub(super) fn schlick(r0: Vec3, w: f32) -> Vec3 {
    r0 + (Vec3::ONE - r0) * w
}

/// `((η − 1)/(η + 1))²`, the normal-incidence reflectance of the index ratio `η` (Mitsuba's
/// `schlick_R0_eta`).
#[inline]
pub(super) fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// The colour `base_color/luminance(base_color)` toward which `spec_tint` and `sheen_tint` tint (white for
/// a black base), Mitsuba's `c_tint`.
#[inline]
pub(super) fn tint(base_color: Vec3) -> Vec3 {
    let lum = luminance(base_color);
    if lum > 0.0 {
        base_color / lum
    } else {
        Vec3::ONE
    }
}

/// The GGX roughness `(α_u, α_v)` of the main specular lobes (Mitsuba's `calc_dist_params`, after Burley
/// 2012 §5.4): `α = roughness²` stretched by `aspect = √(1 − 0.9·anisotropic)`, `α_u = α/aspect`,
/// `α_v = α·aspect`, each at least 0.001.
#[inline]
pub(super) fn specular_alphas(roughness: f32, anisotropic: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// The Fresnel factor of the main specular reflection (Mitsuba's `principled_fresnel`) at the microfacet
/// cosine `cos_m = wo·h`, given the dielectric Fresnel reflectance `f_dielectric` there: from the front, the
/// dielectric share `(1 − metallic)(1 − spec_tint)·F` plus Schlick's approximation toward `base_color` for the
/// metallic share and toward `tint·R₀(η_it)` for the tinted share; from behind only the transmitting share
/// `bsdf·F` (no tint, no metal inside).
#[allow(clippy::too_many_arguments)]
pub(super) fn main_fresnel(f_dielectric: f32, cos_m: f32, eta: f32, front: bool, metallic: f32, spec_tint: f32, bsdf: f32, base_color: Vec3) -> Vec3 {
    if !front {
        return Vec3::splat(bsdf * f_dielectric);
    }
    let w = schlick_angle_weight(cos_m, eta);
    let mut f = Vec3::splat((1.0 - metallic) * (1.0 - spec_tint) * f_dielectric);
    if metallic > 0.0 {
        f += metallic * schlick(base_color, w);
    }
    if spec_tint > 0.0 {
        let eta_it = if cos_m >= 0.0 { eta } else { 1.0 / eta };
        f += (1.0 - metallic) * spec_tint * schlick(tint(base_color) * schlick_r0(eta_it), w);
    }
    f
}

/// The clearcoat's isotropic GTR1 ("Berry") distribution of roughness `alpha` (Burley 2012, appendix B;
/// Mitsuba's `GTR1Isotropic`): `D(m) = (α² − 1)/(π·ln α²·(1 + (α² − 1)cos²θm))`, sampled by
/// `cos²θ = (1 − α^{2(1−u₂)})/(1 − α²)`, `φ = 2πu₁` with density `D(m)·cos θm` (no visible normals).
#[derive(Clone, Copy, Debug)]
pub(super) struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    /// The clearcoat's distribution for `clearcoat_gloss`: `α` from 0.1 (gloss 0) to 0.001 (gloss 1).
    #[inline]
    pub(super) fn for_gloss(clearcoat_gloss: f32) -> Self {
        Self { alpha: 0.1 + (0.001 - 0.1) * clearcoat_gloss }
    }

    /// `D(m)`; 0 where `D·cos θm ≤ 10⁻²⁰` (below the surface), as Mitsuba.
    #[inline]
    pub(super) fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let r = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * m.z * m.z));
        if r * m.z > 1e-20 {
            r
        } else {
            0.0
        }
    }

    /// The density of [`Gtr1::sample`] per solid angle of `m`: `D(m)·cos θm`.
    #[inline]
    pub(super) fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    /// A normal distributed as [`Gtr1::pdf`].
    #[inline]
    pub(super) fn sample(&self, u: Vec2) -> Vec3 {
        let (sin_phi, cos_phi) = (TAU * u.x).sin_cos();
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let sin = (1.0 - cos2).max(0.0).sqrt();
        Vec3::new(cos_phi * sin, sin_phi * sin, cos2.max(0.0).sqrt())
    }
}

/// Smith's GGX masking of `v` at the microfacet `h` with the clearcoat's fixed roughness 0.25 (Mitsuba's
/// `smith_ggx1`, Walter 2007 eq. 34): `2/(1 + √(1 + α² tan²θ))`, 1 at normal incidence, 0 where `v` sees
/// the back of the microfacet.
#[inline]
pub(super) fn clearcoat_g1(v: Vec3, h: Vec3) -> f32 {
    const ALPHA2: f32 = 0.25 * 0.25;
    if v.dot(h) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let c2 = v.z * v.z;
    let tan2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + ALPHA2 * tan2).sqrt())
}

/// The parameters of the diffuse and sheen terms.
pub(super) struct DiffuseTerms {
    pub base_color: Vec3,
    pub roughness: f32,
    pub flatness: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    /// The sheen's weight: `1 − metallic` in `principled`, `(1 − spec_trans)(1 − diff_trans/2)` in
    /// `principledthin`.
    pub sheen_weight: f32,
    /// The diffuse lobe's weight: `(1 − metallic)(1 − spec_trans)` in `principled`, `(1 − spec_trans)(1 −
    /// diff_trans/2)` in `principledthin`.
    pub brdf: f32,
}

impl DiffuseTerms {
    /// The diffuse lobe's `f` (without the cosine) for `wo`, `wi` above the surface and their half vector
    /// `h`: Burley's diffuse with retro-reflection, `brdf·base/π·((1 − Fo/2)(1 − Fi/2) + R_R(Fo + Fi +
    /// Fo·Fi(R_R − 1)))`, `R_R = 2·roughness·cos²θd`, blended by `flatness` into the Hanrahan–Krueger-like
    /// fake subsurface `1.25·(F_ss·(1/(cos θo + cos θi) − ½) + ½)`, `F_ss = (1 + (F_ss90 − 1)Fo)(1 +
    /// (F_ss90 − 1)Fi)`, `F_ss90 = R_R/2`; plus the sheen `sheen·sheen_weight·(1 − cos θd)⁵` tinted toward
    /// the base by `sheen_tint` (Mitsuba's `principled` and `principledthin` `eval`: the sheen, not divided by
    /// π, only where the diffuse lobe is).
    pub(super) fn f(&self, wo: Vec3, wi: Vec3, h: Vec3) -> Vec3 {
        let (f_o, f_i) = (schlick_weight(wi.z.abs()), schlick_weight(wo.z.abs()));
        let f_diff = (1.0 - 0.5 * f_i) * (1.0 - 0.5 * f_o);
        let cos_d = h.dot(wi);
        let rr = 2.0 * self.roughness * cos_d * cos_d;
        let f_retro = rr * (f_o + f_i + f_o * f_i * (rr - 1.0));
        let mut lobe = f_diff + f_retro;
        if self.flatness > 0.0 {
            let fss90 = 0.5 * rr;
            let fss = (1.0 + (fss90 - 1.0) * f_o) * (1.0 + (fss90 - 1.0) * f_i);
            let f_ss = 1.25 * (fss * (1.0 / (wi.z.abs() + wo.z.abs()) - 0.5) + 0.5);
            lobe += (f_ss - lobe) * self.flatness;
        }
        let mut f = self.base_color * (self.brdf * FRAC_1_PI * lobe);
        if self.sheen > 0.0 && self.sheen_weight > 0.0 {
            let c_sheen = Vec3::ONE + (tint(self.base_color) - Vec3::ONE) * self.sheen_tint;
            f += c_sheen * (self.sheen * self.sheen_weight * schlick_weight(cos_d.abs()));
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{integrate_sphere, Chi2Test, PdfIntegral};

    #[test]
    fn gtr1_is_normalised_and_its_sampler_follows_its_pdf() {
        for gloss in [0.0f32, 0.5, 0.9] {
            let g = Gtr1::for_gloss(gloss);
            let projected = integrate_sphere(|m| g.pdf(m));
            assert!((projected - 1.0).abs() < 2e-3, "gloss {gloss}: ∫D cos = {projected}");
            let out = Chi2Test { sample_count: 200_000, test_count: 3, integral: PdfIntegral::One, ..Chi2Test::default() }.run(
                |s| {
                    let m = g.sample(s.next_2d());
                    Some((m, g.pdf(m)))
                },
                |m| g.pdf(m),
            );
            assert!(out.passed(), "gloss {gloss}: {out}");
        }
    }

    #[test]
    fn schlick_follows_the_angle_mitsuba_chooses() {
        // Entering glass: the incident angle; leaving it: the transmitted one, 1 beyond the critical angle.
        assert_eq!(schlick_angle_weight(1.0, 1.5), 0.0);
        assert!((schlick_angle_weight(0.5, 1.5) - 0.5f32.powi(5)).abs() < 1e-7);
        assert_eq!(schlick_angle_weight(-0.3, 1.5), 1.0);
        let cos_t = (1.0f32 - (1.0 - 0.9 * 0.9) * 1.5 * 1.5).sqrt();
        assert!((schlick_angle_weight(-0.9, 1.5) - (1.0 - cos_t).powi(5)).abs() < 1e-6);
        assert!((schlick_r0(1.5) - 0.04).abs() < 1e-7);
        assert_eq!(specular_alphas(0.5, 0.0), (0.25, 0.25));
        assert_eq!(specular_alphas(0.0, 0.0), (0.001, 0.001));
    }
}
