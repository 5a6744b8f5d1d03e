//! What light loses and keeps crossing a rough dielectric coating, as Mitsuba 3.9.1's `roughplastic`
//! precomputes it (`parameters_changed`, with `eval_transmittance` and `eval_reflectance` of
//! include/mitsuba/render/microfacet.h):
//!
//! - `T(μ)`: the fraction of light arriving at `cos θ = μ` from outside that the coating transmits, the mean
//!   over visible normals `m` of `(1 − F(wi·m, η))·G1(wt, m)` (`wt` the refracted direction, 0 where it does
//!   not go inside), tabulated at `μᵢ = max(10⁻⁶, i/63)`, i = 0…63, and linearly interpolated between them;
//! - `R_int`: the coating's diffuse reflectance seen from inside, `2·mean_i(R(μᵢ)·μᵢ)` over the same 64
//!   points, `R(μ)` the mean over visible normals of `F(wi·m, 1/η)·G1(wr, m)` (`wr` reflected, 0 below the
//!   surface) — the rough counterpart of `plastic`'s `F_dr(1/η)`.
//!
//! Each mean over visible normals is Mitsuba's quadrature: a tensor Gauss–Legendre rule on the unit square
//! of the sampler's random numbers (32 × 32 nodes, 128 × 128 where the relative index is below 1 and total
//! internal reflection makes the integrand kink), mapped through the visible-normal sampler. Our sampler
//! maps the square to the normals differently from Mitsuba's (Heitz 2018's polar map for GGX, an exact slope
//! inversion for Beckmann), so the nodes sample the same integrand at other normals: the tables agree with
//! Mitsuba's to the quadrature's accuracy (measured in the tests), not bit for bit.
//!
//! The tables depend on the distribution type, α and η alone; they are built once per distinct triple
//! (a process-wide memo: a scene's roughplastic materials usually share them).

use std::sync::{Arc, Mutex};

use super::microfacet::{Microfacet, MicrofacetType};
use super::fresnel_dielectric;
use crate::math::{Vec2, Vec3};

/// Points of the `T(μ)` table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub(super) const RES: usize = 64;

/// A rough coating's transmittance table and internal diffuse reflectance (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughCoating {
    /// `T(μᵢ)`.
    transmittance: [f32; RES],
    /// `R_int`.
    pub internal_reflectance: f32,
}

impl RoughCoating {
    /// The tables of an isotropic distribution `kind` of roughness `alpha` over relative index `eta`,
    /// shared with every earlier request for the same triple.
    pub(super) fn get(kind: MicrofacetType, alpha: f32, eta: f32) -> Arc<Self> {
        type Memo = Vec<((MicrofacetType, u32, u32), Arc<RoughCoating>)>;
        static MEMO: Mutex<Memo> = Mutex::new(Vec::new());
        let key = (kind, alpha.to_bits(), eta.to_bits());
        if let Some((_, t)) = MEMO.lock().unwrap_or_else(std::sync::PoisonError::into_inner).iter().find(|(k, _)| *k == key) {
            return Arc::clone(t);
        }
        // Built outside the lock (a few ms to a second); a race builds the same value twice.
        let table = Arc::new(Self::new(kind, alpha, eta));
        let mut memo = MEMO.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, t)) = memo.iter().find(|(k, _)| *k == key) {
            return Arc::clone(t);
        }
        memo.push((key, Arc::clone(&table)));
        table
    }

    /// Computes the tables (Mitsuba's `parameters_changed`).
    #[must_use]
    pub fn new(kind: MicrofacetType, alpha: f32, eta: f32) -> Self {
        let md = Microfacet::isotropic(kind, alpha, true);
        let mu = |i: usize| (i as f32 / (RES - 1) as f32).max(1e-6);
        let transmittance = std::array::from_fn(|i| visible_normal_mean(&md, mu(i), eta, transmitted));
        let reflectance: f64 = (0..RES).map(|i| f64::from(visible_normal_mean(&md, mu(i), 1.0 / eta, reflected) * mu(i))).sum();
        Self { transmittance, internal_reflectance: (2.0 * reflectance / RES as f64) as f32 }
    }

    /// `T(μ)` for `μ = cos θ` in `(0, 1]`, interpolated linearly (Mitsuba's `lerp_gather`).
    #[inline]
    #[must_use]
    pub fn transmittance(&self, mu: f32) -> f32 {
        let x = mu * (RES - 1) as f32;
        let i = (x as usize).min(RES - 2);
        let (t0, t1) = (self.transmittance[i], self.transmittance[i + 1]);
        let w = x - i as f32;
        t0 + w * (t1 - t0)
    }
}

