//! The path tracer: next-event estimation + BSDF sampling combined by the power heuristic (Veach 1997
//! §9.2.4), Russian roulette, and the caustic estimator hooks of [`super::caustic`].
//!
//! A path in flight is an [`EyePath`]: its ray, throughput and radiance, what the vertex that spawned
//! the ray was ([`Vertex`]: camera, delta, non-delta with its position and BSDF pdf), and — when a photon
//! map is active — the [`CausticOrigin`] of the last non-delta vertex, kept through delta bounces so that
//! emission reached through `x S⁺ L` can be weighted by `w₂`. A vertex is two steps around its shadow
//! ray, `at_hit` and `after_shadow`, which two drivers run: [`PathTracer::li`], one path and one ray per
//! call, and [`PathTracer::trace_wave`], many paths whose rays go to the backend in batches
//! (ARCHITECTURE.md, "The path tracer's waves").
//!
//! `hide_emitters` (Mitsuba's flag, `[integrator] hide_emitters = true`) is one rule in two parts: the camera
//! ray goes on through every area emitter it meets ([`PathTracer::past_area_emitters`]), and a path that
//! never scattered at a surface (escaped, or only passed through `null` surfaces and `mask` holes) shows
//! nothing ([`PathTracer::hide_unscattered`]).

use super::caustic::{CausticEstimator, CausticOrigin, GatherBuffers, GatherMemory, GatherScratch, LookedUp, OriginArea, Q1Range};
use crate::accel::{Accel, Hit};
use crate::bsdf::TransportMode;
use crate::light::Light;
use crate::math::{Ray, Vec3};
use crate::photon::longest_chain;
use crate::sampler::Sampler;
use crate::sampling::mis::power_heuristic;
use crate::scene::{Scene, SurfaceInteraction};

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

/// The vertex between its closest hit and its shadow ray ([`PathTracer::trace_wave`] traces a wave's
/// shadow rays together, so the vertex waits for the answer).
#[derive(Clone, Copy, Debug)]
struct PendingVertex {
    si: SurfaceInteraction,
    wo_world: Vec3,
    wo_local: Vec3,
    /// The caustic estimators' look-up at `si.p` (`None` at delta vertices and without a photon map).
    looked_up: Option<LookedUp>,
}

/// One eye path in flight: what the path tracer keeps from one ray to the next.
#[derive(Clone, Debug)]
pub struct EyePath {
    sampler: Sampler,
    /// The ray to trace next and its unit direction (computed from the value in hand, not read back from
    /// the ray stored for the backend).
    ray: Ray,
    dir: Vec3,
    /// The scale of the gather's roulette ([`PathTracer::li`]).
    pixel_mean: Vec3,
    l: Vec3,
    beta: Vec3,
    prev: Vertex,
    /// The last non-delta vertex's T2 data, kept through delta bounces.
    caustic: Option<CausticOrigin>,
    first_non_delta: bool,
    /// Delta-sampled vertices since the last non-delta vertex (T2's chain length, method.md §4).
    delta_vertices: u32,
    /// Number of segments of the path up to the current hit.
    depth: u32,
    /// Whether a BSDF sample other than a pass-through (`BsdfSample::pass_through`) was drawn: what
    /// `hide_emitters` asks at the path's end ([`PathTracer::hide_unscattered`]).
    scattered: bool,
    /// The next-event estimate's shadow ray and what it adds if unoccluded.
    shadow: Option<(Ray, Vec3)>,
    vertex: Option<PendingVertex>,
    done: bool,
}

impl EyePath {
    /// A path starting with the camera ray `ray`, drawing from `sampler` (which has drawn the pixel
    /// position); `pixel_mean` as for [`PathTracer::li`].
    #[must_use]
    pub fn new(ray: Ray, sampler: Sampler, pixel_mean: Vec3) -> Self {
        EyePath {
            sampler,
            dir: ray.dir.normalize(),
            ray,
            pixel_mean,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            prev: Vertex::Camera,
            caustic: None,
            first_non_delta: true,
            delta_vertices: 0,
            depth: 1,
            scattered: false,
            shadow: None,
            vertex: None,
            done: false,
        }
    }

    /// The radiance the path has collected (all of it once [`PathTracer::trace_wave`] returns).
    #[must_use]
    pub fn radiance(&self) -> Vec3 {
        self.l
    }
}

