//! Smooth conductor: a one-sided (as Mitsuba's `conductor`; `twosided` mirrors it) perfect mirror weighted by the conductor Fresnel term for a complex
//! index of refraction `η + iκ` (relative to the exterior), or by 1 when `eta_k` is `None`
//! (Mitsuba's material "none").
//!
//! ```toml
//! bsdf = { type = "conductor", material = "Au" }   # a named metal of Mitsuba's (CONDUCTORS), or "none" (default)
//! bsdf = { type = "conductor", eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2], specular_reflectance = 1 }
//! ```
//!
//! `specular_reflectance` (default 1) scales the reflection; `material` or `eta` + `k` (both), not both.

use super::conductor_table::CONDUCTORS;
use super::{reflect_z, Bsdf, BsdfSample, Model, Plugin, TransportMode, ParamMut, ParamVisitor};
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's `conductor`. `eta_k: None` = perfect mirror (Fresnel = 1), Mitsuba's material "none".
#[derive(Clone, Debug, PartialEq)]
pub struct Conductor {
    pub specular_reflectance: Vec3,
    pub eta_k: Option<(Vec3, Vec3)>,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "conductor",
    keys: &["specular_reflectance", "material", "eta", "k"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Bsdf>) -> Result<Bsdf, PropError> {
    let (specular_reflectance, eta_k) = reflection(&p)?;
    Ok(Bsdf::Conductor(Conductor { specular_reflectance, eta_k }))
}

/// The reflection keys of `conductor` and `roughconductor`: `specular_reflectance` (default 1) and the complex index of refraction: `material` (a name of
/// [`CONDUCTORS`], or "none": a perfect mirror, the default) or `eta` and `k` (both), not both.
pub(super) fn reflection(p: &Props<'_, Bsdf>) -> Result<(Vec3, Option<(Vec3, Vec3)>), PropError> {
    let specular_reflectance = p.reflectance_or("specular_reflectance", Vec3::ONE)?;
    let eta_k = match (p.colour("eta")?, p.colour("k")?) {
        (None, None) => named(p.string("material")?)?,
        (Some(_), _) | (_, Some(_)) if p.has("material") => {
            return Err(PropError::new("material", "give either `material` or `eta` and `k`, not both"))
        }
        (Some(eta), Some(k)) => {
            if eta.min_element() <= 0.0 {
                return Err(PropError::new("eta", format!("every component of eta must be > 0, got {eta}")));
            }
            if k.min_element() < 0.0 {
                return Err(PropError::new("k", format!("every component of k must be ≥ 0, got {k}")));
            }
            Some((eta, k))
        }
        (Some(_), None) => return Err(PropError::new("eta", "give both `eta` and `k`, or neither (perfect mirror)")),
        (None, Some(_)) => return Err(PropError::new("k", "give both `eta` and `k`, or neither (perfect mirror)")),
    };
    Ok((specular_reflectance, eta_k))
}

/// `eta`/`k` of Mitsuba's named conductor `name`; `None` (perfect mirror) for "none" or absent.
fn named(name: Option<&str>) -> Result<Option<(Vec3, Vec3)>, PropError> {
    match name {
        None | Some("none") => Ok(None),
        Some(name) => CONDUCTORS
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(_, eta, k)| Some((Vec3::from_array(*eta), Vec3::from_array(*k))))
            .ok_or_else(|| {
                let names: Vec<&str> = CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
                PropError::new("material", format!("unknown conductor {name:?}; known: none, {}", names.join(", ")))
            }),
    }
}

impl Model for Conductor {
    #[inline]
    fn sample(&self, wo: Vec3, _: f32, _: Vec2, _: TransportMode) -> Option<BsdfSample> {
        sample(self.specular_reflectance, self.eta_k, wo)
    }
    fn has_delta(&self) -> bool {
        true
    }
    fn has_non_delta(&self) -> bool {
        false
    }
    fn visit_params(&mut self, v: &mut dyn ParamVisitor) {
        v.param("specular_reflectance", ParamMut::Rgb(&mut self.specular_reflectance));
    }
}

