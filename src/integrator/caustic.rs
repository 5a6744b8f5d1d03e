//! The caustic estimators (method.md §1, §3, §4) — the one place where `pt`, `pm` and `mis` differ.
//!
//! A caustic path reaches a non-delta eye vertex `x` as `L S⁺ x`. Two techniques can make it:
//! - **T1**, photon density estimation at `x` ([`CausticEstimator::gather`]), each photon weighted by `w₁`;
//! - **T2**, a BSDF sample at `x` followed through ≥1 delta vertex to an emitter, weighted by `w₂`
//!   ([`CausticEstimator::t2_weight`]).
//!
//! | estimator | w₁ | w₂ |
//! |---|---|---|
//! | `pt`  | — (no photon map) | 1 |
//! | `pm`  | 1 | 0 |
//! | `mis` | q₁²/(q₁²+q₂²) | 1 − w₁ |
//!
//! `q₁ = N·p_emit·|cos θ|·ΔA / α` (paper eq. 2 with `Le/Φ` generalised to the emission density `p_emit`
//! per unit area and projected solid angle, method.md §4; `photon::emission`) and `q₂ = pdf_w` of the
//! BSDF sampler at `x`. T1 reads `p_emit` from the photon, T2 asks the emission model for the light
//! point it reached.
//! Both sides call [`CausticEstimator::q1`] and the project's one MIS function
//! [`crate::sampling::mis::mis_weight_pair`], so `w₁ + w₂ = 1` for the same path by construction.
//!
//! Emitters that emit no photons (the `constant` emitter, see `photon::emit`) have no T1 technique, so
//! their caustics keep `w₂ = 1` in every estimator; so do paths whose delta chain is longer than the
//! photon pass follows ([`crate::photon::photon_chain_reaches`], the one rule both sides ask).

use crate::bsdf::{Bsdf, TransportMode};
use crate::math::Vec3;
use crate::photon::kdtree::KnnResult;
use crate::photon::{photon_chain_reaches, PhotonEmission, PhotonMap};
use crate::sampling::mis::mis_weight_pair;
use crate::scene::{Estimator, SurfaceInteraction};

/// What T2 needs to remember about the non-delta vertex `x` a BSDF-sampled ray left from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticOrigin {
    /// `q₂`: the solid-angle pdf with which the BSDF sampler at `x` produced the direction.
    pub pdf_w: f32,
    /// `|cos θ|` between that direction and the shading normal at `x`.
    pub cos_theta: f32,
    /// The k-NN area `ΔA(x)` (method.md §3).
    pub delta_area: f32,
    /// `α`: samples per pixel sharing the photon map if `x` is the first non-delta eye vertex, else 1.
    pub alpha: f32,
}

/// Result of the density estimate at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gather {
    /// `L₁(x, ωₒ) = Σₚ w₁(p)·f(x, ωₒ, ωₚ)·Φₚ / ΔA` (method.md §3).
    pub l1: Vec3,
    /// `ΔA = π r²`, clamped from below by [`CausticEstimator::min_area`].
    pub delta_area: f32,
    /// Number of photons that entered the estimate.
    pub photons: u32,
}

/// The caustic estimator of one render pass.
pub struct CausticEstimator<'a> {
    estimator: Estimator,
    map: Option<&'a PhotonMap>,
    knn: usize,
    max_radius: f32,
    /// Lower bound on ΔA: coincident photons give r → 0 (method.md §3). See [`min_delta_area`].
    min_area: f32,
}

/// Lower bound on ΔA (method.md §3): `π·r_floor²` with `r_floor = min(10⁻³·r_max, 5·10⁻⁵·R)`, R the
/// scene's bounding radius (5·10⁻⁵·R is 10⁻³ of the default `r_max` = 5% of R). It follows the scene's
/// scale, never only the user's search bound: a clamp of `π(10⁻³·r_max)²` alone made every estimate
/// of a render with `r_max` = 10⁶ cover 3·10⁶ units², which erased the caustic (issue 13 §2). The
/// `r_max` term keeps the floor below `π·r_max²`, the largest area an estimate can have.
#[must_use]
pub fn min_delta_area(max_radius: f32, scene_radius: f32) -> f32 {
    let r_floor = (1e-3 * max_radius).min(5e-5 * scene_radius);
    (std::f32::consts::PI * r_floor * r_floor).max(f32::MIN_POSITIVE)
}