/// The buffers of [`PathTracer::trace_wave`], kept from one wave to the next (one per tile).
#[derive(Debug, Default)]
pub struct Wave {
    going: Vec<usize>,
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    occluded: Vec<bool>,
}

/// The path tracer for one render pass. Immutable and shared by all worker threads.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    caustics: CausticEstimator<'a>,
    /// Eye samples per pixel that share this pass's photon map (α of paper eq. 2).
    alpha: f32,
    /// Per entry of `scene.materials`.
    materials: Vec<MaterialUse>,
}

impl<'a> PathTracer<'a> {
    /// The tracer of a pass whose eye samples per pixel are `alpha`, with the caustic estimator `caustics`.
    #[must_use]
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel, caustics: CausticEstimator<'a>, alpha: f32) -> Self {
        let materials = scene.materials.iter().map(|m| MaterialUse { non_delta: m.facts().has_non_delta, chooses_lobe: m.facts().chooses_lobe }).collect();
        Self { scene, accel, caustics, alpha, materials }
    }

    /// Longest path in segments, or `u32::MAX` for unlimited.
    fn max_depth(&self) -> u32 {
        self.scene.integrator.max_segments()
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
    /// `stats`: where T2's q₁ and its searches for ΔA are recorded; `scratch`: the path's, for those searches.
    #[allow(clippy::too_many_arguments)]
    fn emission_weight(&self, prev: Vertex, caustic: Option<&CausticOrigin>, light_pdf_w: impl FnOnce() -> f32, pdf_emit: impl FnOnce() -> f32, delta_vertices: u32, stats: &mut PathStats, scratch: &mut GatherScratch<'_>) -> f32 {
        match prev {
            Vertex::Camera => 1.0,
            Vertex::NonDelta { pdf_w, .. } => power_heuristic(pdf_w, light_pdf_w()),
            Vertex::Delta => match caustic {
                None => 1.0,
                Some(origin) => self.caustics.t2_weight(origin, pdf_emit(), delta_vertices, &mut stats.q1, &mut stats.knn_area_queries, scratch),
            },
        }
    }

    /// Whether a path reads what earlier paths found: with a photon map the gather's roulette (method.md
    /// §3.1) reads the pixel's earlier samples (`pixel_mean`) and the recent searches of its scratch
    /// (`GatherMemory`); without one, paths are independent.
    #[must_use]
    pub fn reads_earlier_samples(&self) -> bool {
        self.caustics.active()
    }

    /// Radiance along `ray` (a camera ray), estimated with one path drawing from `sampler` (which has drawn
    /// the pixel position), traced one ray per call. `pixel_mean`: a scale the gather's roulette compares
    /// its bound with, from other samples (the render gives the mean of the pixel's earlier samples, for
    /// its first sample the previous pixel's first sample's radiance; method.md §3.1). The same path, number for number, as [`PathTracer::trace_wave`]
    /// traces it with the same scratch.
    pub fn li(&self, ray: Ray, sampler: Sampler, pixel_mean: Vec3, stats: &mut PathStats, scratch: &mut GatherScratch<'_>) -> Vec3 {
        let mut path = EyePath::new(ray, sampler, pixel_mean);
        while !path.done {
            stats.rays += 1;
            let hit = self.accel.intersect(&path.ray);
            self.at_hit(&mut path, hit, stats, scratch);
            if path.done {
                break;
            }
            let occluded = path.shadow.as_ref().map(|(ray, _)| {
                stats.rays += 1;
                self.accel.occluded(ray)
            });
            self.after_shadow(&mut path, occluded, stats, scratch);
        }
        self.hide_unscattered(&mut path);
        path.l
    }

    /// Traces the paths of `paths` together, one wave per bounce: the closest-hit rays of every path
    /// still going in one [`Accel::intersect_many`], then their shadow rays in one
    /// [`Accel::occluded_many`] (Embree's packets; ARCHITECTURE.md, "The path tracer's waves"). Each path
    /// draws the same numbers and makes the same computations as [`PathTracer::li`] would, given the same
    /// caustic scratch: the paths share `buffers`, and `memories` holds one memory of recent searches for
    /// all of them, or one per path (the gather's roulette reads it; [`PathTracer::reads_earlier_samples`]).
    /// The radiance of `paths[i]` is [`EyePath::radiance`].
    pub fn trace_wave(&self, paths: &mut [EyePath], wave: &mut Wave, stats: &mut PathStats, buffers: &mut GatherBuffers, memories: &mut [GatherMemory]) {
        assert!(memories.len() == 1 || memories.len() == paths.len(), "one memory, or one per path");
        // Path i's memory.
        let shared = memories.len() == 1;
        let m = |i: usize| if shared { 0 } else { i };
        let Wave { going, rays, hits, occluded } = wave;
        going.clear();
        going.extend((0..paths.len()).filter(|&i| !paths[i].done));
        while !going.is_empty() {
            rays.clear();
            rays.extend(going.iter().map(|&i| paths[i].ray));
            hits.clear();
            hits.resize(rays.len(), None);
            stats.rays += rays.len() as u64;
            self.accel.intersect_many(rays, hits);
            self.scene.warm_shading(hits);
            for (&i, &hit) in going.iter().zip(hits.iter()) {
                self.at_hit(&mut paths[i], hit, stats, &mut GatherScratch::new(buffers, &mut memories[m(i)]));
            }
            going.retain(|&i| !paths[i].done);
            rays.clear();
            rays.extend(going.iter().filter_map(|&i| paths[i].shadow.as_ref().map(|(ray, _)| *ray)));
            occluded.clear();
            occluded.resize(rays.len(), false);
            stats.rays += rays.len() as u64;
            self.accel.occluded_many(rays, occluded);
            let mut answers = occluded.iter();
            for &i in going.iter() {
                let answer = paths[i].shadow.is_some().then(|| *answers.next().expect("one answer per shadow ray"));
                self.after_shadow(&mut paths[i], answer, stats, &mut GatherScratch::new(buffers, &mut memories[m(i)]));
            }
            going.retain(|&i| !paths[i].done);
        }
        for path in paths.iter_mut() {
            self.hide_unscattered(path);
        }
    }

    /// Mitsuba's `hide_emitters` (src/integrators/path.cpp, v3.9.1), the path's end: with the flag, a path
    /// that drew no BSDF sample but pass-throughs shows nothing — the emitter or environment its camera ray
    /// reached (through `null` surfaces and `mask` holes too), and all it collected on the way (Mitsuba's
    /// `valid_ray`, false until a vertex samples a lobe other than `BSDFFlags::Null`, masks the whole
    /// result: a `mask`'s next-event estimate is dropped where the path then passes through and escapes).
    /// That last case is the one where Mitsuba's image depends on its sampling, not only on the scene: the
    /// estimate dropped is the light-sampling share of the power heuristic, whose BSDF-sampling share (the
    /// nested lobe's) is kept, so a partly opaque `mask` in front of the sky reads what each renderer's
    /// light and BSDF pdfs make it (measured: a 0.5-opaque panel lit by a constant sky, 10 % darker than
    /// Mitsuba's). Everywhere else the rule gives one image whatever the sampling.
    /// The rule's other part, the camera ray going on through area emitters, is
    /// [`PathTracer::past_area_emitters`].
    fn hide_unscattered(&self, path: &mut EyePath) {
        if self.scene.integrator.hide_emitters && !path.scattered {
            path.l = Vec3::ZERO;
        }
    }

    /// Mitsuba's `hide_emitters` at the camera ray (`skip_area_emitters`, src/render/integrator.cpp, called
    /// from path.cpp before the first vertex): the camera ray's `hit` if it is no area emitter's, else the
    /// first hit past every area emitter along the ray (each crossing traced anew from the emitter's
    /// surface, on either side of it), with `path.ray` the ray that found it. An emitter of zero radiance,
    /// which the scene leaves out of its lights, is a plain surface here (Mitsuba skips it too).
    fn past_area_emitters(&self, path: &mut EyePath, mut hit: Option<Hit>, stats: &mut PathStats) -> Option<Hit> {
        while let Some(h) = hit.filter(|h| self.scene.lights.light_of_prim(h.prim).is_some()) {
            path.ray = self.scene.interaction(&path.ray, &h).spawn_ray(path.dir);
            stats.rays += 1;
            hit = self.accel.intersect(&path.ray);
        }
        hit
    }

    /// A path's closest hit (or escape): the emission it finds, and at a vertex that continues, the
    /// next-event estimate's light sample and shadow ray (`path.shadow`). Marks the path done where it
    /// ends.
    fn at_hit(&self, path: &mut EyePath, hit: Option<Hit>, stats: &mut PathStats, scratch: &mut GatherScratch<'_>) {
        let scene = self.scene;
        let lights = &scene.lights;
        let (dir, beta, prev, delta_vertices) = (path.dir, path.beta, path.prev, path.delta_vertices);
        let hiding = prev == Vertex::Camera && scene.integrator.hide_emitters;
        let hit = if hiding { self.past_area_emitters(path, hit, stats) } else { hit };
        let Some(hit) = hit else {
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
                let w = self.emission_weight(prev, path.caustic.as_ref(), || lights.pdf_li_escaped(dir), pdf_emit, delta_vertices, stats, scratch);
                path.l += beta * w * le;
            }
            path.done = true;
            return;
        };
        let si = scene.interaction(&path.ray, &hit);
        let wo_world = -dir;

        // Emission from an area light that was hit.
        if let Some(light_index) = lights.light_of_prim(hit.prim) {
            let le = lights.le_area(hit.prim, si.ng, wo_world, || scene.tex_uv(&si));
            if le != Vec3::ZERO {
                let light_pdf = || match prev {
                    Vertex::NonDelta { p, .. } => lights.pdf_li_area(hit.prim, p, si.p, si.ng),
                    _ => 0.0,
                };
                let pdf_emit = || self.caustics.emission().map_or(0.0, |em| em.pdf_emit_area(light_index, si.p, si.ng, wo_world));
                path.l += beta * self.emission_weight(prev, path.caustic.as_ref(), light_pdf, pdf_emit, delta_vertices, stats, scratch) * le;
            }
        }
        if path.depth >= self.max_depth() {
            path.done = true;
            return;
        }

        let bsdf = scene.bsdf_at(&si);
        let material = self.materials[si.material as usize];
        let wo_local = si.frame.to_local(wo_world);
        // The caustic estimators' look-up at this vertex, made before the shadow ray: its cache misses
        // then overlap the ray (`caustic::Receiver`).
        let looked_up = (material.non_delta && self.caustics.active()).then(|| self.caustics.look_up(&si));

        // Next-event estimation (direct light L x), MIS with BSDF sampling. Choosing among lights and
        // lobes takes a dimension only where there is a choice (`LightSet::chooses_light`,
        // `Bsdf::chooses_lobe`).
        path.shadow = None;
        if material.non_delta && !lights.is_empty() {
            let sampler = &mut path.sampler;
            let u_sel = if lights.chooses_light() { sampler.next_1d() } else { 0.0 };
            let u_li = sampler.next_2d();
            if let Some((_, ls)) = lights.sample_li(si.p, u_sel, u_li) {
                let wi_local = si.frame.to_local(ls.wi_world);
                let (f, bsdf_pdf_w) = bsdf.f_pdf(wo_local, wi_local, TransportMode::Radiance);
                let f = f * wi_local.z.abs();
                if f != Vec3::ZERO && ls.pdf_w > 0.0 && ls.li != Vec3::ZERO {
                    let shadow = if ls.dist.is_finite() { si.spawn_ray_to(ls.p_light) } else { si.spawn_ray(ls.wi_world) };
                    // BSDF sampling reaches a delta light with probability 0: its density for this
                    // path is 0 and the one MIS function gives NEE weight 1 (method.md §4.1).
                    let bsdf_pdf_w = if ls.delta { 0.0 } else { bsdf_pdf_w };
                    let w = power_heuristic(ls.pdf_w, bsdf_pdf_w);
                    path.shadow = Some((shadow, beta * f * ls.li * (w / ls.pdf_w)));
                }
            }
        }
        path.vertex = Some(PendingVertex { si, wo_world, wo_local, looked_up });
    }

    /// The rest of the vertex `at_hit` left pending, given whether its shadow ray was occluded (`None`
    /// without one): the next-event estimate, T1, BSDF sampling, Russian roulette and the next ray.
    fn after_shadow(&self, path: &mut EyePath, occluded: Option<bool>, stats: &mut PathStats, scratch: &mut GatherScratch<'_>) {
        let PendingVertex { si, wo_world, wo_local, looked_up } = path.vertex.take().expect("at_hit left a vertex");
        if let (Some((_, nee)), Some(false)) = (path.shadow.take(), occluded) {
            path.l += nee;
        }
        let bsdf = self.scene.bsdf_at(&si);
        let material = self.materials[si.material as usize];
        let sampler = &mut path.sampler;

        // Caustics T1 at x with probability P (method.md §3.1), and ΔA(x), which T2 needs. A photon of m
        // delta bounces makes a path of depth + m + 1 segments here: T1 counts only those that fit
        // max_depth (method.md §2.1), and at the last vertex none does (nor can T2 reach a light through a
        // delta vertex from it), so there is no estimate to make.
        let mut area = None;
        let alpha = if path.first_non_delta { self.alpha } else { 1.0 };
        let longest = looked_up.map_or(0, |_| longest_chain(path.depth, self.max_depth()));
        if let (Some(_), 0) = (looked_up, longest) {
            area = Some(OriginArea::Deferred { p: si.p, ng: si.ng, wo_side: wo_world.dot(si.ng) });
        } else if let Some(looked_up) = looked_up {
            let rx = self.caustics.receiver(&si, &bsdf, wo_world, wo_local, looked_up);
            let p_gather = self.caustics.gather_probability(&rx, path.beta, path.l.max(path.pixel_mean), scratch);
            // The roulette's number is drawn whether P < 1 or not, and independent of the pixel's other
            // samples (`Sampler::next_independent_1d`): P reads their radiance (`pixel_mean`) and their
            // queries (`scratch`). Drawn only where P < 1, it shifted this sample's later dimensions by
            // what the earlier samples found, and those dimensions are stratified against theirs: the
            // direction after a dark sample leaned toward bright ones (method.md §3.1; +7.5 % on the
            // cornell ceiling in `pm` with 4-spp passes).
            if sampler.next_independent_1d() < p_gather {
                let g = self.caustics.gather(&rx, alpha, longest, scratch);
                stats.knn_queries += 1;
                stats.q1.merge(&g.q1);
                path.l += path.beta * g.l1 / p_gather;
                area = Some(OriginArea::Known(g.delta_area));
            } else {
                area = Some(OriginArea::Deferred { p: si.p, ng: si.ng, wo_side: wo_world.dot(si.ng) });
            }
        }
        if material.non_delta {
            path.first_non_delta = false;
        }

        // Continue the path by BSDF sampling.
        let u_lobe = if material.chooses_lobe { sampler.next_1d() } else { 0.0 };
        let u_dir = sampler.next_2d();
        let bs = bsdf.sample(wo_local, u_lobe, u_dir, TransportMode::Radiance);
        // A failed sample counts as scattered, as Mitsuba's sample of a non-null lobe with weight 0 does.
        path.scattered |= bs.as_ref().is_none_or(|s| !s.pass_through);
        let Some(bs) = bs else {
            path.done = true;
            return;
        };
        if bs.weight == Vec3::ZERO {
            path.done = true;
            return;
        }
        path.beta *= bs.weight;
        debug_assert!(path.beta.is_finite(), "throughput not finite: {}", path.beta);
        let wi_world = si.frame.to_world(bs.wi_local);
        if bs.delta {
            path.prev = Vertex::Delta;
            path.delta_vertices = path.delta_vertices.saturating_add(1);
        } else {
            path.delta_vertices = 0;
            path.prev = Vertex::NonDelta { p: si.p, pdf_w: bs.pdf_w };
            path.caustic = area.map(|area| CausticOrigin { pdf_w: bs.pdf_w, cos_theta: bs.wi_local.z.abs(), area, alpha, longest_chain: longest });
        }

        // Russian roulette (survival ∝ throughput, capped at 0.95).
        if path.depth >= self.scene.integrator.rr_depth {
            let p_survive = path.beta.max_element().min(0.95);
            if p_survive <= 0.0 || sampler.next_1d() >= p_survive {
                path.done = true;
                return;
            }
            path.beta /= p_survive;
        }
        path.depth += 1;
        path.ray = si.spawn_ray(wi_world);
        path.dir = wi_world.normalize();
    }
}
