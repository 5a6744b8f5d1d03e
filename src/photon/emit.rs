//! The caustic photon pass (method.md §2): emission from area lights, environment maps and delta lights
//! aimed at the delta objects ([`super::emission`]), tracing through delta bounces, storage at the first non-delta hit.
//!
//! - Light `j` is chosen with probability `Φⱼ/Φ` among the photon-emitting lights; the start is
//!   sampled by [`PhotonEmission::sample`]. The `constant` emitter emits no photons: its caustics stay
//!   with BSDF sampling (w₂ = 1) in every estimator.
//! - A photon's power is `Le·|cos θ′| / (N·p(light)·p(x′)·p(ω′)) = Le/(N·p_emit)`, the exact inverse of
//!   the sampling pdf; the photon stores `p_emit` (per unit area and projected solid angle) for q₁.
//! - The first hit must choose a delta lobe, else the photon is no caustic photon and is dropped.
//!   Delta bounces are followed (glass: reflect or refract with the Fresnel probability, the power
//!   divided by it). At a surface with a non-delta lobe the photon is stored; it continues only if
//!   that surface's sampler then chooses a delta lobe (a blend of delta and non-delta), which keeps
//!   photons consistent with eye paths that treat each sampled lobe as delta or not.
//! - Chains longer than [`MAX_DELTA_CHAIN`] are cut and counted in the stats. Whether T1 can make a
//!   path is decided by ONE rule, [`photon_chain_reaches`], used here and by T2's weight
//!   (`integrator::caustic`): a path whose delta chain the photon pass cuts gets `w₂ = 1`.
//! - Photon `i` of pass `p` draws from `Sampler::for_photon(seed, p, i)`: the map is deterministic.
//! - A stop request (Ctrl-C, a time limit) is polled every [`STOP_POLL`] photons: the pass then ends
//!   within milliseconds, and N counts exactly the photons that were traced (each photon is an
//!   independent sample, so any subset chosen without looking at them is an unbiased map of its N).

use std::time::Instant;

use rayon::prelude::*;

use super::emission::PhotonEmission;
use super::kdtree::{KdTree, KdTreeError};
use super::record::{Photon, PhotonList};
use crate::accel::Accel;
use crate::bsdf::TransportMode;
use crate::light::Light;
use crate::math::Aabb;
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Longest chain of delta bounces a photon follows.
pub const MAX_DELTA_CHAIN: u32 = 16;

// The kd-tree keeps a photon's chain in one byte (`record::DecodedPhoton::chain`).
const _: () = assert!(MAX_DELTA_CHAIN <= u8::MAX as u32);

/// The longest delta chain T1 may use at a non-delta eye vertex `x` that the eye path reached in
/// `eye_depth` segments, under `max_depth` (in segments, `u32::MAX` for unlimited; Mitsuba's `max_depth`,
/// `IntegratorSettings::max_segments`). A photon that made `m` delta bounces, gathered at `x`, completes a
/// light path of `eye_depth + m + 1` segments (the chain's `m` delta vertices are joined by `m + 1`
/// segments from the light to `x`); the path tracer, like Mitsuba's (`path.cpp`: no vertex past
/// `max_depth`), makes no path longer than `max_depth`, so neither may T1 (method.md §2.1). The photon
/// pass follows at most [`MAX_DELTA_CHAIN`] bounces as well. 0 where no photon fits: at the eye path's
/// last vertex, and everywhere when `max_depth < 3`. This is the one rule the photon pass (at
/// `eye_depth` 1, the shallowest eye vertex), the density estimate and T2's weight ask
/// ([`photon_chain_reaches`]).
#[must_use]
#[inline]
pub fn longest_chain(eye_depth: u32, max_depth: u32) -> u32 {
    max_depth.saturating_sub(eye_depth.saturating_add(1)).min(MAX_DELTA_CHAIN)
}

/// Whether a path whose non-delta eye vertex lies `eye_depth` segments from the camera, reached from the
/// light through `chain` delta vertices, has at most `max_depth` segments: `eye_depth + chain + 1 ≤
/// max_depth` ([`longest_chain`] without the photon pass's cap).
#[must_use]
fn path_fits(eye_depth: u32, chain: u32, max_depth: u32) -> bool {
    u64::from(eye_depth) + u64::from(chain) + 1 <= u64::from(max_depth)
}

