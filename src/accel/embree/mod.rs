//! The Embree backend: Embree 3 or 4 (chosen by `build.rs` from the installed headers) through our
//! own bindgen bindings. The only module of the crate allowed `unsafe`.
//!
//! - `sys`: the generated bindings (`rtc*` / `RTC*` only).
//! - `handles`: RAII owners of device, scene and geometry; the device's error callback.
//! - `query`: the ray helper, the Embree 3 vs 4 call difference, per-thread FTZ/DAZ.
//!
//! The whole flat soup is ONE `RTC_GEOMETRY_TYPE_TRIANGLE` geometry, so Embree's `primID` is the
//! global triangle index, and `(t, prim, u, v)` come straight from `RTCRayHit` (Embree's barycentric
//! convention is the crate's). Errors are checked once, after the build, never per ray.
//!
//! Instances (`EmbreeAccel::instanced`): each prototype is its own committed scene of one triangle
//! geometry; each instance an `RTC_GEOMETRY_TYPE_INSTANCE` geometry of the top scene placing it
//! (`rtcSetGeometryInstancedScene`, `rtcSetGeometryTransform`), attached under the ID of its index, so
//! the hit's `instID[0]` is the instance and its `primID` the prototype's triangle, to which the
//! prototype's first soup index is added. The flat soup takes the ID after the last instance. Embree 3.13
//! and 4 both trace one level of instancing with the default query context.
#![allow(unsafe_code)]

mod handles;
mod query;
mod sys;

use self::handles::{CommittedScene, Device, Geometry, Scene};
use self::query::{ensure_ftz_daz, hit_of, rtc_ray, rtc_ray_hit, was_occluded, QueryContext, INVALID_ID};
use super::{occluded_each, Accel, Hit};
use crate::error::AccelError;
use crate::math::{Ray, Vec3};

/// The Embree version found at build time, e.g. `"3.13.5"` or `"4.3.3"`.
pub const VERSION: &str = env!("CAUSTICA_EMBREE_VERSION");

/// Scene build quality: `RTC_BUILD_QUALITY_MEDIUM`, Embree's default binned-SAH builder (≈0.4 s for
/// 1.15 M triangles here). `HIGH` (spatial splits) measured no gain on Embree 3.13.5 with ROBUST: the same
/// build time on 1 M triangles and ray rates within noise on the teapot, bunny, cornell, teapot-glossy and
/// a sky-sphere scene — with ROBUST, Embree 3 builds its robust triangle BVH with the binned builder
/// whatever the quality (ARCHITECTURE.md, Decisions); `LOW` (Morton) builds faster but traces slower.
const BUILD_QUALITY: sys::RTCBuildQuality = sys::RTC_BUILD_QUALITY_MEDIUM;

/// Scene flags: `RTC_SCENE_FLAG_ROBUST`: traversal and triangle tests avoid optimisations that lose
/// accuracy. Needed for watertightness: without it (Embree 3.13.5), rays from a sphere's centre
/// through its vertices leak (`tests/suite/embree_backend.rs` fails), while the brute-force oracle and the
/// BVH use the watertight Woop test. It costs speed: without it `pt` ran ×1.06 (an earlier stop) to ×1.12
/// (stop 30) faster on the cornell mesh scene (ARCHITECTURE.md, Decisions, with the leak rates).
const SCENE_FLAGS: sys::RTCSceneFlags = sys::RTCSceneFlags::RTC_SCENE_FLAG_ROBUST;

// `RTC_FORMAT_FLOAT3` items are three packed f32; glam's `Vec3` is `#[repr(C)] { x, y, z }`.
const _: () = assert!(size_of::<Vec3>() == 12 && align_of::<Vec3>() == 4);

/// An Embree scene over one triangle soup, ready for concurrent queries.
pub struct EmbreeAccel {
    // Field order is drop order: the scene is released before the prototypes it instances, and they
    // before their device.
    scene: CommittedScene,
    /// The prototypes' scenes (instanced scenes only).
    _prototypes: Vec<CommittedScene>,
    /// Per instance, the soup index of its prototype's first triangle (empty without instances).
    inst_first: Vec<u32>,
    /// Owns the device (and its error log) for as long as the scene lives.
    _device: Device,
    triangle_count: usize,
}

