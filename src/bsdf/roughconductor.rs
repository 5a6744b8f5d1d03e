//! Rough conductor: the Cook–Torrance microfacet BRDF with the GGX (Trowbridge–Reitz) distribution,
//! two-sided, following Mitsuba 3's `roughconductor` (our reference renderer):
//!
//! `f(wo, wi) = R · F(wo·h) · D(h) · G1(wo) · G1(wi) / (4 cos θo cos θi)`, `h = normalize(wo + wi)`
//! (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 20),
//! with the **separable** Smith masking–shadowing `G2 = G1(wo)·G1(wi)` as Mitsuba uses (not the
//! height-correlated form), `F` the conductor Fresnel term (1 when `eta_k` is `None`).
//!
//! Sampling draws a visible normal `m ~ D_wo(m) = G1(wo)·max(0, wo·m)·D(m)/cos θo` (Heitz 2018, "Sampling
//! the GGX Distribution of Visible Normals", JCGT 7(4)) and reflects `wo` about it, so
//! `pdf_w(wi) = D_wo(h)/(4 |wo·h|) = D(h)·G1(wo)/(4 cos θo)` (Heitz 2018 eq. 17 with the reflection
//! Jacobian 1/(4|wo·h|), Walter 2007 eq. 14). Samples below the horizon are lost (`None`), so `pdf_w`
//! integrates to less than one at grazing incidence — the same choice as Mitsuba.
//!
//! To stay finite at grazing angles nothing divides by a cosine: with
//! `G1(v)/cos θv = 2/(cos θv + sqrt(cos²θv + α² sin²θv))` (Walter 2007 eq. 34 multiplied through by cos θv),
//! `f = R·F·D·[G1/cos](wo)·[G1/cos](wi)/4` and `pdf_w = D·[G1/cos](wo)/4`.
//!
//! `alpha` is clamped to `[1e-4, ∞)`: below that `D` exceeds f32's useful range for a non-delta lobe.

use super::conductor::fresnel_conductor_rgb;
use crate::math::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Smallest roughness evaluated; see the module docs.
pub(crate) const MIN_ALPHA: f32 = 1e-4;

#[inline]
fn clamp_alpha(alpha: f32) -> f32 {
    if alpha >= MIN_ALPHA {
        alpha
    } else {
        MIN_ALPHA
    }
}

/// Mirrors the configuration to the +z side when `wo` is below (two-sided reflection). `None` when `wi`
/// is across the surface from `wo` or in the tangent plane.
#[inline]
fn to_upper(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    let (wo, wi) = if wo.z < 0.0 { (flip(wo), flip(wi)) } else { (wo, wi) };
    (wo.z > 0.0 && wi.z > 0.0).then_some((wo, wi))
}

/// GGX normal distribution, isotropic: `D(m) = 1/(π α² cos⁴θm (1 + tan²θm/α²)²)` (Walter 2007 eq. 33),
/// written as `1/(π α² ((mx² + my²)/α² + mz²)²)` for a unit `m`; 0 for `mz ≤ 0`.
#[must_use]
pub(super) fn ggx_d(alpha: f32, m: Vec3) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    1.0 / (PI * a2 * t * t)
}

/// Smith masking for GGX divided by the cosine: `G1(v, m)/cos θv = 2/(cos θv + sqrt(cos²θv + α² sin²θv))`
/// for `v·m > 0` (Walter 2007 eq. 34 with χ⁺(v·m/v·n)), 0 otherwise. `v.z > 0` is required.
#[must_use]
pub(super) fn smith_g1_over_cos(alpha: f32, v: Vec3, m: Vec3) -> f32 {
    if v.dot(m) <= 0.0 {
        return 0.0;
    }
    let sin2 = v.x * v.x + v.y * v.y;
    2.0 / (v.z + (v.z * v.z + alpha * alpha * sin2).sqrt())
}