/// Whether T1 can make a path whose non-delta eye vertex `x` has `delta_vertices` delta-sampled vertices
/// between it and the light, when [`longest_chain`] at `x` is `longest`: `1..=longest`. The photon pass
/// cuts every longer chain and the density estimate leaves out the photons of chains that do not fit, so
/// T2 must take such a path whole (`w₂ = 1`) where it makes it (method.md §4).
#[must_use]
#[inline]
pub fn photon_chain_reaches(delta_vertices: u32, longest: u32) -> bool {
    (1..=longest).contains(&delta_vertices)
}

/// Whether `light` takes part in the photon pass (area lights, env maps and the delta lights do;
/// `constant` does not).
#[must_use]
pub fn light_emits_photons(light: &Light) -> bool {
    matches!(light, Light::Area(_) | Light::Env(_) | Light::Point(_) | Light::Directional(_))
}

/// A caustic photon map: the kd-tree over stored photons, and what q₁ needs (N, and the emission
/// model that gives T2 the density `p_emit` of a light point).
pub struct PhotonMap {
    tree: KdTree,
    emitted: u64,
    emission: Option<PhotonEmission>,
}

impl PhotonMap {
    /// A map over `tree` whose photons came from `emitted` emissions by `emission`.
    #[must_use]
    pub fn new(tree: KdTree, emitted: u64, emission: Option<PhotonEmission>) -> Self {
        Self { tree, emitted, emission }
    }
    #[must_use]
    pub fn tree(&self) -> &KdTree {
        &self.tree
    }
    /// `N`: every emitted photon, stored or not.
    #[must_use]
    pub fn emitted(&self) -> u64 {
        self.emitted
    }
    /// `Φ`: total power (luminance) of the photon-emitting lights.
    #[must_use]
    pub fn total_power(&self) -> f32 {
        self.emission.as_ref().map_or(0.0, PhotonEmission::total_power)
    }
    /// How the photons were emitted (`None` if no light emits photons).
    #[must_use]
    pub fn emission(&self) -> Option<&PhotonEmission> {
        self.emission.as_ref()
    }
}

/// What one photon pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhotonPassStats {
    pub emitted: u64,
    pub stored: u64,
    pub bytes: u64,
    pub rays: u64,
    pub chains_capped: u64,
    /// The stop request ended the pass before its budget: `emitted` counts what was traced.
    pub stopped: bool,
    pub seconds_trace: f64,
    pub seconds_kdtree: f64,
}

#[derive(Default)]
struct Traced {
    /// The stored photons with their delta chains.
    photons: PhotonList,
    /// Photons traced (stored or not): N's share of this range.
    emitted: u64,
    rays: u64,
    capped: u64,
    stopped: bool,
}

/// How many photons a pass emits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonBudget {
    /// Emit exactly `N` photons (method.md §2's N).
    Emitted(u64),
    /// Emit in deterministic batches until at least this many caustic photons are stored (or
    /// [`MAX_EMITTED_PER_STORED`]× as many were emitted); N is then the number emitted.
    Stored(u64),
}

/// Cap on emitted/stored for [`PhotonBudget::Stored`] (a scene whose delta surfaces catch almost no
/// light must not loop for ever).
pub const MAX_EMITTED_PER_STORED: u64 = 10_000;

/// Photons per parallel work item.
const CHUNK: u64 = 4096;

/// Photons traced between two polls of the stop request.
pub const STOP_POLL: u64 = 64;

struct Emitter<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    emission: &'a PhotonEmission,
    /// [`Scene::delta_bounds`]: emitted rays that miss it are discarded untraced.
    delta_bounds: Aabb,
    /// The scene's `max_depth` in segments (`IntegratorSettings::max_segments`).
    max_depth: u32,
    /// [`longest_chain`] at eye depth 1: no eye vertex can use a longer chain, so none is traced.
    longest_chain: u32,
    seed: u64,
    pass: u64,
    stop: &'a (dyn Fn() -> bool + Sync),
}

