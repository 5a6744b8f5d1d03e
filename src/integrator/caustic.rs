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
//! T1 runs at a vertex with a probability `P` ([`CausticEstimator::gather_probability`], method.md §3.1)
//! and a run divides its estimate by `P`; the weights do not change, and where T1 was skipped T2 finds
//! ΔA by the same search ([`OriginArea::Deferred`]).
//!
//! Delta lights (point, spot, directional) have no T2 technique: no BSDF-sampled ray reaches them, so
//! their photons keep `w₁ = 1` (`p_emit = ∞`, method.md §4.1) and `mis` equals `pm` on their caustics.
//! Emitters that emit no photons (the `constant` emitter, see `photon::emit`) have no T1 technique, so
//! their caustics keep `w₂ = 1` in every estimator; so do paths whose delta chain is longer than the
//! photon pass follows ([`crate::photon::photon_chain_reaches`], the one rule both sides ask).
//!
//! `max_depth` (method.md §2.1): a photon of `m` delta bounces gathered at a vertex `x` of eye depth `d`
//! makes a path of `d + m + 1` segments, and Mitsuba's `max_depth` counts segments (its path tracer
//! stops at that depth, and so does ours). So T1 counts only the photons with `m ≤`
//! [`crate::photon::longest_chain`]`(d, max_depth)`, the photon pass traces no chain that fits at no eye
//! depth, and T2, whose paths stop at `max_depth` by themselves, asks the same rule for its weight:
//! `w₁ + w₂ = 1` on every path either technique makes, and a longer path is made by neither.

use crate::bsdf::{Bsdf, BsdfAtWo, TransportMode};
use crate::math::{Vec3, Vec4};
use crate::photon::{KnnMemory, KnnResult};
use crate::photon::{photon_chain_reaches, CellAt, Near, OccupancyGrid, PhotonCounts, PhotonsNear, PhotonEmission, PhotonMap};
use crate::sampling::mis::mis_weight_pair;
use crate::scene::{Estimator, SurfaceInteraction};

/// `(q₁, q₂)` of one photon's path at `x` (method.md §4): `q₁ = q1_scale·p_emit·|cos θ|` with
/// `q1_scale = N·ΔA/α`, and `q₂` the BSDF pdf of the photon's direction. A delta light's photon
/// (`p_emit = ∞`, method.md §4.1) has `q₁ = ∞` and `q₂ = 0`: no BSDF-sampled path reaches a delta light,
/// so T2's density for that path is 0 and the MIS function's first rule gives `w₁ = 1`.
#[inline]
fn photon_densities(q1_scale: f32, pdf_emit: f32, cos_theta: f32, q2: f32) -> (f32, f32) {
    if pdf_emit == f32::INFINITY {
        (f32::INFINITY, 0.0)
    } else {
        (q1_scale * pdf_emit * cos_theta, q2)
    }
}

/// The gather's acceptance test (method.md §3): a photon arriving along `wi` (unit, pointing back toward the
/// light) at a vertex of geometric normal `ng` seen from `wo_side = ωₒ·n_g` enters the estimate only on ωₒ's
/// side, `(ωₚ·n_g)·(ωₒ·n_g) > 0`. So T1 makes no path that crosses the surface at `x` (light transmitted by a
/// rough dielectric, or a reflection a shading normal sends below `n_g`), and T2 must take such a path whole,
/// `w₂ = 1` (method.md §1.1): the path tracer asks this same function of the direction it sampled at `x`.
#[must_use]
#[inline]
pub fn t1_accepts(wi: Vec3, ng: Vec3, wo_side: f32) -> bool {
    wi.dot(ng) * wo_side > 0.0
}

/// A name for the gather's acceptance test `ωₚ·n_g · (ωₒ·n_g) > 0`, which depends on `n_g` and on the side
/// of `ωₒ` only: equal normals and sides give equal keys ([`crate::photon::KdTree::knn_warm`]).
fn acceptance_key(ng: Vec3, wo_above: bool) -> u64 {
    let [x, y, z] = ng.to_array().map(f32::to_bits);
    (u64::from(x) | u64::from(y) << 32) ^ u64::from(z).rotate_left(16) ^ u64::from(wo_above)
}

/// Photons per batch of the density estimate's BSDF evaluation ([`CausticEstimator::gather`]).
const BATCH: usize = 64;

/// One batch of the density estimate: local directions, BSDF values and pdfs, photon indices.
#[derive(Clone, Debug)]
struct GatherBatch {
    wi: [[f32; BATCH]; 3],
    f: [[f32; BATCH]; 3],
    /// The BSDF's pdfs, then (`mis`) the photons' q₂.
    pdf: [f32; BATCH],
    index: [u32; BATCH],
    /// `mis`: the photons' q₁ and their weights w₁.
    q1: [f32; BATCH],
    w1: [f32; BATCH],
}

impl Default for GatherBatch {
    fn default() -> Self {
        GatherBatch { wi: [[0.0; BATCH]; 3], f: [[0.0; BATCH]; 3], pdf: [0.0; BATCH], index: [0; BATCH], q1: [0.0; BATCH], w1: [0.0; BATCH] }
    }
}

/// What the gather's searches need besides their inputs, in two parts:
/// - `buffers` ([`GatherBuffers`]): the k-NN result and the batch buffer, which carry nothing from one
///   query to the next; one per tile;
/// - `memory` ([`GatherMemory`]): the recent searches, which the warm start and the roulette's bound read;
///   the render keeps one per pixel, so that a pixel's searches follow one another as they would alone.
pub struct GatherScratch<'a> {
    pub buffers: &'a mut GatherBuffers,
    pub memory: &'a mut GatherMemory,
}

impl<'a> GatherScratch<'a> {
    #[must_use]
    pub fn new(buffers: &'a mut GatherBuffers, memory: &'a mut GatherMemory) -> Self {
        GatherScratch { buffers, memory }
    }
}

/// Buffers and memory owned together: the scratch of one path at a time ([`GatherState::scratch`]).
#[derive(Clone, Debug, Default)]
pub struct GatherState {
    pub buffers: GatherBuffers,
    pub memory: GatherMemory,
}

impl GatherState {
    pub fn scratch(&mut self) -> GatherScratch<'_> {
        GatherScratch { buffers: &mut self.buffers, memory: &mut self.memory }
    }
}

/// The buffers of [`GatherScratch`]: the k-NN result and the batch buffer (2.5 KiB, zeroed once here
/// rather than once per query: a query reads only the entries it wrote).
#[derive(Clone, Debug, Default)]
pub struct GatherBuffers {
    knn: KnnResult,
    batch: GatherBatch,
}

impl GatherBuffers {
    /// The last search's squared radius ([`KnnResult::r2`]).
    #[must_use]
    pub fn knn_r2(&self) -> f32 {
        self.knn.r2()
    }
}

/// The memory of [`GatherScratch`]: the recent searches ([`KnnMemory`]) and the last leaf bound of
/// [`CausticEstimator::estimate_bound`]. Small and `Copy` (~190 bytes), so each pixel keeps its own.
#[derive(Clone, Copy, Debug, Default)]
pub struct GatherMemory {
    knn: KnnMemory,
    leaf_bound: Option<LeafBound>,
}

/// What [`CausticEstimator::look_up`] finds at a vertex: the occupancy grid's cell at `x`, which the
/// roulette's bound and the search both read, and that cell's photon sums.
#[derive(Clone, Copy, Debug)]
pub struct LookedUp {
    cell: CellAt,
    /// `OccupancyGrid::photons_in(cell)`.
    near: Option<PhotonsNear>,
}

