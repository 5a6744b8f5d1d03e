//! Smooth dielectric interface (glass, water): two delta lobes, specular reflection and refraction,
//! chosen with probabilities `F` and `1 − F` (exact unpolarised Fresnel), so both have weight 1 apart
//! from the transport-mode factor below. `eta = int_ior/ext_ior`; `wo.z > 0` is outside.
//!
//! **Radiance vs importance** (pbrt-v4 convention, §9.5.2; Veach 1997 §5.2): radiance is not symmetric
//! under refraction — `L/η²` is conserved — so in [`TransportMode::Radiance`] the refracted weight is
//! multiplied by `(η_o/η_i)²` = `1/η²` where `η = η_i/η_o` is the relative index of the side `wi` lies
//! on over the side of `wo` (entering glass from outside in a camera path: `×1/η²`, leaving it: `×η²`).
//! [`TransportMode::Importance`] (photons carry flux) does not scale: the weight is exactly 1.
//!
//! ```toml
//! bsdf = { type = "dielectric", int_ior = 1.5, ext_ior = "air" }   # numbers or Mitsuba's IOR names (`ior`)
//! ```
//!
//! Defaults as Mitsuba: `int_ior` 1.5046 ("bk7"), `ext_ior` 1.000277 ("air").

use super::ior::{ior_or, AIR, BK7};
use super::{reflect_z, Bsdf, BsdfSample, Model, Plugin};
use super::TransportMode;
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `dielectric`; `eta = int_ior / ext_ior`. The interior is on the -z side of the shading frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Dielectric {
    pub eta: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "dielectric",
    keys: &["int_ior", "ext_ior"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let int_ior = ior_or(&p, "int_ior", BK7)?;
    let ext_ior = ior_or(&p, "ext_ior", AIR)?;
    Ok(Bsdf::Dielectric(Dielectric { eta: int_ior / ext_ior }))
}

impl Model for Dielectric {
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, _: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        sample(self.eta, wo, u_lobe, mode)
    }
    fn chooses_lobe(&self) -> bool {
        true
    }
    fn has_delta(&self) -> bool {
        true
    }
    fn has_non_delta(&self) -> bool {
        false
    }
    fn transmits(&self) -> bool {
        true
    }
}

/// Unpolarised Fresnel reflectance of a dielectric interface with relative index `eta = η_int/η_ext`
/// (Mitsuba 3 `fresnel_dielectric`; Walter et al. 2007 eq. 22 in the `r_s`, `r_p` form).
///
/// `cos_theta_i > 0` means incidence from outside. Returns `(F, cos θt, η_it, η_ti)`: `cos θt` is signed
/// (opposite to `cos θi`, the refracted direction's z), `η_it = η_t/η_i` and `η_ti = 1/η_it` are the relative
/// indices along the refraction. Total internal reflection gives `F = 1`, `cos θt = 0`.
#[must_use]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    // Snell: cos²θt = 1 − sin²θi·η_ti².
    let cos_i = cos_theta_i.abs().min(1.0);
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    if cos_t2 <= 0.0 {
        return (1.0, 0.0, eta_it, eta_ti);
    }
    let cos_t = cos_t2.sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if cos_i == 0.0 {
        1.0
    } else {
        // r_s = (cos θi − η_it cos θt)/(cos θi + η_it cos θt), r_p = (cos θt − η_it cos θi)/(cos θt + η_it cos θi).
        let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
        let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r.clamp(0.0, 1.0), if outside { -cos_t } else { cos_t }, eta_it, eta_ti)
}