impl Emitter<'_> {
    /// Traces photons with indices `start..end` (fewer if the stop request comes); powers are for
    /// N = 1 (divided by N afterwards).
    fn trace_range(&self, start: u64, end: u64, out: &mut Traced) {
        let chunks: Vec<Traced> = (start / CHUNK..end.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut t = Traced::default();
                for i in (c * CHUNK).max(start)..((c + 1) * CHUNK).min(end) {
                    if i % STOP_POLL == 0 && (self.stop)() {
                        t.stopped = true;
                        break;
                    }
                    let mut sampler = Sampler::for_photon(self.seed, self.pass, i);
                    trace_one(self, &mut sampler, &mut t);
                    t.emitted += 1;
                }
                t
            })
            .collect();
        for t in chunks {
            out.photons.extend(&t.photons);
            out.emitted += t.emitted;
            out.rays += t.rays;
            out.capped += t.capped;
            out.stopped |= t.stopped;
        }
    }
}

/// Emits photons for pass `pass` within `budget` and builds their kd-tree (which fails only past 2³²
/// stored photons). `stop` is polled every [`STOP_POLL`] photons; when it returns true the pass ends
/// early with the photons traced so far (N = their number, [`PhotonPassStats::stopped`] set).
pub fn trace_photons(
    scene: &Scene,
    accel: &dyn Accel,
    budget: PhotonBudget,
    seed: u64,
    pass: u64,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<(PhotonMap, PhotonPassStats), KdTreeError> {
    let t0 = Instant::now();
    let emission = PhotonEmission::new(scene);
    let mut traced = Traced::default();
    if let Some(emission) = &emission {
        let max_depth = scene.integrator.max_segments();
        let longest_chain = longest_chain(1, max_depth);
        let em = Emitter { scene, accel, emission, delta_bounds: scene.delta_bounds(), max_depth, longest_chain, seed, pass, stop };
        match budget {
            PhotonBudget::Emitted(n) => em.trace_range(0, n, &mut traced),
            PhotonBudget::Stored(target) => {
                let cap = target.saturating_mul(MAX_EMITTED_PER_STORED);
                let mut batch = target.max(CHUNK);
                let mut end = 0u64;
                while (traced.photons.len() as u64) < target && end < cap && !traced.stopped {
                    let start = end;
                    end = (start + batch).min(cap);
                    em.trace_range(start, end, &mut traced);
                    let emitted = traced.emitted;
                    let stored = traced.photons.len() as u64;
                    // Next batch: what the observed storage rate says is missing, plus 5%.
                    batch = if stored == 0 {
                        batch.saturating_mul(4)
                    } else {
                        let missing = target.saturating_sub(stored) as f64;
                        ((missing * emitted as f64 / stored as f64 * 1.05) as u64).max(CHUNK)
                    };
                }
            }
        }
    }
    let emitted = traced.emitted;
    // Power = Le·|cos θ′| / (N·p) (method.md §2): the 1/N is applied now that N is known.
    let inv_n = if emitted > 0 { 1.0 / emitted as f32 } else { 0.0 };
    let mut photons = traced.photons;
    photons.scale_power(inv_n);
    let seconds_trace = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let stored = photons.len() as u64;
    let tree = KdTree::build(photons)?;
    let stats = PhotonPassStats {
        emitted,
        stored,
        bytes: tree.memory_bytes() as u64,
        rays: traced.rays,
        chains_capped: traced.capped,
        stopped: traced.stopped,
        seconds_trace,
        seconds_kdtree: t1.elapsed().as_secs_f64(),
    };
    Ok((PhotonMap::new(tree, emitted, emission), stats))
}

fn trace_one(em: &Emitter<'_>, sampler: &mut Sampler, out: &mut Traced) {
    let (scene, accel) = (em.scene, em.accel);
    let u_sel = sampler.next_1d();
    let u_a = sampler.next_2d();
    let u_b = sampler.next_2d();
    let u_c = sampler.next_1d();
    let Some(start) = em.emission.sample(scene.lights.lights(), u_sel, u_a, u_b, u_c) else { return };
    let (es, pdf_emit) = (start.emission, start.pdf_emit);
    // Power·N = Le·|cos θ′| / p: method.md §2 with the exact sampling pdf (1/N applied by the caller).
    let mut power = start.power_n;
    let mut ray = crate::math::Ray::segment(es.origin, es.dir, es.t_min, f32::INFINITY);
    // Only a first hit on a delta surface makes a caustic photon: a ray that misses every delta
    // triangle's box is discarded without tracing (the same photons are stored, at a fraction of the
    // rays when the delta objects are small as seen from the lights).
    if !em.delta_bounds.may_intersect(&ray) {
        return;
    }
    let mut delta_bounces = 0u32;
    loop {
        out.rays += 1;
        let Some(hit) = accel.intersect(&ray) else { return };
        let si = scene.interaction(&ray, &hit);
        // Where photons are stored and which surfaces carry them on are facts of the material, not of the
        // hit (`crate::material`): the eye paths decide by the same facts where to gather.
        let facts = scene.materials[si.material as usize].facts();
        let wi_world = -ray.dir.normalize();
        if delta_bounces > 0 && facts.has_non_delta {
            out.photons.push(Photon::new(si.p, wi_world, power, pdf_emit), delta_bounces);
        }
        if !facts.has_delta {
            return;
        }
        if !photon_chain_reaches(delta_bounces + 1, em.longest_chain) {
            // One more delta bounce would make a chain no photon may store. Counted when a path of that
            // chain still fits max_depth (T2 takes those paths whole); a longer one neither technique makes.
            if path_fits(1, delta_bounces + 1, em.max_depth) {
                out.capped += 1;
            }
            return;
        }
        let wo_local = si.frame.to_local(wi_world);
        let bsdf = scene.bsdf_at(&si);
        let Some(bs) = bsdf.sample(wo_local, sampler.next_1d(), sampler.next_2d(), TransportMode::Importance) else { return };
        if !bs.delta {
            // The first hit chose a non-delta lobe (not a caustic photon), or a later one did after storing.
            return;
        }
        power *= bs.weight;
        if power.max_element() <= 0.0 {
            return;
        }
        delta_bounces += 1;
        ray = si.spawn_ray(si.frame.to_world(bs.wi_local));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one rule against the path lengths it stands for: at eye depth d a chain of m delta vertices is
    /// T1's when 1 ≤ m ≤ `MAX_DELTA_CHAIN` and the path's d + m + 1 segments fit max_depth.
    #[test]
    fn the_longest_chain_is_the_one_that_fits_max_depth() {
        for max_depth in [0, 1, 2, 3, 4, 6, 17, 18, 19, 40, u32::MAX - 1, u32::MAX] {
            for d in (1..40).chain([u32::MAX - 2, u32::MAX - 1, u32::MAX]) {
                let longest = longest_chain(d, max_depth);
                for m in 0..=MAX_DELTA_CHAIN + 2 {
                    let fits = (1..=MAX_DELTA_CHAIN).contains(&m) && u64::from(d) + u64::from(m) + 1 <= u64::from(max_depth);
                    assert_eq!(photon_chain_reaches(m, longest), fits, "max_depth {max_depth}, d {d}, m {m}");
                    assert_eq!(path_fits(d, m, max_depth), u64::from(d) + u64::from(m) < u64::from(max_depth));
                }
            }
        }
        // Unlimited: the photon pass's cap alone, as before max_depth counted.
        assert_eq!(longest_chain(1, u32::MAX), MAX_DELTA_CHAIN);
        assert_eq!(longest_chain(1_000, u32::MAX), MAX_DELTA_CHAIN);
        // The stokes Cornell box (max_depth 6): 4 delta bounces seen directly, none at the last vertex.
        assert_eq!((longest_chain(1, 6), longest_chain(4, 6), longest_chain(5, 6)), (4, 1, 0));
        // Below 3 segments no caustic path exists.
        assert_eq!(longest_chain(1, 2), 0);
    }
}