// SAFETY: after `rtcCommitScene` the scene is never modified; Embree documents `rtcIntersect1` and
// `rtcOccluded1` as thread-safe on a committed scene, and every query builds its own ray and query
// context on the calling thread's stack. Releasing the handles (in `Drop`) may happen on any thread.
// The device is only touched at setup (`new`) and in `Drop`, both with exclusive access.
unsafe impl Send for EmbreeAccel {}
// SAFETY: see `Send`: `&EmbreeAccel` only exposes queries on the committed scene.
unsafe impl Sync for EmbreeAccel {}

impl std::fmt::Debug for EmbreeAccel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmbreeAccel")
            .field("version", &VERSION)
            .field("triangles", &self.triangle_count)
            .finish()
    }
}

impl EmbreeAccel {
    /// Builds the scene: all triangles in one geometry (primID = index in `indices`). An empty soup
    /// gives a scene without geometry, on which every ray misses.
    ///
    /// # Errors
    /// [`AccelError::InvalidGeometry`] for out-of-range indices or non-finite positions (Embree would
    /// read out of bounds); [`AccelError::Embree`] with Embree's message if any setup call failed.
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<Self, AccelError> {
        Self::build(positions, indices, SCENE_FLAGS)
    }

    /// The same scene built without `RTC_SCENE_FLAG_ROBUST`, as Mitsuba 3 builds its own: Embree's faster
    /// triangle test, which is **not watertight** (rays through shared edges and vertices can pass through
    /// a closed mesh). For `caustica bench` only, which reports what the flag costs on a scene and how many
    /// answers change without it; the renderer never builds it ([`SCENE_FLAGS`]).
    ///
    /// # Errors
    /// As [`EmbreeAccel::new`].
    pub fn without_robust(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<Self, AccelError> {
        Self::build(positions, indices, sys::RTCSceneFlags::RTC_SCENE_FLAG_NONE)
    }

    fn build(positions: &[Vec3], indices: &[[u32; 3]], flags: sys::RTCSceneFlags) -> Result<Self, AccelError> {
        super::validate_soup(positions, indices)?;
        let device = Device::new()?;
        device.check("rtcNewDevice")?;
        let mut scene = Scene::new(&device)?;
        if !indices.is_empty() {
            let mut geometry = Geometry::new(&device, sys::RTC_GEOMETRY_TYPE_TRIANGLE)?;
            geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_VERTEX, sys::RTC_FORMAT_FLOAT3, positions)?;
            geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_INDEX, sys::RTC_FORMAT_UINT3, indices)?;
            geometry.commit();
            let geom_id = scene.attach(geometry);
            device.check("creating the triangle geometry")?;
            if geom_id != 0 {
                return Err(AccelError::Embree(format!("expected geometry ID 0, Embree assigned {geom_id}")));
            }
        }
        scene.set_flags(flags);
        scene.set_build_quality(BUILD_QUALITY);
        let scene = scene.commit();
        device.check("rtcCommitScene")?;
        Ok(Self {
            scene,
            _prototypes: Vec::new(),
            inst_first: Vec::new(),
            _device: device,
            triangle_count: indices.len(),
        })
    }

    /// Builds the two-level scene: the triangles `flat` (hits numbered in `flat`) and the instances of
    /// `g` (module docs).
    ///
    /// # Errors
    /// As [`EmbreeAccel::new`].
    pub fn instanced(g: &super::Geometry, flat: &[[u32; 3]]) -> Result<Self, AccelError> {
        super::validate_soup(g.positions, g.indices)?;
        let device = Device::new()?;
        device.check("rtcNewDevice")?;
        let mut prototypes = Vec::with_capacity(g.prototypes.len());
        for p in 0..g.prototypes.len() {
            let mut scene = Scene::new(&device)?;
            let indices = g.prototype_indices(p);
            if !indices.is_empty() {
                let mut geometry = Geometry::new(&device, sys::RTC_GEOMETRY_TYPE_TRIANGLE)?;
                geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_VERTEX, sys::RTC_FORMAT_FLOAT3, g.positions)?;
                geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_INDEX, sys::RTC_FORMAT_UINT3, indices)?;
                geometry.commit();
                scene.attach(geometry);
            }
            scene.set_flags(SCENE_FLAGS);
            scene.set_build_quality(BUILD_QUALITY);
            prototypes.push(scene.commit());
            device.check("building a prototype's scene")?;
        }
        let mut scene = Scene::new(&device)?;
        for (id, inst) in g.instances.iter().enumerate() {
            let mut geometry = Geometry::new(&device, sys::RTC_GEOMETRY_TYPE_INSTANCE)?;
            let (m, t) = (inst.to_world.matrix3, inst.to_world.translation);
            let columns = [m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z, m.z_axis.x, m.z_axis.y, m.z_axis.z, t.x, t.y, t.z];
            geometry.set_instance(&prototypes[inst.prototype as usize], &columns);
            geometry.commit();
            scene.attach_by_id(geometry, id as u32);
        }
        device.check("creating the instances")?;
        if !flat.is_empty() {
            let mut geometry = Geometry::new(&device, sys::RTC_GEOMETRY_TYPE_TRIANGLE)?;
            geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_VERTEX, sys::RTC_FORMAT_FLOAT3, g.positions)?;
            geometry.set_new_buffer(&device, sys::RTC_BUFFER_TYPE_INDEX, sys::RTC_FORMAT_UINT3, flat)?;
            geometry.commit();
            scene.attach_by_id(geometry, g.instances.len() as u32);
            device.check("creating the triangle geometry")?;
        }
        scene.set_flags(SCENE_FLAGS);
        scene.set_build_quality(BUILD_QUALITY);
        let scene = scene.commit();
        device.check("rtcCommitScene")?;
        Ok(Self {
            scene,
            _prototypes: prototypes,
            inst_first: g.instances.iter().map(|i| g.prototypes[i.prototype as usize].start).collect(),
            _device: device,
            triangle_count: flat.len(),
        })
    }

    /// The closest hit as Embree numbers it (an instance's triangle in its prototype).
    #[inline(always)]
    fn intersect_raw(&self, ray: &Ray) -> Option<Hit> {
        ensure_ftz_daz();
        let mut rayhit = rtc_ray_hit(ray);
        QueryContext::new().intersect1(&self.scene, &mut rayhit);
        hit_of(&rayhit)
    }

    /// `hit` with its prototype triangle numbered in the soup (a hit on an instance).
    #[inline(always)]
    fn in_soup(&self, hit: Option<Hit>) -> Option<Hit> {
        hit.map(|h| if h.inst == super::FLAT { h } else { Hit { prim: h.prim + self.inst_first[h.inst as usize], ..h } })
    }

    /// Number of triangles in the scene.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Raw Embree throughput baseline: `rtcIntersect1` over `rays` in a tight loop with one
    /// pre-initialised query context, counting hits. Lets the benchmark show that [`Accel::intersect`]
    /// adds nothing measurable over raw Embree.
    #[must_use]
    pub fn intersect_raw_baseline(&self, rays: &[Ray]) -> usize {
        ensure_ftz_daz();
        let mut ctx = QueryContext::new();
        let mut hits = 0;
        for ray in rays {
            let mut rayhit = rtc_ray_hit(ray);
            ctx.intersect1(&self.scene, &mut rayhit);
            hits += usize::from(rayhit.hit.geomID != INVALID_ID);
        }
        hits
    }
}