/// Unpolarised Fresnel reflectance of a conductor with relative complex IOR `eta + i·k`, for the cosine
/// `cos_theta_i` of the incident angle (its absolute value is used).
///
/// Real-valued form of the Fresnel equations for complex η (Born & Wolf, *Principles of Optics* §14.2;
/// as in Mitsuba 3 `fresnel_conductor` and S. Lagarde, "Memo on Fresnel equations", 2013):
/// `a² + b² = sqrt((η² − κ² − sin²θ)² + 4η²κ²)`, `a = sqrt((a² + b² + η² − κ² − sin²θ)/2)`,
/// `R_s = (a² + b² + cos²θ − 2a cos θ)/(a² + b² + cos²θ + 2a cos θ)`,
/// `R_p = R_s·(cos²θ (a² + b²) + sin⁴θ − 2a cos θ sin²θ)/(cos²θ (a² + b²) + sin⁴θ + 2a cos θ sin²θ)`,
/// `F = (R_s + R_p)/2`. At normal incidence `F = ((η − 1)² + κ²)/((η + 1)² + κ²)`.
#[must_use]
pub fn fresnel_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let cos = cos_theta_i.abs().min(1.0);
    let cos2 = cos * cos;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp1 = eta * eta - k * k - sin2;
    let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
    let term1 = a2pb2 + cos2;
    let term2 = 2.0 * cos * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * cos2 + sin4;
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    let f = 0.5 * (r_s + r_p);
    // term1 + term2 > 0 unless η = κ = 0 and cos θ = 0 together (not a material): keep NaN out anyway.
    if f.is_nan() {
        1.0
    } else {
        f.clamp(0.0, 1.0)
    }
}

/// [`fresnel_conductor`] per RGB channel.
#[must_use]
pub fn fresnel_conductor_rgb(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fresnel_conductor(cos_theta_i, eta.x, k.x),
        fresnel_conductor(cos_theta_i, eta.y, k.y),
        fresnel_conductor(cos_theta_i, eta.z, k.z),
    )
}

/// The mirror direction, chosen with probability 1 (`pdf_w = 1`), weight `specular_reflectance·F(cos θo)`;
/// `None` for `wo` below the surface.
#[must_use]
pub(super) fn sample(specular_reflectance: Vec3, eta_k: Option<(Vec3, Vec3)>, wo: Vec3) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let fresnel = eta_k.map_or(Vec3::ONE, |(eta, k)| fresnel_conductor_rgb(wo.z, eta, k));
    Some(BsdfSample {
        wi_local: reflect_z(wo),
        weight: specular_reflectance * fresnel,
        pdf_w: 1.0,
        delta: true,
        pass_through: false,
    })
}

#[cfg(test)]
mod tests {
    use crate::bsdf::TwoSided;
    use super::*;
    use crate::bsdf::{fresnel_dielectric, Bsdf, TransportMode};
    use crate::math::Vec2;