/// `R·F(wo·h)·D(h)·G1(wo)·G1(wi)/(4 cos θo cos θi)`.
#[must_use]
pub(super) fn f(alpha: f32, specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3, wi: Vec3) -> Vec3 {
    let Some((wo, wi)) = to_upper(wo, wi) else {
        return Vec3::ZERO;
    };
    let alpha = clamp_alpha(alpha);
    let Some(h) = (wo + wi).try_normalize() else {
        return Vec3::ZERO;
    };
    let g = smith_g1_over_cos(alpha, wo, h) * smith_g1_over_cos(alpha, wi, h);
    if g == 0.0 {
        return Vec3::ZERO;
    }
    let fresnel = eta_k.map_or(Vec3::ONE, |(eta, k)| fresnel_conductor_rgb(wo.dot(h), eta, k));
    specular_reflectance * fresnel * (0.25 * ggx_d(alpha, h) * g)
}

/// `(f, pdf_w)` in one evaluation: the half vector, `D(h)` and `G1(wo)` are shared (the density-estimation
/// loop needs both for every photon). Bit-identical to `(f(..), pdf_w(..))` (tested).
#[must_use]
pub(super) fn f_pdf(alpha: f32, specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    let Some((wo, wi)) = to_upper(wo, wi) else {
        return (Vec3::ZERO, 0.0);
    };
    let alpha = clamp_alpha(alpha);
    let Some(h) = (wo + wi).try_normalize() else {
        return (Vec3::ZERO, 0.0);
    };
    let d = ggx_d(alpha, h);
    let g1o = smith_g1_over_cos(alpha, wo, h);
    let pdf = 0.25 * d * g1o;
    let g = g1o * smith_g1_over_cos(alpha, wi, h);
    if g == 0.0 {
        return (Vec3::ZERO, pdf);
    }
    let fresnel = eta_k.map_or(Vec3::ONE, |(eta, k)| fresnel_conductor_rgb(wo.dot(h), eta, k));
    (specular_reflectance * fresnel * (0.25 * d * g), pdf)
}

/// `D(h)·G1(wo)/(4 cos θo)`: the density of [`sample_wi`].
#[must_use]
pub(super) fn pdf_w(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    let Some((wo, wi)) = to_upper(wo, wi) else {
        return 0.0;
    };
    let alpha = clamp_alpha(alpha);
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    0.25 * ggx_d(alpha, h) * smith_g1_over_cos(alpha, wo, h)
}