/// How the benchmark hands a set of rays to Embree: one `rtcIntersect1` / `rtcOccluded1` per ray, packets of
/// 4, 8 or 16 (`rtcIntersect4/8/16`, `rtcOccluded4/8/16`), or one stream (`rtcIntersect1M`, Embree 3 only;
/// occlusion has no stream variant here).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Batching {
    Single,
    Packet4,
    Packet8,
    Packet16,
    Stream,
}

impl Batching {
    /// The ways this build of Embree offers (no streams in Embree 4).
    pub const AVAILABLE: &'static [Batching] = if cfg!(embree3) {
        &[Batching::Single, Batching::Packet4, Batching::Packet8, Batching::Packet16, Batching::Stream]
    } else {
        &[Batching::Single, Batching::Packet4, Batching::Packet8, Batching::Packet16]
    };

    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Batching::Single => "single",
            Batching::Packet4 => "packet4",
            Batching::Packet8 => "packet8",
            Batching::Packet16 => "packet16",
            Batching::Stream => "stream",
        }
    }
}

impl EmbreeAccel {
    /// Closest hits of `rays` handed to Embree as `batching` says (packets: a lone ray left over by
    /// `rtcIntersect1`; streams: one call for all of `rays`); `out[i]` answers `rays[i]`, the same answer
    /// whatever the batching.
    pub fn intersect_batched(&self, rays: &[Ray], out: &mut [Option<Hit>], batching: Batching) {
        assert_eq!(rays.len(), out.len());
        ensure_ftz_daz();
        let mut ctx = QueryContext::new();
        // Embree's own numbering (a prototype's triangles from 0), made the soup's at the end.
        let one = |ray: &Ray| self.intersect_raw(ray);
        match batching {
            Batching::Single => out.iter_mut().zip(rays).for_each(|(o, ray)| *o = one(ray)),
            Batching::Packet4 => in_packets(4, rays, out, one, |r, o| ctx.intersect4(&self.scene, r, o)),
            Batching::Packet8 => in_packets(8, rays, out, one, |r, o| ctx.intersect8(&self.scene, r, o)),
            Batching::Packet16 => in_packets(16, rays, out, one, |r, o| ctx.intersect16(&self.scene, r, o)),
            #[cfg(embree3)]
            Batching::Stream => ctx.intersect_stream(&self.scene, rays, out),
            #[cfg(not(embree3))]
            Batching::Stream => panic!("Embree {VERSION} has no ray streams"),
        }
        if !self.inst_first.is_empty() {
            out.iter_mut().for_each(|o| *o = self.in_soup(*o));
        }
    }