/// A non-delta eye vertex as the caustic estimators see it, made once per vertex
/// ([`CausticEstimator::receiver`]): the shading data, ωₒ in both frames, the BSDF prepared at ωₒ, and
/// the [`LookedUp`] cell.
#[derive(Clone, Copy, Debug)]
pub struct Receiver<'s> {
    pub si: &'s SurfaceInteraction,
    pub wo_world: Vec3,
    /// `si.frame.to_local(wo_world)`.
    pub wo_local: Vec3,
    /// `bsdf` at `wo_local` with its ωₒ-only work done: the roulette's bound and the density estimate
    /// both evaluate it (bit for bit `bsdf.f_pdf`), so that work is done once per vertex.
    at_wo: BsdfAtWo<'s>,
    cell: CellAt,
    near: Option<PhotonsNear>,
}

/// The photons of the kd-tree's leaves within `radius` of `p` ([`crate::photon::KdTree::bound_within`]):
/// their power (largest channel) and a box of their directions. A bound for any ball inside that one, so
/// the eye samples of a pixel, whose first hits lie a fraction of the k-NN radius apart, share one.
#[derive(Clone, Copy, Debug)]
struct LeafBound {
    p: Vec3,
    radius: f32,
    power: f32,
    lo: Vec3,
    hi: Vec3,
}

/// The radius of a new [`LeafBound`] over the one needed: a wider ball serves more queries and holds more
/// power (at most this squared, 1.56×, on a uniform density).
const LEAF_BOUND_REACH: f32 = 1.1;

/// The smallest and largest q₁ (method.md §4) that reached the MIS function in a render: finite, positive
/// values only (a delta light's `q₁ = ∞` and a grazing photon's `q₁ = 0` are its rules' limits, not
/// numbers it must survive). The stats report it (`mis_q1_range`), so a run shows how far from 1 the
/// weight function's inputs went on real scenes (issue 13 §3). Empty for `pt` and `pm`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Q1Range {
    pub min: f32,
    pub max: f32,
}

impl Default for Q1Range {
    fn default() -> Self {
        Self { min: f32::INFINITY, max: 0.0 }
    }
}

impl Q1Range {
    /// Records one q₁ (NaN, 0 and ∞ are left out). Plain compares, not `f32::min`/`max`: the bounds are
    /// never NaN, so the result is the same without the NaN handling (T2 calls this per path; the gather
    /// records its photons by [`Q1Range::add_batch`]).
    #[inline]
    pub fn add(&mut self, q1: f32) {
        if q1 > 0.0 && q1 < f32::INFINITY {
            if q1 < self.min {
                self.min = q1;
            }
            if q1 > self.max {
                self.max = q1;
            }
        }
    }

    /// Records the q₁ of a batch's photons whose BSDF value is not zero (`f[c][j]`, RGB, ≥ 0), as
    /// [`Q1Range::add`] would one by one: four photons per SIMD vector, their lanes selected (a NaN, 0, ∞
    /// or f = 0 lane gives ∞ to the minimum and 0 to the maximum) and folded by `minps`/`maxps`, with no
    /// branch per photon; the slices are of one length. Per photon, the compares and stores of `add` were
    /// a fifth of the extra instructions of a `mis` gather over a `pm` one; this form takes 4–5 % off a
    /// `mis` gather (callgrind: 19,760 → 18,959 instructions on teapot-glossy, 7,841 → 7,437 on
    /// cornell-caustics), with the same range and bit-identical images.
    pub fn add_batch(&mut self, q1: &[f32], f: [&[f32]; 3]) {
        let n = q1.len();
        let whole = n - n % 4;
        let (mut lo, mut hi) = (Vec4::splat(self.min), Vec4::splat(self.max));
        for j in (0..whole).step_by(4) {
            let q = Vec4::from_slice(&q1[j..j + 4]);
            let f_max = Vec4::from_slice(&f[0][j..j + 4]).max(Vec4::from_slice(&f[1][j..j + 4])).max(Vec4::from_slice(&f[2][j..j + 4]));
            let kept = q.cmpgt(Vec4::ZERO) & q.cmplt(Vec4::INFINITY) & f_max.cmpgt(Vec4::ZERO);
            lo = lo.min(Vec4::select(kept, q, Vec4::INFINITY));
            hi = hi.max(Vec4::select(kept, q, Vec4::ZERO));
        }
        (self.min, self.max) = (lo.min_element(), hi.max_element());
        for j in whole..n {
            if f[0][j] > 0.0 || f[1][j] > 0.0 || f[2][j] > 0.0 {
                self.add(q1[j]);
            }
        }
    }

    pub fn merge(&mut self, o: &Q1Range) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }

    /// `[min, max]`, or `None` if no q₁ was recorded.
    #[must_use]
    pub fn get(&self) -> Option<[f32; 2]> {
        (self.min <= self.max).then_some([self.min, self.max])
    }
}

/// Roulette on the density estimate (method.md §3.1): T1 runs at `x` with probability
/// `P = min(1, c/(κ·L))`, no lower than [`GATHER_MIN_PROBABILITY`], where `c` bounds what it can add and `L`
/// is the largest channel of the radiance the eye sample has collected so far (`P = 1` while that is 0).
/// With the real bound, κ = 2 instead of 1 takes 18 % of cornell-caustics' queries and 16 % of
/// teapot-glossy's away for +0.6 % and +0.4 % RMSE per sample; κ = 4, 25 % for +0.8 % and +1.2 %
/// (ARCHITECTURE.md, "Roulette on the density estimate").
pub const GATHER_ROULETTE_KAPPA: f32 = 2.0;

/// The least probability with which T1 runs at a vertex whose cell holds photons (the largest factor
/// `1/P` by which a run scales its estimate). The bound `c` already caps what a run adds at `κ·L`; the floor
/// limits the damage where `c` falls short of the estimate (its f is taken at one direction of the box).
/// 0.03 instead of 0.1: cornell-caustics −20 % queries, teapot-glossy −11 %, RMSE per sample within
/// ±0.3 % (ARCHITECTURE.md, "Roulette on the density estimate").
pub const GATHER_MIN_PROBABILITY: f32 = 0.03;


/// Where T2 finds the k-NN area `ΔA(x)` (method.md §3.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OriginArea {
    /// The density estimate at `x` ran and found this ΔA.
    Known(f32),
    /// The estimate at `x` was skipped: T2 runs the same search for ΔA alone
    /// ([`CausticEstimator::area_at`]) when a caustic path from `x` needs it, at `p` with the acceptance
    /// test of geometric normal `ng` and `wo_side = ωₒ·n_g`.
    Deferred { p: Vec3, ng: Vec3, wo_side: f32 },
}

/// What T2 needs to remember about the non-delta vertex `x` a BSDF-sampled ray left from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticOrigin {
    /// `q₂`: the solid-angle pdf with which the BSDF sampler at `x` produced the direction.
    pub pdf_w: f32,
    /// `|cos θ|` between that direction and the shading normal at `x`.
    pub cos_theta: f32,
    /// The k-NN area `ΔA(x)` (method.md §3), or how to find it.
    pub area: OriginArea,
    /// `α`: samples per pixel sharing the photon map if `x` is the first non-delta eye vertex, else 1.
    pub alpha: f32,
    /// [`crate::photon::longest_chain`] at `x`: the longest delta chain T1 could have used there; 0 when the
    /// sampled direction crossed the surface at `x`, where T1 uses no photon at all ([`t1_accepts`]).
    pub longest_chain: u32,
}