impl<'a> CausticEstimator<'a> {
    /// `map` is `None` for `pt`, and for `pm`/`mis` when the scene needs no photon pass.
    /// `scene_radius`: the scene's bounding radius (sets the floor of ΔA, [`min_delta_area`]).
    #[must_use]
    pub fn new(estimator: Estimator, map: Option<&'a PhotonMap>, knn: usize, max_radius: f32, scene_radius: f32) -> Self {
        let map = if estimator == Estimator::Pt { None } else { map };
        Self { estimator, map, knn: knn.max(1), max_radius, min_area: min_delta_area(max_radius, scene_radius) }
    }

    /// Whether density estimation runs at non-delta vertices (a photon map exists).
    #[must_use]
    pub fn active(&self) -> bool {
        self.map.is_some()
    }

    #[must_use]
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    #[must_use]
    pub fn min_area(&self) -> f32 {
        self.min_area
    }

    /// `q₁ = N·p_emit·|cos θ|·ΔA / α` — paper eq. 2 (where `p_emit = Le/Φ`), method.md §4. Computed in
    /// f64; a value beyond f32 saturates to ∞, which the MIS function maps to its limit.
    #[must_use]
    pub fn q1(&self, pdf_emit: f32, cos_theta: f32, delta_area: f32, alpha: f32) -> f32 {
        let Some(map) = self.map else { return 0.0 };
        (map.emitted() as f64 * f64::from(pdf_emit) * f64::from(cos_theta.abs()) * f64::from(delta_area) / f64::from(alpha)) as f32
    }

    /// The emission model of this pass's photons (T2 asks it for `p_emit`); `None` without photons.
    #[must_use]
    pub fn emission(&self) -> Option<&PhotonEmission> {
        self.map.and_then(PhotonMap::emission)
    }

    /// T1 at `x`: the k-NN density estimate, each photon weighted by `w₁` (method.md §3, §4).
    /// Photons arriving from the other side of the surface than `wo` are rejected inside the search.
    pub fn gather(&self, si: &SurfaceInteraction, wo_world: Vec3, bsdf: &Bsdf, alpha: f32, scratch: &mut KnnResult) -> Gather {
        let Some(map) = self.map else {
            return Gather { l1: Vec3::ZERO, delta_area: self.min_area, photons: 0 };
        };
        let ng = si.ng;
        let wo_side = wo_world.dot(ng);
        map.tree().knn(si.p, self.knn, self.max_radius, |ph| ph.wi_world().dot(ng) * wo_side > 0.0, scratch);
        let delta_area = (std::f32::consts::PI * scratch.r2()).max(self.min_area);
        let wo_local = si.frame.to_local(wo_world);
        let mut sum = Vec3::ZERO;
        let photons = map.tree().photons();
        // q₁ = (N·ΔA/α)·p_emit·|cos θ|: the bracket is the same for every photon of this estimate.
        let q1_scale = self.q1(1.0, 1.0, delta_area, alpha);
        for nb in scratch.neighbors() {
            let ph = &photons[nb.index as usize];
            let wi_local = si.frame.to_local(ph.wi_world());
            let w1_f = match self.estimator {
                Estimator::Mis => {
                    let (f, q2) = bsdf.f_pdf(wo_local, wi_local, TransportMode::Radiance);
                    if f == Vec3::ZERO {
                        continue;
                    }
                    let q1 = q1_scale * ph.pdf_emit() * wi_local.z.abs();
                    mis_weight_pair(q1, q2).0 * f
                }
                _ => bsdf.f(wo_local, wi_local, TransportMode::Radiance),
            };
            sum += w1_f * ph.power();
        }
        Gather { l1: sum / delta_area, delta_area, photons: scratch.len() as u32 }
    }

    /// T2's weight for a light reached from `origin` through `delta_vertices` ≥ 1 delta-sampled vertices,
    /// whose light point a photon would leave with density `pdf_emit` (0 for emitters without photons).
    /// T1 cannot make the path when `pdf_emit` is 0, or when the photon pass cuts a chain that long
    /// ([`photon_chain_reaches`]): then `w₂ = 1`.
    #[must_use]
    pub fn t2_weight(&self, origin: &CausticOrigin, pdf_emit: f32, delta_vertices: u32) -> f32 {
        if self.map.is_none() || !photon_chain_reaches(delta_vertices) || pdf_emit.is_nan() || pdf_emit <= 0.0 {
            return 1.0;
        }
        match self.estimator {
            Estimator::Pt => 1.0,
            Estimator::Pm => 0.0,
            Estimator::Mis => {
                let q1 = self.q1(pdf_emit, origin.cos_theta, origin.delta_area, origin.alpha);
                mis_weight_pair(q1, origin.pdf_w).1
            }
        }
    }
}