    /// Occlusion of `rays` handed to Embree as `batching` says (packets: a lone ray left over by
    /// `rtcOccluded1`; `Stream` is not offered: panics); `out[i]` answers `rays[i]` as [`Accel::occluded`]
    /// does.
    pub fn occluded_batched(&self, rays: &[Ray], out: &mut [bool], batching: Batching) {
        assert_eq!(rays.len(), out.len());
        ensure_ftz_daz();
        let mut ctx = QueryContext::new();
        let one = |ray: &Ray| self.occluded(ray);
        match batching {
            Batching::Single => occluded_each(self, rays, out),
            Batching::Packet4 => in_packets(4, rays, out, one, |r, o| ctx.occluded4(&self.scene, r, o)),
            Batching::Packet8 => in_packets(8, rays, out, one, |r, o| ctx.occluded8(&self.scene, r, o)),
            Batching::Packet16 => in_packets(16, rays, out, one, |r, o| ctx.occluded16(&self.scene, r, o)),
            Batching::Stream => panic!("no occlusion stream is offered"),
        }
    }
}

/// `out[i]` for `rays[i]`: `n` rays at a time by `packet`, a lone ray left over by `one` (a packet call
/// with one active lane costs more than a single-ray call).
fn in_packets<T>(n: usize, rays: &[Ray], out: &mut [T], one: impl Fn(&Ray) -> T, mut packet: impl FnMut(&[Ray], &mut [T])) {
    for (rays, out) in rays.chunks(n).zip(out.chunks_mut(n)) {
        if let ([ray], [o]) = (rays, &mut *out) {
            *o = one(ray);
        } else {
            packet(rays, out);
        }
    }
}

impl Accel for EmbreeAccel {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let hit = self.in_soup(self.intersect_raw(ray));
        debug_assert!(hit.is_none_or(|h| h.inst != super::FLAT || (h.prim as usize) < self.triangle_count));
        hit
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        ensure_ftz_daz();
        let mut rtc = rtc_ray(ray);
        QueryContext::new().occluded1(&self.scene, &mut rtc);
        was_occluded(rtc.tfar, ray)
    }

    fn name(&self) -> &'static str {
        "embree"
    }

    /// In packets of 8 (`rtcIntersect8`), a lone ray by `rtcIntersect1`: the same answers bit for bit
    /// (`query::packet_queries`). On the path tracer's waves of real render rays (cornell scene with mesh
    /// spheres, waves of 76 rays on average), packets of 8 trace closest-hit rays 1.21× and shadow rays
    /// 1.50× as fast as one call per ray; packets of 4 1.20× and 1.26×, of 16 1.17× and 1.59×, a stream
    /// (`rtcIntersect1M`) 1.15× (ARCHITECTURE.md, "The path tracer's waves").
    fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.intersect_batched(rays, out, Batching::Packet8);
    }

    fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        self.occluded_batched(rays, out, Batching::Packet8);
    }
}