/// `(1 − F)·G1(wt, m)` of the light from `wi` refracted at `m`, 0 unless it goes inside.
fn transmitted(md: &Microfacet, wi: Vec3, m: Vec3, eta: f32) -> f32 {
    let wi_m = wi.dot(m);
    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wi_m, eta);
    let wt = super::roughdielectric::refract(wi, m, wi_m, cos_t, eta_ti);
    if !(wt.z < 0.0) {
        return 0.0;
    }
    // G1 of the refracted direction, seen from below: the microfacet must face it (wt·m < 0).
    let up = Vec3::new(wt.x, wt.y, -wt.z);
    let g1 = if wt.dot(m) < 0.0 { md.g1_over_cos_unmasked(up) * up.z } else { 0.0 };
    (1.0 - f) * g1
}

/// `F·G1(wr, m)` of the light from `wi` reflected at `m`, 0 below the surface.
fn reflected(md: &Microfacet, wi: Vec3, m: Vec3, eta: f32) -> f32 {
    let wi_m = wi.dot(m);
    let wr = 2.0 * wi_m * m - wi;
    if !(wr.z > 0.0) {
        return 0.0;
    }
    fresnel_dielectric(wi_m, eta).0 * md.g1_over_cos(wr, m) * wr.z
}

/// The mean of `g(md, wi, m, eta)` over the visible normals of `wi = (sin θ, 0, μ)`: Gauss–Legendre on the
/// sampler's unit square (module docs).
fn visible_normal_mean(md: &Microfacet, mu: f32, eta: f32, g: fn(&Microfacet, Vec3, Vec3, f32) -> f32) -> f32 {
    let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let (nodes, weights) = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
    let mut sum = 0.0f64;
    for (&x, &wx) in nodes.iter().zip(&weights) {
        for (&y, &wy) in nodes.iter().zip(&weights) {
            let u = Vec2::new(0.5 * x as f32 + 0.5, 0.5 * y as f32 + 0.5);
            let m = md.sample_normal(wi, u);
            sum += f64::from(g(md, wi, m, eta)) * wx * wy;
        }
    }
    // The weights of each axis sum to 2 on [−1, 1].
    (0.25 * sum) as f32
}

/// Nodes and weights of the `n`-point Gauss–Legendre rule on `[−1, 1]`: the roots of `P_n` by Newton's
/// method from Chebyshev guesses, weights `2/((1 − x²) P_n'(x)²)` (Abramowitz & Stegun 25.4.29; Mitsuba's
/// `quad::gauss_legendre`).
#[must_use]
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    // (P_n(x), P_n'(x)) by the three-term recurrence.
    let legendre = |x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=n {
            let k = k as f64;
            (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
        }
        (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
    };
    let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n.div_ceil(2) {
        let mut x = -(std::f64::consts::PI * (2 * i + 1) as f64 / (2 * n) as f64).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(x);
            let step = p / dp;
            x -= step;
            if step.abs() <= 4.0 * x.abs() * f64::EPSILON {
                break;
            }
        }
        let dp = legendre(x).1;
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        (nodes[i], nodes[n - 1 - i], weights[i], weights[n - 1 - i]) = (x, -x, w, w);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 32, 128] {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-12, "n {n}");
            // Exact up to degree 2n − 1: ∫x^k = 2/(k + 1) for even k.
            for k in (0..2 * n).step_by(2).take(20) {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                assert!((got - 2.0 / (k as f64 + 1.0)).abs() < 1e-10, "n {n} k {k}: {got}");
            }
            assert!(x.windows(2).all(|p| p[0] < p[1]), "n {n}: nodes not increasing");
        }
    }
}