/// Result of the density estimate at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gather {
    /// `L₁(x, ωₒ) = Σₚ w₁(p)·f(x, ωₒ, ωₚ)·Φₚ / ΔA` (method.md §3).
    pub l1: Vec3,
    /// `ΔA = π r²`, clamped from below by [`CausticEstimator::min_area`] at `x`.
    pub delta_area: f32,
    /// Number of photons that entered the estimate.
    pub photons: u32,
    /// The q₁ of its photons (`mis` only).
    pub q1: Q1Range,
}

/// The caustic estimator of one render pass.
pub struct CausticEstimator<'a> {
    estimator: Estimator,
    map: Option<&'a PhotonMap>,
    knn: usize,
    max_radius: f32,
    /// The radius of the photons' bounding sphere (the scene's when they have none), a scale of the floor
    /// of ΔA ([`min_delta_area`]).
    photons_radius: f32,
    /// `s ∈ (0, 1]`: the estimate uses the photons within `r² = s·r²_kNN` and `ΔA = π·s·r²_kNN` (the
    /// progressive schedule of method.md §6; 1 = the plain k-NN estimate).
    area_scale: f32,
    /// Where no photon lies within `max_radius` (`None` without photons or for an infinite radius).
    occupancy: Option<OccupancyGrid>,
    /// How many photons can lie within `max_radius` of a point (`None` where no table is built).
    counts: Option<PhotonCounts>,
}

/// Lower bound on ΔA at the query point `x` (method.md §3): coincident photons give r → 0, and ΔA divides
/// the estimate. `π·r_floor²` with
///
/// `r_floor = min(10⁻³·r_max, 5·10⁻⁵·R, max(4ε·‖x‖∞, 10⁻⁹·R))`,
///
/// R the radius of the photons' bounding sphere, ε the f32 epsilon. Each term is a scale the floor must
/// stay under:
/// - `10⁻³·r_max` keeps it below `π·r_max²`, the largest area an estimate can have;
/// - `5·10⁻⁵·R` follows the extent of the photons (10⁻³ of the former default `r_max`, 5% of the scene's radius,
///   in an ordinary scene), never the user's search bound alone (a clamp of `π(10⁻³·r_max)²` made every
///   estimate of a render with `r_max` = 10⁶ cover 3·10⁶ units², which erased the caustic, issue 13 §2)
///   nor the whole scene's size (a dim light of side 2·10³ over a 3-unit scene blurred the caustic away);
/// - `4ε·‖x‖∞`, four units in the last place of `x`'s coordinates, is the finest area positions at `x`
///   resolve: the extent R is set by the farthest photon, and one photon scattered 470 units away on a
///   ground plane of half side 10⁴ made R = 278 and the floor (0.014)² — wider than a glass sphere's focus
///   3 units from it, whose caustic came out 42% dark. Near the origin `10⁻⁹·R` keeps the floor above 0.
#[must_use]
pub fn min_delta_area(max_radius: f32, photons_radius: f32, x: Vec3) -> f32 {
    let resolved = (4.0 * f32::EPSILON * x.abs().max_element()).max(1e-9 * photons_radius);
    let r_floor = (1e-3 * max_radius).min(5e-5 * photons_radius).min(resolved);
    (std::f32::consts::PI * r_floor * r_floor).max(f32::MIN_POSITIVE)
}

impl<'a> CausticEstimator<'a> {
    /// `map` is `None` for `pt`, and for `pm`/`mis` when the scene needs no photon pass.
    /// `scene_radius`: the scene's bounding radius, the scale of the floor of ΔA ([`min_delta_area`]) when
    /// the photons have no extent (none, or all at one point); else their bounding sphere's radius is.
    #[must_use]
    pub fn new(estimator: Estimator, map: Option<&'a PhotonMap>, knn: usize, max_radius: f32, scene_radius: f32) -> Self {
        let map = if estimator == Estimator::Pt { None } else { map };
        let photons_radius = map.map(|m| m.tree().bounds().bounding_sphere().1).filter(|r| *r > 0.0 && r.is_finite()).unwrap_or(scene_radius);
        let occupancy = map.and_then(|m| OccupancyGrid::new(m.tree(), max_radius));
        let counts = map.and_then(|m| PhotonCounts::new(m.tree(), max_radius));
        Self { estimator, map, knn: knn.max(1), max_radius, photons_radius, area_scale: 1.0, occupancy, counts }
    }