/// A visible normal for `wo` on the +z side (Heitz 2018, listing in §4: stretch to the hemisphere
/// configuration, sample the projected half-disk, unstretch).
#[must_use]
pub(super) fn sample_visible_normal(alpha: f32, wo: Vec3, u: Vec2) -> Vec3 {
    // §3.2: the view direction in the hemisphere configuration.
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    // §4.1: orthonormal basis (special case when vh is the pole).
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    // §4.2: uniform point on the disk, warped onto the visible projected half-disk.
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
    let p1 = r * cos_phi;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
    // §4.3: reprojection onto the hemisphere.
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // §3.4: back to the ellipsoid configuration.
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Reflects `wo` about a sampled visible normal; `None` if the result is not on `wo`'s side.
#[must_use]
pub(super) fn sample_wi(alpha: f32, wo: Vec3, u_dir: Vec2) -> Option<Vec3> {
    let below = wo.z < 0.0;
    let wo_up = if below { Vec3::new(wo.x, wo.y, -wo.z) } else { wo };
    let m = sample_visible_normal(clamp_alpha(alpha), wo_up, u_dir);
    // wi = 2(wo·m)m − wo (Walter 2007 eq. 13).
    let wi = (2.0 * wo_up.dot(m) * m - wo_up).normalize();
    if wi.z.is_nan() || wi.z <= 0.0 {
        return None;
    }
    Some(if below { Vec3::new(wi.x, wi.y, -wi.z) } else { wi })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::integrate_sphere;

    const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    #[test]
    fn ggx_is_normalised_and_visible_normals_too() {
        for alpha in ALPHAS {
            // ∫ D(m) cos θm dm = 1 (Walter 2007 eq. 4).
            let projected = integrate_sphere(|m| ggx_d(alpha, m) * m.z.max(0.0));
            assert!((projected - 1.0).abs() < 1e-4, "alpha {alpha}: ∫D cos = {projected}");
            // ∫ D_wo(m) dm = ∫ G1(wo, m) max(0, wo·m) D(m) dm / cos θo = 1 (Heitz 2018 eq. 2; Heitz 2014 eq. 22).
            for theta in [0.0f32, 30.0, 60.0, 85.0] {
                let wo = dir(theta, 0.4);
                let visible = integrate_sphere(|m| smith_g1_over_cos(alpha, wo, m) * wo.dot(m).max(0.0) * ggx_d(alpha, m));
                assert!((visible - 1.0).abs() < 1e-3, "alpha {alpha} θo {theta}: ∫D_wo = {visible}");
            }
        }
    }

    #[test]
    fn smith_g1_matches_the_tangent_form() {
        // G1 = 2/(1 + sqrt(1 + α² tan²θ)) (Walter 2007 eq. 34), as Mitsuba 3 `smith_g1` writes it.
        for alpha in ALPHAS {
            for theta in [0.0f32, 10.0, 45.0, 80.0, 89.0] {
                let v = dir(theta, 1.0);
                let tan2 = (theta.to_radians().tan()).powi(2);
                let want = 2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt());
                let got = smith_g1_over_cos(alpha, v, Vec3::Z) * v.z;
                assert!((got - want).abs() < 1e-5, "alpha {alpha} θ {theta}: {got} vs {want}");
            }
            // Back-facing microfacet: masked.
            assert_eq!(smith_g1_over_cos(alpha, dir(60.0, 0.0), dir(60.0, std::f32::consts::PI)), 0.0);
        }
    }

    #[test]
    fn f_matches_the_textbook_formula() {
        let r = Vec3::new(0.9, 0.7, 0.5);
        for alpha in ALPHAS {
            for (to, ti) in [(10.0f32, 20.0f32), (45.0, 70.0), (80.0, 5.0)] {
                let (wo, wi) = (dir(to, 0.3), dir(ti, 2.0));
                let h = (wo + wi).normalize();
                let tan2 = |v: Vec3| (v.x * v.x + v.y * v.y) / (v.z * v.z);
                let g1 = |v: Vec3| 2.0 / (1.0 + (1.0 + alpha * alpha * tan2(v)).sqrt());
                let cos_h = h.z;
                let tan2_h = tan2(h);
                let d = 1.0 / (PI * alpha * alpha * cos_h.powi(4) * (1.0 + tan2_h / (alpha * alpha)).powi(2));
                let want = r * d * g1(wo) * g1(wi) / (4.0 * wo.z * wi.z);
                let got = f(alpha, r, None, wo, wi);
                assert!(((got - want) / want).abs().max_element() < 1e-4, "alpha {alpha}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn finite_at_grazing_and_tiny_alpha() {
        for alpha in [0.0f32, 1e-7, 1e-4, 0.05, 1.0, 3.0] {
            for z in [1e-30f32, 1e-20, 1e-7, 1e-3] {
                let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
                for u in [
                    Vec2::new(0.0, 0.0),
                    Vec2::new(0.5, 0.5),
                    Vec2::new(0.999_999, 0.25),
                    Vec2::new(0.3, 0.999_999),
                ] {
                    if let Some(wi) = sample_wi(alpha, wo, u) {
                        assert!(wi.is_finite() && wi.z > 0.0);
                        let (fv, p) = (f(alpha, Vec3::ONE, None, wo, wi), pdf_w(alpha, wo, wi));
                        assert!(fv.is_finite() && p.is_finite() && p >= 0.0, "alpha {alpha} z {z}: {fv} {p}");
                    }
                }
                let wi = Vec3::new(-0.6, 0.0, 0.8);
                assert!(f(alpha, Vec3::ONE, None, wo, wi).is_finite() && pdf_w(alpha, wo, wi).is_finite());
            }
        }
    }
}
