//! The path tracer: next-event estimation + BSDF sampling combined by the power heuristic (Veach 1997
//! §9.2.4), Russian roulette, and the caustic estimator hooks of [`super::caustic`].
//!
//! Path state is one struct ([`Vertex`]): what the vertex that spawned the current ray was (camera,
//! delta, non-delta with its position and BSDF pdf), and — when a photon map is active — the
//! [`CausticOrigin`] of the last non-delta vertex, kept through delta bounces so that emission reached
//! through `x S⁺ L` can be weighted by `w₂`.

use super::caustic::{CausticEstimator, CausticOrigin, GatherScratch, OriginArea, Q1Range};
use crate::accel::Accel;
use crate::bsdf::TransportMode;
use crate::light::Light;
use crate::math::{Ray, Vec3};
use crate::sampler::Sampler;
use crate::sampling::mis::power_heuristic;
use crate::scene::Scene;

/// Counters a worker accumulates; summed over tiles for the stats.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathStats {
    /// Closest-hit and shadow rays.
    pub rays: u64,
    /// k-NN queries (density estimates).
    pub knn_queries: u64,
    /// k-NN searches T2 made for ΔA at vertices that skipped their density estimate (method.md §3.1).
    pub knn_area_queries: u64,
    /// The q₁ that reached the MIS function, in T1 and T2 (`mis` only).
    pub q1: Q1Range,
}

impl PathStats {
    pub fn add(&mut self, o: &PathStats) {
        self.rays += o.rays;
        self.knn_queries += o.knn_queries;
        self.knn_area_queries += o.knn_area_queries;
        self.q1.merge(&o.q1);
    }
}

/// What spawned the current ray.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Vertex {
    Camera,
    /// A delta lobe was sampled (mirror, glass, or the delta lobe of a blend).
    Delta,
    /// A non-delta lobe was sampled at `p` with solid-angle pdf `pdf_w` (for NEE/BSDF MIS).
    NonDelta { p: Vec3, pdf_w: f32 },
}

/// What every vertex asks of its material, answered once per pass (the BSDF methods recurse through
/// `twosided` and blends).
#[derive(Clone, Copy, Debug)]
struct MaterialUse {
    /// [`Bsdf::has_non_delta`](crate::bsdf::Bsdf::has_non_delta): NEE and the density estimate run here.
    non_delta: bool,
    /// [`Bsdf::chooses_lobe`](crate::bsdf::Bsdf::chooses_lobe): BSDF sampling takes a dimension for `u_lobe`.
    chooses_lobe: bool,
}

/// The path tracer for one render pass. Immutable and shared by all worker threads.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    caustics: CausticEstimator<'a>,
    /// Eye samples per pixel that share this pass's photon map (α of paper eq. 2).
    alpha: f32,
    /// Per entry of `scene.bsdfs`.
    materials: Vec<MaterialUse>,
}