/// Chooses reflection when `u_lobe < F`, refraction otherwise. `wo.z != 0` is checked by the caller.
#[must_use]
pub(super) fn sample(eta: f32, wo: Vec3, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
    if !(eta > 0.0 && eta.is_finite()) {
        return None;
    }
    let (r, cos_t, _eta_it, eta_ti) = fresnel_dielectric(wo.z, eta);
    if u_lobe < r {
        // Throughput F, chosen with probability F.
        return Some(BsdfSample {
            wi_local: reflect_z(wo),
            weight: Vec3::ONE,
            pdf_w: r,
            delta: true,
            pass_through: false,
        });
    }
    // Refraction (Snell, in vector form): wi = −η_ti·wo_tangential + cos θt·n (Mitsuba `refract`).
    let wi = Vec3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t).try_normalize()?;
    if wi.z == 0.0 || wi.z.signum() == wo.z.signum() {
        return None;
    }
    let scale = match mode {
        TransportMode::Radiance => eta_ti * eta_ti,
        TransportMode::Importance => 1.0,
    };
    // Throughput (1 − F)·scale, chosen with probability 1 − F.
    Some(BsdfSample {
        wi_local: wi,
        weight: Vec3::splat(scale),
        pdf_w: 1.0 - r,
        delta: true,
        pass_through: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Bsdf;
    use crate::math::Vec2;
    use crate::sampler::Sampler;

    /// Walter et al. 2007 eq. 22: F = ½ (g − c)²/(g + c)² · (1 + ((c(g + c) − 1)/(c(g − c) + 1))²),
    /// g = sqrt(η_it² − 1 + c²), c = |cos θi|; 1 when g is imaginary (TIR).
    fn fresnel_walter(cos_i: f64, eta_it: f64) -> f64 {
        let c = cos_i.abs();
        let g2 = eta_it * eta_it - 1.0 + c * c;
        if g2 <= 0.0 {
            return 1.0;
        }
        let g = g2.sqrt();
        let a = (g - c) / (g + c);
        let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        0.5 * a * a * (1.0 + b * b)
    }

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    #[test]
    fn fresnel_known_values() {
        // Normal incidence: ((η − 1)/(η + 1))² = 0.04 for η = 1.5, from either side.
        assert!((fresnel_dielectric(1.0, 1.5).0 - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(-1.0, 1.5).0 - 0.04).abs() < 1e-6);
        // Brewster's angle tan θB = η: only the s-polarised part, r_s² / 2.
        let theta_b = 1.5f64.atan();
        let (ci, ct) = (theta_b.cos(), (theta_b.sin() / 1.5).asin().cos());
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((f64::from(fresnel_dielectric(theta_b.cos() as f32, 1.5).0) - 0.5 * rs * rs).abs() < 1e-6);
        // Index-matched: no reflection; grazing: total reflection.
        assert_eq!(fresnel_dielectric(0.3, 1.0).0, 0.0);
        assert_eq!(fresnel_dielectric(0.0, 1.5).0, 1.0);
        for eta in [1.33f32, 1.5, 2.4, 1.0 / 1.5] {
            for i in -20..=20 {
                let cos = i as f32 / 20.0;
                let (r, _, eta_it, _) = fresnel_dielectric(cos, eta);
                let want = fresnel_walter(f64::from(cos), f64::from(eta_it));
                if cos != 0.0 {
                    assert!((f64::from(r) - want).abs() < 1e-5, "eta {eta} cos {cos}: {r} vs {want}");
                }
            }
        }
    }

    #[test]
    fn refraction_obeys_snell_and_mode_scaling() {
        let eta = 1.5f32;
        let bsdf = Bsdf::Dielectric(Dielectric { eta });
        assert!(bsdf.has_delta() && !bsdf.has_non_delta());
        for (theta, outside) in [
            (0.0f32, true),
            (30.0, true),
            (60.0, true),
            (85.0, true),
            (20.0, false),
            (40.0, false),
        ] {
            let mut wo = dir(theta, 0.7);
            if !outside {
                wo.z = -wo.z;
            }
            let (r, ..) = fresnel_dielectric(wo.z, eta);
            let refr = |mode| bsdf.sample(wo, 0.999_999, Vec2::new(0.5, 0.5), mode).expect("refraction");
            let (rad, imp) = (refr(TransportMode::Radiance), refr(TransportMode::Importance));
            for s in [rad, imp] {
                let wi = s.wi_local;
                assert!(s.delta && wi.z * wo.z < 0.0 && (wi.length() - 1.0).abs() < 1e-6);
                assert!((s.pdf_w - (1.0 - r)).abs() < 1e-7);
                // Snell: η_i sin θi = η_t sin θt, and the tangential parts are antiparallel.
                let (n_o, n_i) = if outside { (1.0, eta) } else { (eta, 1.0) };
                let (sin_o, sin_i) = (wo.truncate().length(), wi.truncate().length());
                assert!((n_o * sin_o - n_i * sin_i).abs() < 1e-5, "θ {theta}: {sin_o} {sin_i}");
                assert!(wo.truncate().perp_dot(wi.truncate()).abs() < 1e-6 && wo.truncate().dot(wi.truncate()) <= 0.0);
            }
            // Radiance mode: ×(η_o/η_i)² where wo is on the η_o side; importance mode: ×1.
            let expected = if outside { 1.0 / (eta * eta) } else { eta * eta };
            assert!((rad.weight - Vec3::splat(expected)).abs().max_element() < 1e-6, "{:?}", rad.weight);
            assert_eq!(imp.weight, Vec3::ONE);
            // Reflection: same in both modes, pdf F.
            let refl = bsdf.sample(wo, 0.0, Vec2::ZERO, TransportMode::Radiance).expect("reflection");
            assert!(refl.delta && refl.pdf_w == r && refl.weight == Vec3::ONE);
            assert!((refl.wi_local - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-7);
        }
    }

    #[test]
    fn total_internal_reflection() {
        let bsdf = Bsdf::Dielectric(Dielectric { eta: 1.5 });
        // Inside, beyond the critical angle asin(1/1.5) ≈ 41.8°.
        let mut wo = dir(50.0, 0.2);
        wo.z = -wo.z;
        for u in [0.0, 0.5, 0.999_999] {
            let s = bsdf.sample(wo, u, Vec2::ZERO, TransportMode::Radiance).expect("TIR");
            assert!(s.pdf_w == 1.0 && s.weight == Vec3::ONE && s.wi_local.z < 0.0);
        }
    }

    #[test]
    fn reflection_probability_is_fresnel() {
        let bsdf = Bsdf::Dielectric(Dielectric { eta: 1.5 });
        for (theta, sign) in [(0.0f32, 1.0f32), (60.0, 1.0), (80.0, 1.0), (30.0, -1.0), (41.0, -1.0)] {
            let mut wo = dir(theta, 0.0);
            wo.z *= sign;
            let (r, ..) = fresnel_dielectric(wo.z, 1.5);
            let n = 200_000;
            let mut reflections = 0u32;
            let mut mean_weight = 0.0f64;
            for i in 0..n {
                let mut s = Sampler::for_key(21, i, 0);
                let smp = bsdf
                    .sample(wo, s.next_1d(), s.next_2d(), TransportMode::Importance)
                    .expect("sample");
                reflections += u32::from(smp.wi_local.z * wo.z > 0.0);
                mean_weight += f64::from(smp.weight.x);
            }
            let frac = f64::from(reflections) / n as f64;
            let sigma = (f64::from(r) * (1.0 - f64::from(r)) / n as f64).sqrt();
            assert!((frac - f64::from(r)).abs() <= 5.0 * sigma + 1e-9, "θ {theta}: {frac} vs F = {r}");
            // Importance transport through white glass keeps every photon's power.
            assert_eq!(mean_weight / n as f64, 1.0);
        }
    }

    #[test]
    fn index_matched_passes_straight_through() {
        let bsdf = Bsdf::Dielectric(Dielectric { eta: 1.0 });
        let wo = dir(35.0, 1.0);
        let s = bsdf.sample(wo, 0.0, Vec2::ZERO, TransportMode::Radiance).expect("transmission");
        assert!((s.wi_local + wo).length() < 1e-6 && s.pdf_w == 1.0 && s.weight == Vec3::ONE);
    }
}