    /// Reference Fresnel for complex IOR in f64 complex arithmetic (pbrt-v4 `FrComplex`, eq. 9.6 with
    /// complex η): r∥ = (η cos θi − cos θt)/(η cos θi + cos θt), r⊥ = (cos θi − η cos θt)/(cos θi + η cos θt).
    fn fresnel_complex_reference(cos_i: f64, eta: f64, k: f64) -> f64 {
        #[derive(Clone, Copy)]
        struct C(f64, f64);
        let add = |a: C, b: C| C(a.0 + b.0, a.1 + b.1);
        let sub = |a: C, b: C| C(a.0 - b.0, a.1 - b.1);
        let mul = |a: C, b: C| C(a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: C, b: C| {
            let d = b.0 * b.0 + b.1 * b.1;
            C((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
        };
        let sqrt = |a: C| {
            let r = (a.0 * a.0 + a.1 * a.1).sqrt();
            let re = (0.5 * (r + a.0)).sqrt();
            let im = (0.5 * (r - a.0)).max(0.0).sqrt().copysign(a.1);
            C(re, im)
        };
        let norm = |a: C| a.0 * a.0 + a.1 * a.1;
        let e = C(eta, k);
        let ci = C(cos_i, 0.0);
        let sin2_t = div(C(1.0 - cos_i * cos_i, 0.0), mul(e, e));
        let ct = sqrt(sub(C(1.0, 0.0), sin2_t));
        let r_par = div(sub(mul(e, ci), ct), add(mul(e, ci), ct));
        let r_perp = div(sub(ci, mul(e, ct)), add(ci, mul(e, ct)));
        0.5 * (norm(r_par) + norm(r_perp))
    }

    // Gold at roughly R, G, B wavelengths (n, k from Johnson & Christy 1972 at 650, 550, 450 nm).
    const AU_ETA: Vec3 = Vec3::new(0.143, 0.374, 1.442);
    const AU_K: Vec3 = Vec3::new(3.983, 2.385, 1.603);

    #[test]
    fn normal_incidence_matches_closed_form() {
        let f = fresnel_conductor_rgb(1.0, AU_ETA, AU_K);
        for c in 0..3 {
            let (n, k) = (AU_ETA[c], AU_K[c]);
            let expected = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
            assert!((f[c] - expected).abs() < 1e-5 * expected, "channel {c}: {} vs {expected}", f[c]);
        }
        // Gold is yellow: red reflects more than blue.
        assert!(f.x > 0.9 && f.x > f.y && f.y > f.z);
    }

    #[test]
    fn oblique_incidence_matches_complex_arithmetic() {
        for (eta, k) in [(0.143, 3.983), (1.442, 1.603), (0.2, 0.0), (2.5, 0.3), (1.5, 0.0), (0.05, 8.0)] {
            for i in 0..=20 {
                let cos = i as f32 / 20.0;
                let got = fresnel_conductor(cos, eta, k);
                let want = fresnel_complex_reference(f64::from(cos), f64::from(eta), f64::from(k));
                assert!((f64::from(got) - want).abs() < 2e-5, "eta {eta} k {k} cos {cos}: {got} vs {want}");
            }
        }
        // κ = 0 is a dielectric interface: agrees with the dielectric Fresnel term.
        for i in 1..=20 {
            let cos = i as f32 / 20.0;
            assert!((fresnel_conductor(cos, 1.5, 0.0) - fresnel_dielectric(cos, 1.5).0).abs() < 1e-5);
        }
        // Grazing incidence reflects everything.
        assert!((fresnel_conductor(0.0, 0.2, 3.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn mirror_sample_on_both_sides_when_twosided() {
        for eta_k in [None, Some((AU_ETA, AU_K))] {
            let one_sided = Bsdf::Conductor(Conductor {
                specular_reflectance: Vec3::new(1.0, 0.5, 0.25),
                eta_k,
            });
            assert!(one_sided.sample(Vec3::new(0.0, -0.6, -0.8), 0.3, Vec2::new(0.2, 0.7), TransportMode::Radiance).is_none());
            let bsdf = Bsdf::TwoSided(TwoSided(Box::new(one_sided)));
            assert!(bsdf.has_delta() && !bsdf.has_non_delta());
            for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, -0.6, -0.8), Vec3::Z] {
                let s = bsdf
                    .sample(wo, 0.3, Vec2::new(0.2, 0.7), TransportMode::Radiance)
                    .expect("mirror sample");
                assert!(s.delta && s.pdf_w == 1.0);
                assert!((s.wi_local - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-7);
                let fr = eta_k.map_or(Vec3::ONE, |(e, k)| fresnel_conductor_rgb(wo.z, e, k));
                assert!((s.weight - Vec3::new(1.0, 0.5, 0.25) * fr).abs().max_element() < 1e-6);
                assert_eq!(bsdf.f(wo, s.wi_local, TransportMode::Radiance), Vec3::ZERO);
                assert_eq!(bsdf.pdf_w(wo, s.wi_local), 0.0);
            }
            assert!(bsdf.sample(Vec3::X, 0.3, Vec2::new(0.2, 0.7), TransportMode::Radiance).is_none());
        }
    }
}