impl<'a> PathTracer<'a> {
    /// The tracer of a pass whose eye samples per pixel are `alpha`, with the caustic estimator `caustics`.
    #[must_use]
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel, caustics: CausticEstimator<'a>, alpha: f32) -> Self {
        let materials = scene.bsdfs.iter().map(|b| MaterialUse { non_delta: b.has_non_delta(), chooses_lobe: b.chooses_lobe() }).collect();
        Self { scene, accel, caustics, alpha, materials }
    }

    /// Longest path in segments, or `u32::MAX` for unlimited.
    fn max_depth(&self) -> u32 {
        u32::try_from(self.scene.integrator.max_depth).unwrap_or(u32::MAX)
    }

    /// Weight of emission `le` found at the end of the current ray (the one function for every emission
    /// term a camera path collects).
    /// - after the camera: 1;
    /// - after a non-delta vertex: power heuristic between the BSDF pdf and NEE's `light_pdf_w`;
    /// - after a delta vertex with no non-delta vertex before (E S⁺ L, e.g. a light in a mirror): 1;
    /// - after `x S⁺` with `x` non-delta: the caustic weight `w₂` (method.md §4).
    /// `delta_vertices`: delta-sampled vertices since the last non-delta one (the caustic chain's length);
    /// `pdf_emit`: the density with which the photon pass would start a photon where this emission was
    /// found (0 for emitters without photons; evaluated only for `x S⁺ L`).
    /// `stats`: where T2's q₁ and its searches for ΔA are recorded; `scratch`: the tile's, for those searches.
    #[allow(clippy::too_many_arguments)]
    fn emission_weight(&self, prev: Vertex, caustic: Option<&CausticOrigin>, light_pdf_w: impl FnOnce() -> f32, pdf_emit: impl FnOnce() -> f32, delta_vertices: u32, stats: &mut PathStats, scratch: &mut GatherScratch) -> f32 {
        match prev {
            Vertex::Camera => 1.0,
            Vertex::NonDelta { pdf_w, .. } => power_heuristic(pdf_w, light_pdf_w()),
            Vertex::Delta => match caustic {
                None => 1.0,
                Some(origin) => self.caustics.t2_weight(origin, pdf_emit(), delta_vertices, &mut stats.q1, &mut stats.knn_area_queries, scratch),
            },
        }
    }

    /// Radiance along `ray` (a camera ray), estimated with one path. `pixel_mean`: the mean of the pixel's
    /// earlier samples (for its first, of the previous pixel's), a scale the gather's roulette compares its
    /// bound with.
    pub fn li(&self, mut ray: Ray, sampler: &mut Sampler, pixel_mean: Vec3, stats: &mut PathStats, scratch: &mut GatherScratch) -> Vec3 {
        let scene = self.scene;
        let lights = &scene.lights;
        let max_depth = self.max_depth();
        let rr_depth = scene.integrator.rr_depth;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut prev = Vertex::Camera;
        let mut caustic: Option<CausticOrigin> = None;
        let mut first_non_delta = true;
        // Delta-sampled vertices since the last non-delta vertex (T2's chain length, method.md §4).
        let mut delta_vertices: u32 = 0;
        // Number of segments of the path up to the current hit.
        let mut depth: u32 = 1;
        // The current ray's unit direction, kept beside `ray` (computed from the value in hand, not read back
        // from the ray just stored for the backend: that read waited on the stores).
        let mut dir = ray.dir.normalize();
        loop {
            stats.rays += 1;
            let Some(hit) = self.accel.intersect(&ray) else {
                // Escaped: environment emission, split into the part that emits photons (env maps) and
                // the part that does not (constant), since only the first has a T1 technique.
                for (index, light) in lights.lights().iter().enumerate() {
                    let le = match light {
                        Light::Env(env) => env.eval(dir),
                        Light::Constant { radiance } => *radiance,
                        // Rays never reach area lights here, nor the delta lights anywhere.
                        Light::Area(_) | Light::Point(_) | Light::Directional(_) => continue,
                    };
                    if le == Vec3::ZERO {
                        continue;
                    }
                    let pdf_emit = || match (light, self.caustics.emission()) {
                        (Light::Env(env), Some(em)) => em.pdf_emit_env(index, env, dir),
                        _ => 0.0,
                    };
                    let w = self.emission_weight(prev, caustic.as_ref(), || lights.pdf_li_escaped(dir), pdf_emit, delta_vertices, stats, scratch);
                    l += beta * w * le;
                }
                break;
            };
            let si = scene.interaction(&ray, &hit);
            let wo_world = -dir;

            // Emission from an area light that was hit.
            if let Some(light_index) = lights.light_of_prim(hit.prim) {
                let le = lights.le_area(hit.prim, si.ng, wo_world);
                if le != Vec3::ZERO {
                    let light_pdf = || match prev {
                        Vertex::NonDelta { p, .. } => lights.pdf_li_area(hit.prim, p, si.p, si.ng),
                        _ => 0.0,
                    };
                    let pdf_emit = || self.caustics.emission().map_or(0.0, |em| em.pdf_emit_area(light_index, si.p, si.ng, wo_world));
                    l += beta * self.emission_weight(prev, caustic.as_ref(), light_pdf, pdf_emit, delta_vertices, stats, scratch) * le;
                }
            }
            if depth >= max_depth {
                break;
            }

            let bsdf = &scene.bsdfs[si.material as usize];
            let material = self.materials[si.material as usize];
            let wo_local = si.frame.to_local(wo_world);
            let non_delta = material.non_delta;
            // The caustic estimators' view of this vertex, made before the shadow ray: its grid look-up's
            // cache misses then overlap the ray (`caustic::Receiver`).
            let receiver = (non_delta && self.caustics.active()).then(|| self.caustics.receiver(&si, bsdf, wo_world, wo_local));

            // Next-event estimation (direct light L x), MIS with BSDF sampling. Choosing among lights and
            // lobes takes a dimension only where there is a choice (`LightSet::chooses_light`,
            // `Bsdf::chooses_lobe`).
            if non_delta && !lights.is_empty() {
                let u_sel = if lights.chooses_light() { sampler.next_1d() } else { 0.0 };
                let u_li = sampler.next_2d();
                if let Some((_, ls)) = lights.sample_li(si.p, u_sel, u_li) {
                    let wi_local = si.frame.to_local(ls.wi_world);
                    let (f, bsdf_pdf_w) = bsdf.f_pdf(wo_local, wi_local, TransportMode::Radiance);
                    let f = f * wi_local.z.abs();
                    if f != Vec3::ZERO && ls.pdf_w > 0.0 && ls.li != Vec3::ZERO {
                        let shadow = if ls.dist.is_finite() { si.spawn_ray_to(ls.p_light) } else { si.spawn_ray(ls.wi_world) };
                        stats.rays += 1;
                        if !self.accel.occluded(&shadow) {
                            // BSDF sampling reaches a delta light with probability 0: its density for this
                            // path is 0 and the one MIS function gives NEE weight 1 (method.md §4.1).
                            let bsdf_pdf_w = if ls.delta { 0.0 } else { bsdf_pdf_w };
                            let w = power_heuristic(ls.pdf_w, bsdf_pdf_w);
                            l += beta * f * ls.li * (w / ls.pdf_w);
                        }
                    }
                }
            }

            // Caustics T1 at x with probability P (method.md §3.1), and ΔA(x), which T2 needs.
            let mut area = None;
            let alpha = if first_non_delta { self.alpha } else { 1.0 };
            if let Some(rx) = &receiver {
                let p_gather = self.caustics.gather_probability(rx, beta, l.max(pixel_mean), scratch);
                // The roulette's number is drawn whether P < 1 or not, and independent of the pixel's other
                // samples (`Sampler::next_independent_1d`): P reads their radiance (`pixel_mean`) and their
                // queries (`scratch`). Drawn only where P < 1, it shifted this sample's later dimensions by
                // what the earlier samples found, and those dimensions are stratified against theirs: the
                // direction after a dark sample leaned toward bright ones (method.md §3.1; +7.5 % on the
                // cornell ceiling in `pm` with 4-spp passes).
                if sampler.next_independent_1d() < p_gather {
                    let g = self.caustics.gather(rx, alpha, scratch);
                    stats.knn_queries += 1;
                    stats.q1.merge(&g.q1);
                    l += beta * g.l1 / p_gather;
                    area = Some(OriginArea::Known(g.delta_area));
                } else {
                    area = Some(OriginArea::Deferred { p: si.p, ng: si.ng, wo_side: wo_world.dot(si.ng) });
                }
            }
            if non_delta {
                first_non_delta = false;
            }

            // Continue the path by BSDF sampling.
            let u_lobe = if material.chooses_lobe { sampler.next_1d() } else { 0.0 };
            let u_dir = sampler.next_2d();
            let Some(bs) = bsdf.sample(wo_local, u_lobe, u_dir, TransportMode::Radiance) else { break };
            if bs.weight == Vec3::ZERO {
                break;
            }
            beta *= bs.weight;
            debug_assert!(beta.is_finite(), "throughput not finite: {beta}");
            let wi_world = si.frame.to_world(bs.wi_local);
            if bs.delta {
                prev = Vertex::Delta;
                delta_vertices = delta_vertices.saturating_add(1);
            } else {
                delta_vertices = 0;
                prev = Vertex::NonDelta { p: si.p, pdf_w: bs.pdf_w };
                caustic = area.map(|area| CausticOrigin { pdf_w: bs.pdf_w, cos_theta: bs.wi_local.z.abs(), area, alpha });
            }

            // Russian roulette (survival ∝ throughput, capped at 0.95).
            if depth >= rr_depth {
                let p_survive = beta.max_element().min(0.95);
                if p_survive <= 0.0 || sampler.next_1d() >= p_survive {
                    break;
                }
                beta /= p_survive;
            }
            depth += 1;
            ray = si.spawn_ray(wi_world);
            dir = wi_world.normalize();
        }
        l
    }
}