    /// Shrinks the estimate's area to the fraction `scale` of the k-NN area (method.md §6); a scale
    /// outside (0, 1] (or NaN) leaves the plain k-NN estimate.
    #[must_use]
    pub fn with_area_scale(mut self, scale: f32) -> Self {
        self.area_scale = if scale > 0.0 && scale <= 1.0 { scale } else { 1.0 };
        self
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

    /// The floor of ΔA at `x` ([`min_delta_area`]).
    #[must_use]
    pub fn min_area(&self, x: Vec3) -> f32 {
        min_delta_area(self.max_radius, self.photons_radius, x)
    }

    /// `q₁ = N·p_emit·|cos θ|·ΔA / α` — paper eq. 2 (where `p_emit = Le/Φ`), method.md §4. Computed in
    /// f64; a value beyond f32 saturates to ∞, which the MIS function maps to its limit.
    #[must_use]
    pub fn q1(&self, pdf_emit: f32, cos_theta: f32, delta_area: f32, alpha: f32) -> f32 {
        let Some(map) = self.map else { return 0.0 };
        if pdf_emit == f32::INFINITY {
            // A delta light's start (method.md §4.1).
            return f32::INFINITY;
        }
        (map.emitted() as f64 * f64::from(pdf_emit) * f64::from(cos_theta.abs()) * f64::from(delta_area) / f64::from(alpha)) as f32
    }

    /// The emission model of this pass's photons (T2 asks it for `p_emit`); `None` without photons.
    #[must_use]
    pub fn emission(&self) -> Option<&PhotonEmission> {
        self.map.and_then(PhotonMap::emission)
    }

    /// The occupancy grid's cell at `si.p` and its photon sums, which a [`Receiver`] reads. The path tracer
    /// looks them up before the vertex's shadow ray, so that the two dependent cache misses of the look-up
    /// (the grid's bits, then the cell's sums) overlap the ray's traversal instead of stalling the
    /// roulette's bound (perf: half of `estimate_bound`'s time was the wait on the sums).
    #[must_use]
    pub fn look_up(&self, si: &SurfaceInteraction) -> LookedUp {
        // Without a grid the search starts from the root and no bound reads the cell.
        let cell = self.occupancy.as_ref().map_or(CellAt::NotFinite, |grid| grid.cell_at(si.p));
        let near = self.occupancy.as_ref().and_then(|grid| grid.photons_in(cell));
        LookedUp { cell, near }
    }

    /// The vertex `si` with outgoing direction `wo_world` (`wo_local` in its shading frame) and BSDF `bsdf`,
    /// and its [`CausticEstimator::look_up`], as [`CausticEstimator::gather_probability`] and
    /// [`CausticEstimator::gather`] take it.
    #[must_use]
    pub fn receiver<'s>(&self, si: &'s SurfaceInteraction, bsdf: &'s Bsdf, wo_world: Vec3, wo_local: Vec3, looked_up: LookedUp) -> Receiver<'s> {
        debug_assert!(wo_local.distance(si.frame.to_local(wo_world)) <= 1e-5, "wo_local is not wo_world in the shading frame");
        let LookedUp { cell, near } = looked_up;
        Receiver { si, wo_world, wo_local, at_wo: BsdfAtWo::new(bsdf, wo_local, TransportMode::Radiance), cell, near }
    }

    /// The probability with which T1 runs at `x` (method.md §3.1): `P = min(1, max(β)·c/(κ·L))`, at least
    /// [`GATHER_MIN_PROBABILITY`], with `c` the bound of [`CausticEstimator::estimate_bound`] and `L` the
    /// largest channel of `collected` (the larger of the radiance the eye sample has gathered so far and its
    /// pixel's mean, for a pixel's first sample its neighbour's). 1 where `L` is 0 and where no bound is
    /// known. `scratch` is the one the estimate would use (its recent queries bound the radius).
    #[must_use]
    pub fn gather_probability(&self, rx: &Receiver, beta: Vec3, collected: Vec3, scratch: &mut GatherScratch<'_>) -> f32 {
        let budget = GATHER_ROULETTE_KAPPA * collected.max_element() / beta.max_element();
        if !(budget > 0.0) || budget == f32::INFINITY {
            return 1.0;
        }
        match self.estimate_bound(rx, scratch) {
            Some(c) if c < budget => (c / budget).max(GATHER_MIN_PROBABILITY),
            _ => 1.0,
        }
    }

    /// A bound `c` on the largest channel of the estimate `L₁(x)` (method.md §3.1): `f·Φ/ΔA_min`, with Φ the
    /// power of the photons that may lie within the estimate's radius, f the BSDF toward the direction of
    /// their box nearest ωₒ's mirror direction, and ΔA_min the least area the estimate can have. The tile's
    /// recent queries bound the k-NN radius, `r_lo ≤ r_k ≤ r_hi` ([`KnnResult::radius_bounds`]). In order:
    /// 1. where the occupancy grid holds no photon around `x`: 0;
    /// 2. where it holds fewer than k, the search finds fewer than k and ΔA is that of `max_radius`: the
    ///    grid's photons ([`OccupancyGrid::photons_near`]);
    /// 3. where `0 < r_lo` and `r_hi < max_radius`: the kd-tree's leaves within `r_hi`
    ///    ([`crate::photon::KdTree::bound_within`], reused while the ball stays inside the last one
    ///    computed: [`LeafBound`]), with ΔA that of `r_lo`;
    /// 4. where fewer than k photons can lie within `max_radius` ([`PhotonCounts::at_most_near`], n of them),
    ///    the search finds them all and ΔA is that of `max_radius`: n times the largest photon power (no
    ///    more than the grid's), toward the grid's direction box;
    /// 5. where `0 < r_lo`: the grid's photons, with ΔA that of `r_lo`.
    /// `None` where none applies (no recent query near `x`, and k photons or more may be within reach).
    #[must_use]
    pub fn estimate_bound(&self, rx: &Receiver, scratch: &mut GatherScratch<'_>) -> Option<f32> {
        let map = self.map?;
        let Receiver { si, wo_world, wo_local, at_wo, near, .. } = *rx;
        let mirror = si.frame.to_world(Vec3::new(-wo_local.x, -wo_local.y, wo_local.z));
        // f toward the point of a box of directions nearest the mirror direction, put on ωₒ's side (the
        // non-delta lobes reflect), times the power, over the area.
        let bound = |power: f32, lo: Vec3, hi: Vec3, area: f32| {
            if power == 0.0 {
                return 0.0;
            }
            let wi = si.frame.to_local(mirror.clamp(lo, hi));
            let wi = Vec3::new(wi.x, wi.y, wi.z.abs().max(1e-3).copysign(wo_local.z)).normalize();
            at_wo.f_pdf(wi).0.max_element() * power / area
        };
        // Where the search finds fewer than k photons, its area is that of max_radius.
        let area_max = || self.estimate_area(self.max_radius * self.max_radius, si.p).1;
        if let Some(near) = near {
            if near.power == 0.0 {
                return Some(0.0);
            }
            if near.fewer_than(self.knn) {
                return Some(bound(near.power, near.dirs.min(), near.dirs.max(), area_max()));
            }
        }
        // The margins cover the rounding of the recent radii and distances (as the warm start's does).
        let (r_lo, r_hi) = scratch.memory.knn.radius_bounds(si.p, self.knn, acceptance_key(si.ng, wo_world.dot(si.ng) > 0.0));
        let area_lo = || self.estimate_area(r_lo * r_lo * (1.0 - 1.0 / 65536.0), si.p).1;
        if r_lo > 0.0 && r_hi < self.max_radius {
            let r_hi = r_hi * (1.0 + 1.0 / 65536.0);
            let leaves = match scratch.memory.leaf_bound {
                Some(b) if b.p.distance(si.p) + r_hi <= b.radius => b,
                _ => {
                    let radius = (LEAF_BOUND_REACH * r_hi).min(self.max_radius);
                    let near = map.tree().bound_within(si.p, radius);
                    *scratch.memory.leaf_bound.insert(LeafBound { p: si.p, radius, power: near.power, lo: near.lo, hi: near.hi })
                }
            };
            return Some(bound(leaves.power, leaves.lo, leaves.hi, area_lo()));
        }
        // Fewer than k photons within max_radius (the fine counts): the search finds them all, over the
        // area of max_radius, and they carry at most n times the largest photon power.
        if let Some(counts) = &self.counts {
            let n = counts.at_most_near(si.p);
            if (n as usize) < self.knn {
                let power = n as f32 * counts.max_power();
                let (power, lo, hi) = near.map_or((power, Vec3::NEG_ONE, Vec3::ONE), |near| (power.min(near.power), near.dirs.min(), near.dirs.max()));
                return Some(bound(power, lo, hi, area_max()));
            }
        }
        if !(r_lo > 0.0) {
            return None;
        }
        near.map(|near| bound(near.power, near.dirs.min(), near.dirs.max(), area_lo()))
    }

    /// T1 at `x`: the k-NN density estimate, each photon weighted by `w₁` (method.md §3, §4), over the
    /// photons whose delta chain is at most `longest` ([`crate::photon::longest_chain`] at `x`: the paths
    /// they make fit `max_depth`, method.md §2.1). That filter acts on the sum only: the search, hence ΔA,
    /// the roulette's bound and T2's area, are those of all photons, so an unlimited depth gives the
    /// estimate it gave.
    /// Photons arriving from the other side of the surface than `wo` are rejected inside the search.
    /// With an area scale `s < 1` (method.md §6) only the photons within `r² = s·r²_kNN` enter, over
    /// `ΔA = π·s·r²_kNN`; that ΔA is the one returned, so T2's q₁ uses the area of the estimate made.
    /// Kept out of line (fat LTO had inlined it into `PathTracer::li`), so that callgrind's
    /// `--toggle-collect` (`scripts/bench-instructions`) and perf can name its cost; one call per search.
    #[inline(never)]
    pub fn gather(&self, rx: &Receiver, alpha: f32, longest: u32, scratch: &mut GatherScratch<'_>) -> Gather {
        let Receiver { si, wo_world, at_wo: bsdf_at_wo, cell, .. } = *rx;
        let GatherBuffers { knn, batch } = &mut *scratch.buffers;
        let (delta_area, searched) = self.search(si.p, cell, si.ng, wo_world.dot(si.ng), &mut scratch.memory.knn, knn);
        let (Some(map), Some(r2)) = (self.map, searched) else {
            return Gather { l1: Vec3::ZERO, delta_area, photons: 0, q1: Q1Range::default() };
        };
        // Directions, p_emit and power decoded once per photon at build time (KdTree::decoded): the search
        // tested the direction, and the sum below finds the rest in the same record.
        let decoded = map.tree().decoded();
        let mut sum = Vec3::ZERO;
        let mut used = 0u32;
        let mut q1_range = Q1Range::default();
        // q₁ = (N·ΔA/α)·p_emit·|cos θ|: the bracket is the same for every photon of this estimate.
        let q1_scale = self.q1(1.0, 1.0, delta_area, alpha);
        // In batches (structure of arrays, in the tile's scratch): the photons' local directions, then the
        // BSDF of all of them at once (`BsdfAtWo::f_pdf_many`, vectorised), then the weighted sum in the
        // neighbours' order.
        let mis = self.estimator == Estimator::Mis;
        for chunk in knn.neighbors().chunks(BATCH) {
            let mut n = 0;
            for nb in chunk {
                let d = &decoded[nb.index as usize];
                if nb.dist2 > r2 || u32::from(d.chain) > longest {
                    continue;
                }
                let wi_local = si.frame.to_local(d.wi);
                (batch.wi[0][n], batch.wi[1][n], batch.wi[2][n], batch.index[n]) = (wi_local.x, wi_local.y, wi_local.z, nb.index);
                n += 1;
            }
            used += n as u32;
            let [wx, wy, wz] = &batch.wi;
            let [fr, fg, fb] = &mut batch.f;
            bsdf_at_wo.f_pdf_many([&wx[..n], &wy[..n], &wz[..n]], [&mut fr[..n], &mut fg[..n], &mut fb[..n]], &mut batch.pdf[..n]);
            // One loop per estimator (not a match per photon): `w₁·f·Φ` for `mis`, `f·Φ` for `pm`.
            if mis {
                // The densities (a read of each photon's record), then all the weights in one loop of
                // vector instructions (`power_heuristic` has no branches; perf put this sum at 5.2 % of
                // teapot-glossy's `mis` render with the weight evaluated photon by photon), then the sum.
                for j in 0..n {
                    let pdf_emit = decoded[batch.index[j] as usize].pdf_emit;
                    (batch.q1[j], batch.pdf[j]) = photon_densities(q1_scale, pdf_emit, batch.wi[2][j].abs(), batch.pdf[j]);
                }
                for (w, (&q1, &q2)) in batch.w1[..n].iter_mut().zip(batch.q1[..n].iter().zip(&batch.pdf[..n])) {
                    *w = mis_weight_pair(q1, q2).0;
                }
                q1_range.add_batch(&batch.q1[..n], [&fr[..n], &fg[..n], &fb[..n]]);
                // A photon with f = 0 adds (w₁·0)·Φ = 0 (w₁ ∈ [0, 1], Φ finite): no test per photon.
                for j in 0..n {
                    let f = Vec3::new(batch.f[0][j], batch.f[1][j], batch.f[2][j]);
                    sum += (batch.w1[j] * f) * decoded[batch.index[j] as usize].power;
                }
            } else {
                for j in 0..n {
                    let f = Vec3::new(batch.f[0][j], batch.f[1][j], batch.f[2][j]);
                    sum += f * decoded[batch.index[j] as usize].power;
                }
            }
        }
        Gather { l1: sum / delta_area, delta_area, photons: used, q1: q1_range }
    }

    /// T1's k-NN search at `p` (method.md §3): the photons arriving on the side of `n_g` that `wo_side = ωₒ·n_g`
    /// gives, left in `knn`; returns the estimate's ΔA and its `r²`. `cell` is `p`'s in the occupancy grid
    /// (unread without one). `r²` is `None` when `knn` was not written:
    /// without a photon map (ΔA is then the floor at `p`), and where no photon lies within `max_radius` (the
    /// occupancy grid's answer for one memory read; ΔA is then that of `r = max_radius`).
    fn search(&self, p: Vec3, cell: CellAt, ng: Vec3, wo_side: f32, memory: &mut KnnMemory, knn: &mut KnnResult) -> (f32, Option<f32>) {
        let Some(map) = self.map else { return (self.min_area(p), None) };
        let near = self.occupancy.as_ref().map_or(Near::Tree, |grid| grid.near_in(cell));
        if near == Near::Empty {
            return (self.estimate_area(self.max_radius * self.max_radius, p).1, None);
        }
        let decoded = map.tree().decoded();
        // Warm-started from the recent queries in `memory` with the same test (the same ng and side).
        let key = acceptance_key(ng, wo_side > 0.0);
        // From the cell's list of leaves where it keeps one (OccupancyGrid::near), else from the root.
        map.tree().knn_warm_from(p, self.knn, self.max_radius, key, near.search_from(), |i| t1_accepts(decoded[i].wi, ng, wo_side), memory, knn);
        let (r2, delta_area) = self.estimate_area(knn.r2(), p);
        (delta_area, Some(r2))
    }

    /// `ΔA(x)` of a vertex whose density estimate was skipped (method.md §3.1): the same search as
    /// [`CausticEstimator::gather`]'s, so the same area the estimate would have used.
    pub fn area_at(&self, p: Vec3, ng: Vec3, wo_side: f32, scratch: &mut GatherScratch<'_>) -> f32 {
        let cell = self.occupancy.as_ref().map_or(CellAt::NotFinite, |grid| grid.cell_at(p));
        self.search(p, cell, ng, wo_side, &mut scratch.memory.knn, &mut scratch.buffers.knn).0
    }

    /// The squared radius `s·r²_kNN` of the estimate at `x` and its area ΔA (clamped, method.md §3, §6).
    fn estimate_area(&self, r2_knn: f32, x: Vec3) -> (f32, f32) {
        let r2 = r2_knn * self.area_scale;
        (r2, (std::f32::consts::PI * r2).max(self.min_area(x)))
    }

    /// T2's weight for a light reached from `origin` through `delta_vertices` ≥ 1 delta-sampled vertices,
    /// whose light point a photon would leave with density `pdf_emit` (0 for emitters without photons).
    /// T1 cannot make the path when `pdf_emit` is 0, or when its chain is longer than T1 uses at `origin`
    /// ([`photon_chain_reaches`] with `origin.longest_chain`: the photon pass's cap; `max_depth` never
    /// refuses a path T2 made, which stopped at `max_depth` itself): then `w₂ = 1`. The q₁ that reached the MIS function is added to `q1_seen`.
    /// When `x` skipped its estimate, `mis` runs the search for ΔA here ([`CausticEstimator::area_at`]) and
    /// counts it in `area_queries`.
    #[must_use]
    pub fn t2_weight(&self, origin: &CausticOrigin, pdf_emit: f32, delta_vertices: u32, q1_seen: &mut Q1Range, area_queries: &mut u64, scratch: &mut GatherScratch<'_>) -> f32 {
        if self.map.is_none() || !photon_chain_reaches(delta_vertices, origin.longest_chain) || pdf_emit.is_nan() || pdf_emit <= 0.0 {
            return 1.0;
        }
        match self.estimator {
            Estimator::Pt => 1.0,
            Estimator::Pm => 0.0,
            Estimator::Mis => {
                let delta_area = match origin.area {
                    OriginArea::Known(delta_area) => delta_area,
                    OriginArea::Deferred { p, ng, wo_side } => {
                        *area_queries += 1;
                        self.area_at(p, ng, wo_side, scratch)
                    }
                };
                let q1 = self.q1(pdf_emit, origin.cos_theta, delta_area, origin.alpha);
                q1_seen.add(q1);
                mis_weight_pair(q1, origin.pdf_w).1
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::bsdf::{Diffuse, RoughConductor};
    use super::*;
    use crate::math::{Frame, Vec2};
    use crate::photon::kdtree::KdTree;
    use crate::photon::{Photon, MAX_DELTA_CHAIN};
    use crate::sampler::Sampler;

    /// The vertex `si` seen from `wo` with BSDF `bsdf`, as the estimator's queries take it.
    fn vertex<'s>(est: &CausticEstimator, si: &'s SurfaceInteraction, bsdf: &'s Bsdf, wo: Vec3) -> Receiver<'s> {
        est.receiver(si, bsdf, wo, si.frame.to_local(wo), est.look_up(si))
    }

    /// `maps` independent maps of `m` photons uniform on the square [−1, 1]² of the plane z = 0, each
    /// arriving straight down with power 1/m (so the irradiance is E = 1/4), and the mean of `L₁` over
    /// `queries` uniform points of [−½, ½]² per map, for a white diffuse plane (f = 1/π), divided by the
    /// exact radiance E/π; also the largest |ΔA − π·s·r²_kNN| seen.
    fn mean_ratio(area_scale: f32, k: usize, maps: u64, m: u64, queries: u64) -> (f64, f32) {
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE });
        let mut sum = 0.0f64;
        let mut worst_area = 0.0f32;
        let mut state = GatherState::default();
        for map_index in 0..maps {
            let photons: Vec<Photon> = (0..m)
                .map(|i| {
                    let u = Sampler::for_key(7, map_index, i).next_2d();
                    Photon::new(Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0), Vec3::Z, Vec3::splat(1.0 / m as f32), 1.0)
                })
                .collect();
            let map = PhotonMap::new(KdTree::build(photons).unwrap(), m, None);
            let est = CausticEstimator::new(Estimator::Pm, Some(&map), k, 1.0, 1.0).with_area_scale(area_scale);
            for q in 0..queries {
                let u: Vec2 = Sampler::for_key(8, map_index, q).next_2d();
                let p = Vec3::new(u.x - 0.5, u.y - 0.5, 0.0);
                let si = SurfaceInteraction { p, p_error: Vec3::ZERO, ng: Vec3::Z, ns: Vec3::Z, frame: Frame::from_normal(Vec3::Z), uv: Vec2::ZERO, prim: 0, inst: crate::accel::FLAT, material: 0 };
                let g = est.gather(&vertex(&est, &si, &bsdf, Vec3::Z), 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
                worst_area = worst_area.max((g.delta_area - std::f32::consts::PI * area_scale * state.buffers.knn_r2()).abs() / g.delta_area);
                sum += f64::from(g.l1.x);
            }
        }
        let exact = 0.25 / std::f64::consts::PI;
        (sum / (maps * queries) as f64 / exact, worst_area)
    }

    /// A batch's q₁ range by SIMD selects is the range [`Q1Range::add`] keeps one photon at a time over the
    /// photons with f ≠ 0: batches of every length up to 11 (whole vectors and a tail), with NaN, 0, ∞,
    /// subnormal and ordinary q₁, f = 0 in all or in some channels, added onto an empty and a non-empty range.
    #[test]
    fn batch_q1_range_equals_the_one_by_one_range() {
        let values = [f32::NAN, 0.0, f32::INFINITY, f32::from_bits(1), 1e-30, 0.5, 3.0, 7e5, f32::MAX];
        let mut s = Sampler::for_key(21, 0, 0);
        for case in 0..4000u64 {
            let n = (case % 12) as usize;
            let pick = |s: &mut Sampler| values[(s.next_1d() * values.len() as f32) as usize];
            let q1: Vec<f32> = (0..n).map(|_| pick(&mut s)).collect();
            let f: [Vec<f32>; 3] = std::array::from_fn(|_| (0..n).map(|_| if s.next_1d() < 0.5 { 0.0 } else { s.next_1d() }).collect());
            let start = if case % 2 == 0 { Q1Range::default() } else { Q1Range { min: 2.0, max: 4.0 } };
            let mut one_by_one = start;
            for j in 0..n {
                if Vec3::new(f[0][j], f[1][j], f[2][j]) != Vec3::ZERO {
                    one_by_one.add(q1[j]);
                }
            }
            let mut batch = start;
            batch.add_batch(&q1, [&f[0], &f[1], &f[2]]);
            assert_eq!(batch, one_by_one, "q1 {q1:?} f {f:?}");
        }
    }

    /// The progressive schedule's shrunken estimate (method.md §6): with `s < 1` the k-th photon lies
    /// outside the disk, and the count of the k − 1 inner photons inside `s·r²_kNN` over `π·s·r²_kNN` is
    /// unbiased for a uniform density, while the plain k-NN estimate (s = 1) is high by k/(k − 1)
    /// (E[1/Gamma(k)] = 1/(k − 1)). k = 8 makes the two differ by 14%, far beyond the ±4% bound (the
    /// estimates' standard error here is about 1%).
    #[test]
    fn shrunken_area_is_unbiased_on_a_uniform_density() {
        let k = 8;
        let (plain, area_plain) = mean_ratio(1.0, k, 8, 20_000, 1000);
        let (shrunk, area_shrunk) = mean_ratio(0.25, k, 8, 20_000, 1000);
        let kk = k as f64 / (k as f64 - 1.0);
        assert!((plain / kk - 1.0).abs() < 0.04, "s = 1: mean/exact {plain}, expected {kk}");
        assert!((shrunk - 1.0).abs() < 0.04, "s = 1/4: mean/exact {shrunk}, expected 1");
        // ΔA is the area of the estimate that was made (the one q₁ takes).
        assert!(area_plain < 1e-6 && area_shrunk < 1e-6, "ΔA ≠ π·s·r²: {area_plain} {area_shrunk}");
    }

    /// One photon far away must not blur a caustic (the floor of ΔA, [`min_delta_area`]): 2,000 photons in a
    /// disk of radius 10⁻³ (r_k ≈ 10⁻⁴ at its centre for k = 20) give the same estimate, over the unclamped
    /// k-NN area, with and without a photon 500 units away. That photon makes the photons' bounding radius
    /// 250, and the floor without the precision term `min(10⁻³·r_max, 5·10⁻⁵·R)` = 10⁻³, ten times r_k.
    #[test]
    fn a_far_photon_does_not_widen_the_floor_of_the_area() {
        let centre = Vec3::new(0.5, 0.0, 0.5);
        let mut s = Sampler::for_key(4, 0, 0);
        let disk: Vec<Photon> = (0..2000)
            .map(|_| {
                let u = crate::sampling::warp::square_to_uniform_disk_concentric(s.next_2d());
                Photon::new(centre + 1e-3 * Vec3::new(u.x, u.y, 0.0), Vec3::Z, Vec3::splat(1.0 / 2000.0), 1.0)
            })
            .collect();
        let mut with_outlier = disk.clone();
        with_outlier.push(Photon::new(Vec3::new(500.0, 0.0, 0.0), Vec3::Z, Vec3::splat(1.0 / 2000.0), 1.0));
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE });
        let si = SurfaceInteraction { p: centre, p_error: Vec3::ZERO, ng: Vec3::Z, ns: Vec3::Z, frame: Frame::from_normal(Vec3::Z), uv: Vec2::ZERO, prim: 0, inst: crate::accel::FLAT, material: 0 };
        let mut state = GatherState::default();
        let mut estimate = |photons: Vec<Photon>| {
            let map = PhotonMap::new(KdTree::build(photons).unwrap(), 2000, None);
            let est = CausticEstimator::new(Estimator::Pm, Some(&map), 20, 1.0, 1.0);
            let g = est.gather(&vertex(&est, &si, &bsdf, Vec3::Z), 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
            let knn_area = std::f32::consts::PI * state.buffers.knn_r2();
            assert!(knn_area < 1e-7 && g.delta_area == knn_area, "ΔA {} clamped above the k-NN area {knn_area}", g.delta_area);
            g.l1.x
        };
        let (plain, far) = (estimate(disk), estimate(with_outlier));
        assert!((far / plain - 1.0).abs() < 1e-5, "with a far photon {far}, without {plain}");
        // The floor still follows the user's bound and the photons' extent where those are smaller.
        assert!(min_delta_area(1e-6, 1.0, centre) <= std::f32::consts::PI * 1e-18 * 1.0001);
        assert!(min_delta_area(1.0, 1e-6, centre) <= std::f32::consts::PI * (5e-11f32).powi(2) * 1.0001);
        // And stays positive at the origin.
        assert!(min_delta_area(1.0, 1.0, Vec3::ZERO) > 0.0);
    }

    /// The estimate counts only the photons whose chain fits (method.md §2.1), over the area of all of them:
    /// 6,000 photons of chains 1, 2, 3 in turn, equal powers, on a white diffuse plane (f = 1/π): with a
    /// limit L the estimate is the count of chains ≤ L over the same ΔA, and with the cap (an unlimited
    /// max_depth) it is the estimate of every photon.
    #[test]
    fn the_estimate_counts_only_the_chains_that_fit() {
        let mut s = Sampler::for_key(25, 0, 0);
        let mut list = crate::photon::PhotonList::default();
        for i in 0..6000u32 {
            let u = s.next_2d();
            list.push(Photon::new(Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0), Vec3::Z, Vec3::splat(1.0 / 6000.0), 1.0), 1 + i % 3);
        }
        let map = PhotonMap::new(KdTree::build(list).unwrap(), 6000, None);
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE });
        for estimator in [Estimator::Pm, Estimator::Mis] {
            let est = CausticEstimator::new(estimator, Some(&map), 50, 0.5, 1.0);
            let mut state = GatherState::default();
            for q in 0..50 {
                let u = s.next_2d();
                let si = plane_point(Vec3::new(u.x - 0.5, u.y - 0.5, 0.0));
                let rx = vertex(&est, &si, &bsdf, Vec3::Z);
                let all = est.gather(&rx, 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
                assert_eq!(all.photons, 50, "query {q}");
                for longest in 0..=3 {
                    let g = est.gather(&rx, 1.0, longest, &mut state.scratch());
                    assert_eq!(g.delta_area, all.delta_area, "query {q}, L = {longest}: ΔA is that of every photon");
                    let decoded = map.tree().decoded();
                    let fit = state.buffers.knn.neighbors().iter().filter(|nb| u32::from(decoded[nb.index as usize].chain) <= longest).count();
                    assert_eq!(g.photons as usize, fit, "query {q}, L = {longest}");
                    // Each photon adds w₁·f·Φ with f and Φ equal for all: the estimate is proportional to the count.
                    let expected = all.l1.x * fit as f32 / 50.0;
                    assert!((g.l1.x - expected).abs() <= 1e-4 * all.l1.x, "query {q}, L = {longest}: {} vs {expected}", g.l1.x);
                }
                assert_eq!(est.gather(&rx, 1.0, 3, &mut state.scratch()), all);
            }
        }
    }

    #[test]
    fn area_scale_outside_the_unit_interval_is_ignored() {
        for s in [0.0, -1.0, 1.5, f32::NAN, f32::INFINITY] {
            assert_eq!(CausticEstimator::new(Estimator::Pm, None, 8, 1.0, 1.0).with_area_scale(s).area_scale, 1.0);
        }
    }

    /// A plane z = 0 with `m` photons uniform on [−1, 1]² arriving straight down, total power 1 (white).
    fn plane_map(m: u64) -> PhotonMap {
        let photons: Vec<Photon> = (0..m)
            .map(|i| {
                let u = Sampler::for_key(21, 0, i).next_2d();
                Photon::new(Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0), Vec3::Z, Vec3::splat(1.0 / m as f32), 1.0)
            })
            .collect();
        PhotonMap::new(KdTree::build(photons).unwrap(), m, None)
    }

    /// `m` photons uniform on the square [−1, 1]² of the plane z = 0, arriving from cosine-distributed
    /// directions over the upper hemisphere, each with power `power(s)/m`; all drawn from the stream keyed
    /// by `key`, which is returned for the test's further draws.
    fn hemisphere_plane_map(m: u64, key: u64, mut power: impl FnMut(&mut Sampler) -> Vec3) -> (PhotonMap, Sampler) {
        let mut s = Sampler::for_key(key, 0, 0);
        let photons: Vec<Photon> = (0..m)
            .map(|_| {
                let u = s.next_2d();
                let w = crate::sampling::warp::square_to_cosine_hemisphere(s.next_2d());
                Photon::new(Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0), w, power(&mut s) / m as f32, 1.0)
            })
            .collect();
        (PhotonMap::new(KdTree::build(photons).unwrap(), m, None), s)
    }

    fn plane_point(p: Vec3) -> SurfaceInteraction {
        SurfaceInteraction { p, p_error: Vec3::ZERO, ng: Vec3::Z, ns: Vec3::Z, frame: Frame::from_normal(Vec3::Z), uv: Vec2::ZERO, prim: 0, inst: crate::accel::FLAT, material: 0 }
    }

    /// T2's ΔA at a vertex whose estimate was skipped ([`CausticEstimator::area_at`], method.md §3.1) is the
    /// ΔA the estimate would have used there: inside the photons (k found), at their edge (fewer), beyond
    /// them (the occupancy grid's empty cells), and from below the plane (every photon rejected). Each
    /// side keeps its own scratch, so their warm starts differ.
    #[test]
    fn a_deferred_area_is_the_estimates() {
        let map = plane_map(4000);
        let est = CausticEstimator::new(Estimator::Mis, Some(&map), 20, 0.2, 1.0);
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE });
        let (mut gather_state, mut area_state) = (GatherState::default(), GatherState::default());
        let mut s = Sampler::for_key(22, 0, 0);
        let (mut full, mut partial, mut empty) = (0, 0, 0);
        for _ in 0..3000 {
            let u = s.next_2d();
            let si = plane_point(Vec3::new(3.0 * u.x - 1.5, 3.0 * u.y - 1.5, 0.0));
            let wo = if s.next_1d() < 0.1 { -Vec3::Z } else { Vec3::Z };
            let g = est.gather(&vertex(&est, &si, &bsdf, wo), 1.0, MAX_DELTA_CHAIN, &mut gather_state.scratch());
            let area = est.area_at(si.p, si.ng, wo.dot(si.ng), &mut area_state.scratch());
            assert_eq!(g.delta_area.to_bits(), area.to_bits(), "{}: estimate's ΔA {} but deferred {area}", si.p, g.delta_area);
            match g.photons {
                20 => full += 1,
                0 => empty += 1,
                _ => partial += 1,
            }
        }
        assert!(full > 500 && partial > 50 && empty > 500, "cases: {full} full, {partial} partial, {empty} empty");
    }

    /// The roulette's probability (method.md §3.1) where the grid holds fewer than k photons around the point
    /// (400 photons on [−1, 1]², about 37 in a 3×3 block of 0.2-wide cells; k = 60): 1 before the sample has
    /// collected radiance; `c/(κ·L)` between [`GATHER_MIN_PROBABILITY`] and 1,
    /// with `c = max(β)·f·Φ/(π·max_radius²)`, Φ the grid's power near the point and f toward the photons.
    #[test]
    fn the_gather_probability_follows_its_rule() {
        let map = plane_map(400);
        let max_radius = 0.2;
        let est = CausticEstimator::new(Estimator::Pm, Some(&map), 60, max_radius, 1.0);
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(0.5) });
        let si = plane_point(Vec3::new(0.1, -0.2, 0.0));
        let near = est.occupancy.as_ref().unwrap().photons_near(si.p).unwrap();
        assert!(near.power > 0.0 && near.fewer_than(60), "{near:?}");
        let beta = Vec3::new(0.2, 0.8, 0.4);
        // c = 0.8·(0.5/π)·Φ/(π r²).
        let c = 0.8 * (0.5 / std::f32::consts::PI) * near.power / (std::f32::consts::PI * max_radius * max_radius);
        let mut state = GatherState::default();
        let mut p = |collected: Vec3| est.gather_probability(&vertex(&est, &si, &bsdf, Vec3::Z), beta, collected, &mut state.scratch());
        assert_eq!(p(Vec3::ZERO), 1.0);
        assert_eq!(p(Vec3::new(0.0, c * 0.5 / GATHER_ROULETTE_KAPPA, 0.0)), 1.0);
        let half = p(Vec3::new(0.0, 0.0, 2.0 * c / GATHER_ROULETTE_KAPPA));
        assert!((half - 0.5).abs() < 1e-4, "P = {half}, expected 1/2");
        assert_eq!(p(Vec3::splat(1e6 * c)), GATHER_MIN_PROBABILITY);
        // No photon near: the estimate is 0, P the least.
        let far = plane_point(Vec3::new(5.0, 5.0, 0.0));
        assert_eq!(est.estimate_bound(&vertex(&est, &far, &bsdf, Vec3::Z), &mut state.scratch()), Some(0.0));
        assert_eq!(est.gather_probability(&vertex(&est, &far, &bsdf, Vec3::Z), beta, Vec3::ONE, &mut state.scratch()), GATHER_MIN_PROBABILITY);
        // A BSDF that reflects nothing toward the photons: the estimate is 0, P is the least.
        assert_eq!(est.gather_probability(&vertex(&est, &si, &Bsdf::Diffuse(Diffuse { reflectance: Vec3::ZERO }), Vec3::Z), beta, Vec3::ONE, &mut state.scratch()), GATHER_MIN_PROBABILITY);
        // A sharp GGX lobe: the bound takes f toward the photons' directions (all straight down, +z), not at
        // its peak. Seen along the normal the peak is where the photons arrive from: P = 1. Seen from 60°
        // off the normal, f toward +z is the lobe's tail, far below its peak, and so is P.
        let glossy = Bsdf::RoughConductor(RoughConductor {
            distribution: crate::bsdf::Microfacet::isotropic(crate::bsdf::MicrofacetType::Ggx, 0.01, true),
            specular_reflectance: Vec3::ONE,
            eta_k: None,
        });
        let oblique = Vec3::new(3f32.sqrt() / 2.0, 0.0, 0.5);
        let (tail, _) = glossy.f_pdf(oblique, Vec3::Z, TransportMode::Radiance);
        let (peak, _) = glossy.f_pdf(oblique, Vec3::new(-oblique.x, 0.0, oblique.z), TransportMode::Radiance);
        assert!(tail.x < 1e-4 * peak.x, "tail {tail}, peak {peak}");
        let c_tail = 0.8 * tail.x * near.power / (std::f32::consts::PI * max_radius * max_radius);
        let budget = 2.0 * c_tail / GATHER_ROULETTE_KAPPA;
        let along = est.gather_probability(&vertex(&est, &si, &glossy, Vec3::Z), beta, Vec3::splat(budget), &mut state.scratch());
        let from_60 = est.gather_probability(&vertex(&est, &si, &glossy, oblique), beta, Vec3::splat(budget), &mut state.scratch());
        assert_eq!(along, 1.0);
        assert!((from_60 - 0.5).abs() < 0.05, "P = {from_60}, expected about 1/2");
    }

    /// Where k photons lie well within `max_radius` the grid bounds nothing (a dense caustic: its power over
    /// the area of `max_radius` is far below the estimate). Without a recent query near the point there is
    /// no bound (P = 1); after one, the bound from the kd-tree's leaves within the recent radius holds: it is
    /// never below the estimate made there (a diffuse receiver, photons from all over the hemisphere), and is
    /// within a small factor of it.
    #[test]
    fn the_bound_holds_where_k_photons_are_near() {
        let m = 20_000u64;
        let (map, mut s) = hemisphere_plane_map(m, 23, |_| Vec3::ONE);
        let est = CausticEstimator::new(Estimator::Pm, Some(&map), 20, 0.5, 1.0);
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(0.5) });
        let mut state = GatherState::default();
        let p0 = plane_point(Vec3::new(0.3, 0.1, 0.0));
        assert!(!est.occupancy.as_ref().unwrap().photons_near(p0.p).unwrap().fewer_than(20));
        assert_eq!(est.estimate_bound(&vertex(&est, &p0, &bsdf, Vec3::Z), &mut state.scratch()), None);
        assert_eq!(est.gather_probability(&vertex(&est, &p0, &bsdf, Vec3::Z), Vec3::ONE, Vec3::splat(1e6), &mut state.scratch()), 1.0);
        let first = est.gather(&vertex(&est, &p0, &bsdf, Vec3::Z), 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
        let r0 = state.buffers.knn_r2().sqrt();
        let (mut worst, mut at) = (0.0f32, p0.p);
        for i in 0..400 {
            // A walk in steps of up to a tenth of the k-NN radius, as a pixel's samples hit, kept in [−½, ½]².
            let u = s.next_2d();
            at = (at + 0.1 * r0 * Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0)).clamp(Vec3::splat(-0.5), Vec3::splat(0.5));
            let x = plane_point(at);
            let c = est.estimate_bound(&vertex(&est, &x, &bsdf, Vec3::Z), &mut state.scratch()).expect("a recent query is near");
            let g = est.gather(&vertex(&est, &x, &bsdf, Vec3::Z), 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
            assert!(c >= g.l1.max_element() * (1.0 - 1e-5), "query {i} at {}: bound {c} below the estimate {}", x.p, g.l1);
            worst = worst.max(c / g.l1.max_element());
        }
        assert!(first.photons == 20 && worst < 8.0, "the bound is {worst}× the estimate at worst");
    }

    /// Where photons are sparse — fewer than k within `max_radius`, k or more in the occupancy grid's 3×3×3
    /// cells — and no recent query lies near (a path's scattered later vertices), the photon counts bound
    /// the estimate: where a bound is given it is never below the estimate made there (a diffuse receiver,
    /// photons from all over the hemisphere, powers that differ), and most such points get one.
    #[test]
    fn the_counts_bound_the_estimate_where_photons_are_sparse() {
        let m = 1000u64;
        let (map, mut s) = hemisphere_plane_map(m, 24, |s| Vec3::new(1.0, 0.5 + s.next_1d(), 0.2));
        let est = CausticEstimator::new(Estimator::Pm, Some(&map), 20, 0.1, 1.0);
        let bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(0.5) });
        let (mut sparse, mut bounded) = (0, 0);
        for i in 0..400 {
            let u = s.next_2d();
            let x = plane_point(Vec3::new(1.8 * u.x - 0.9, 1.8 * u.y - 0.9, 0.0));
            if est.occupancy.as_ref().unwrap().photons_near(x.p).unwrap().fewer_than(20) {
                continue;
            }
            sparse += 1;
            // A fresh scratch: no recent query near.
            let mut state = GatherState::default();
            let c = est.estimate_bound(&vertex(&est, &x, &bsdf, Vec3::Z), &mut state.scratch());
            let g = est.gather(&vertex(&est, &x, &bsdf, Vec3::Z), 1.0, MAX_DELTA_CHAIN, &mut state.scratch());
            if let Some(c) = c {
                bounded += 1;
                assert!(g.photons < 20, "point {i}: a bound where {} photons were found", g.photons);
                assert!(c >= g.l1.max_element() * (1.0 - 1e-5), "point {i} at {}: bound {c} below the estimate {}", x.p, g.l1);
            }
        }
        assert!(sparse > 100 && 2 * bounded > sparse, "{bounded} of {sparse} sparse points bounded");
    }
}
