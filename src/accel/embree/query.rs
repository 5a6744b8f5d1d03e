//! Per-ray calls: the one helper that fills every `RTCRay` field, the Embree 3 / Embree 4 difference in
//! `rtcIntersect1` / `rtcOccluded1`, and the per-thread flush-to-zero / denormals-are-zero setup.
//!
//! Embree 3: `rtcIntersect1(scene, RTCIntersectContext*, rayhit)`, the context set up by the header's
//! inline `rtcInitIntersectContext`. Embree 4: `rtcIntersect1(scene, rayhit, RTCIntersectArguments*)`
//! (`rtcOccluded1` likewise with `RTCOccludedArguments`), set up by `rtcInitIntersectArguments` /
//! `rtcInitOccludedArguments`. Those initialisers are `RTC_FORCEINLINE` and have no symbol, so they
//! are written out below from the headers (`rtcore_common.h`, Embree 4 `rtcore_scene.h`).

use std::cell::Cell;

use super::handles::CommittedScene;
use super::sys;
use crate::accel::Hit;
use crate::math::Ray;

/// `RTC_INVALID_GEOMETRY_ID` (`(unsigned int)-1`): `hit.geomID` after a miss.
pub(super) const INVALID_ID: u32 = sys::RTC_INVALID_GEOMETRY_ID;
// A hit's `instID[0]` is Embree's invalid ID on the flat soup: the crate's `FLAT`.
const _: () = assert!(INVALID_ID == crate::accel::FLAT);

/// The one place an `RTCRay` is built: every field set explicitly. `mask` is all ones (a zero mask
/// would miss every geometry), `time` 0 (no motion blur), `id`/`flags` 0.
#[inline]
#[must_use]
pub(super) fn rtc_ray(ray: &Ray) -> sys::RTCRay {
    sys::RTCRay {
        org_x: ray.origin.x,
        org_y: ray.origin.y,
        org_z: ray.origin.z,
        tnear: ray.t_min,
        dir_x: ray.dir.x,
        dir_y: ray.dir.y,
        dir_z: ray.dir.z,
        time: 0.0,
        tfar: ray.t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// An `RTCRayHit` for `rtcIntersect1`: the ray from [`rtc_ray`] and a hit whose IDs are all invalid.
/// The hit struct comes from the generated bindings (Embree 4's is larger than Embree 3's).
#[inline]
#[must_use]
pub(super) fn rtc_ray_hit(ray: &Ray) -> sys::RTCRayHit {
    let mut hit = sys::RTCHit {
        geomID: INVALID_ID,
        primID: INVALID_ID,
        ..Default::default()
    };
    hit.instID.fill(INVALID_ID);
    sys::RTCRayHit { ray: rtc_ray(ray), hit }
}

/// The closest hit `rtcIntersect1` (or a stream) left in `rayhit`, `None` after a miss.
#[inline]
#[must_use]
pub(super) fn hit_of(rayhit: &sys::RTCRayHit) -> Option<Hit> {
    (rayhit.hit.geomID != INVALID_ID).then_some(Hit {
        t: rayhit.ray.tfar,
        prim: rayhit.hit.primID,
        u: rayhit.hit.u,
        v: rayhit.hit.v,
        // The instance geometry's ID, or RTC_INVALID_GEOMETRY_ID (= `FLAT`) on the flat soup.
        inst: rayhit.hit.instID[0],
    })
}

/// Whether an occlusion query found a hit: Embree marks an occluded ray by setting `tfar = −∞`; a ray
/// that came in with `t_max = −∞` (an empty interval) keeps it without being occluded.
#[inline]
#[must_use]
pub(super) fn was_occluded(tfar: f32, ray: &Ray) -> bool {
    tfar == f32::NEG_INFINITY && ray.t_max != f32::NEG_INFINITY
}

/// The per-query arguments of one Embree major version, initialised as the header's inline
/// initialiser does. Embree may write into them during traversal, so each thread uses its own.
#[cfg(embree3)]
pub(super) struct QueryContext(sys::RTCIntersectContext);

#[cfg(embree3)]
impl QueryContext {
    /// `rtcInitIntersectContext` (Embree 3 `rtcore_common.h`): incoherent rays, no filter, empty
    /// instance stack; the optional fields (`instStackSize`, `minWidthDistanceFactor`) are zero.
    #[inline]
    #[must_use]
    pub fn new() -> Self {
        let mut ctx = sys::RTCIntersectContext {
            flags: sys::RTCIntersectContextFlags::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            ..Default::default()
        };
        ctx.instID.fill(INVALID_ID);
        Self(ctx)
    }

    #[inline]
    pub fn intersect1(&mut self, scene: &CommittedScene, rayhit: &mut sys::RTCRayHit) {
        // SAFETY: the scene is committed and never modified again (concurrent queries are allowed);
        // the context and ray-hit are valid, exclusively borrowed and suitably aligned.
        unsafe { sys::rtcIntersect1(scene.raw(), &mut self.0, rayhit) };
    }

    #[inline]
    pub fn occluded1(&mut self, scene: &CommittedScene, ray: &mut sys::RTCRay) {
        // SAFETY: as in `intersect1`.
        unsafe { sys::rtcOccluded1(scene.raw(), &mut self.0, ray) };
    }
}

#[cfg(embree4)]
pub(super) struct QueryContext {
    intersect: sys::RTCIntersectArguments,
    occluded: sys::RTCOccludedArguments,
}

#[cfg(embree4)]
impl QueryContext {
    /// `rtcInitIntersectArguments` / `rtcInitOccludedArguments` (Embree 4 `rtcore_scene.h`): incoherent
    /// rays, all features, no ray-query context (Embree uses a default one), no callbacks;
    /// `minWidthDistanceFactor`, where compiled in, is zero.
    #[inline]
    #[must_use]
    pub fn new() -> Self {
        Self {
            intersect: sys::RTCIntersectArguments {
                flags: sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT,
                feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
                context: std::ptr::null_mut(),
                filter: None,
                intersect: None,
                ..Default::default()
            },
            occluded: sys::RTCOccludedArguments {
                flags: sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT,
                feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
                context: std::ptr::null_mut(),
                filter: None,
                occluded: None,
                ..Default::default()
            },
        }
    }

    #[inline]
    pub fn intersect1(&mut self, scene: &CommittedScene, rayhit: &mut sys::RTCRayHit) {
        // SAFETY: the scene is committed and never modified again (concurrent queries are allowed);
        // the arguments and ray-hit are valid, exclusively borrowed and suitably aligned.
        unsafe { sys::rtcIntersect1(scene.raw(), rayhit, &mut self.intersect) };
    }

    #[inline]
    pub fn occluded1(&mut self, scene: &CommittedScene, ray: &mut sys::RTCRay) {
        // SAFETY: as in `intersect1`.
        unsafe { sys::rtcOccluded1(scene.raw(), ray, &mut self.occluded) };
    }
}

thread_local! {
    static FTZ_DAZ_SET: Cell<bool> = const { Cell::new(false) };
}

/// Sets flush-to-zero and denormals-are-zero on the calling thread, once per thread, as Embree's
/// manual asks of every thread that calls it (denormals slow traversal down by orders of magnitude).
/// Side effect: all later SSE float arithmetic on this thread flushes denormals to zero too.
#[inline]
pub(super) fn ensure_ftz_daz() {
    let done = FTZ_DAZ_SET.try_with(|set| set.replace(true)).unwrap_or(false);
    if !done {
        set_ftz_daz();
    }
}

/// MXCSR bits: FTZ (bit 15, 0x8000) and DAZ (bit 6, 0x0040).
#[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
#[allow(deprecated)] // `_mm_getcsr`/`_mm_setcsr` are deprecated in favour of inline asm, but exact.
fn set_ftz_daz() {
    #[cfg(target_arch = "x86")]
    use std::arch::x86::{_mm_getcsr, _mm_setcsr};
    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
    const FTZ: u32 = 0x8000;
    const DAZ: u32 = 0x0040;
    // SAFETY: reads and writes this thread's MXCSR, only setting the FTZ and DAZ mode bits (no
    // exception is unmasked); SSE is available on every x86 target Embree supports.
    unsafe { _mm_setcsr(_mm_getcsr() | FTZ | DAZ) };
}

/// Other architectures: MXCSR is x86-only; caustica is built and tested on x86_64, so no FPCR setup
/// is attempted here.
#[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
fn set_ftz_daz() {}

/// The `valid` mask of Embree's packet calls: −1 for an active lane, 0 for an inactive one; Embree reads
/// it with vector loads, so it is aligned as the widest packet.
#[repr(C, align(64))]
struct Valid<const N: usize>([std::os::raw::c_int; N]);

/// One `rtc{Intersect,Occluded}N` call with the Embree 3 (context) or Embree 4 (arguments) signature.
#[cfg(embree3)]
macro_rules! packet_call {
    ($f:ident, $args:ident, $ctx:expr, $valid:expr, $scene:expr, $packet:expr) => {
        // SAFETY: the scene is committed and never modified again (concurrent queries are allowed); the
        // valid mask, context and packet are valid, exclusively borrowed and aligned as Embree requires
        // (the bindings carry the packet types' alignment, `Valid` is 64-byte aligned).
        unsafe { sys::$f($valid.0.as_ptr(), $scene.raw(), &mut $ctx.0, $packet) }
    };
}
#[cfg(embree4)]
macro_rules! packet_call {
    ($f:ident, $args:ident, $ctx:expr, $valid:expr, $scene:expr, $packet:expr) => {
        // SAFETY: as for Embree 3 above: committed scene; valid mask, arguments and packet valid,
        // exclusively borrowed and aligned as Embree requires.
        unsafe { sys::$f($valid.0.as_ptr(), $scene.raw(), $packet, &mut $ctx.$args) }
    };
}

/// Fills lane `lane` of an SoA ray packet (`RTCRay4/8/16`) from `ray`, every field as [`rtc_ray`] does.
macro_rules! set_lane {
    ($p:expr, $lane:expr, $ray:expr) => {{
        let (p, i, r) = (&mut $p, $lane, $ray);
        p.org_x[i] = r.origin.x;
        p.org_y[i] = r.origin.y;
        p.org_z[i] = r.origin.z;
        p.tnear[i] = r.t_min;
        p.dir_x[i] = r.dir.x;
        p.dir_y[i] = r.dir.y;
        p.dir_z[i] = r.dir.z;
        p.time[i] = 0.0;
        p.tfar[i] = r.t_max;
        p.mask[i] = u32::MAX;
        p.id[i] = 0;
        p.flags[i] = 0;
    }};
}

/// Packet queries of one width: up to N rays per `rtcIntersectN` / `rtcOccludedN` call, the answers
/// exactly those of `rtcIntersect1` / `rtcOccluded1` per ray (Embree's packet and single-ray kernels run
/// the same triangle test; `tests/suite/embree_backend.rs` checks them bit for bit).
macro_rules! packet_queries {
    ($n:literal, $intersect:ident, $occluded:ident, $RayHitN:ident, $RayN:ident, $rtc_intersect:ident, $rtc_occluded:ident) => {
        impl QueryContext {
            /// Closest hits of `rays` (at most N) in one packet call: `out[i]` answers `rays[i]`.
            pub fn $intersect(&mut self, scene: &CommittedScene, rays: &[Ray], out: &mut [Option<Hit>]) {
                assert!(rays.len() <= $n && out.len() == rays.len(), "{} rays for a packet of {}", rays.len(), $n);
                let mut valid = Valid([0; $n]);
                let mut packet = sys::$RayHitN::default();
                for (lane, ray) in rays.iter().enumerate() {
                    valid.0[lane] = -1;
                    set_lane!(packet.ray, lane, ray);
                }
                packet.hit.geomID = [INVALID_ID; $n];
                packet.hit.primID = [INVALID_ID; $n];
                packet.hit.instID.iter_mut().for_each(|level| level.fill(INVALID_ID));
                packet_call!($rtc_intersect, intersect, self, valid, scene, &mut packet);
                for (lane, o) in out.iter_mut().enumerate() {
                    *o = (packet.hit.geomID[lane] != INVALID_ID).then(|| Hit {
                        t: packet.ray.tfar[lane],
                        prim: packet.hit.primID[lane],
                        u: packet.hit.u[lane],
                        v: packet.hit.v[lane],
                        inst: packet.hit.instID[0][lane],
                    });
                }
            }

            /// Occlusion of `rays` (at most N) in one packet call: `out[i]` answers `rays[i]` as
            /// `Accel::occluded` does (tfar = −∞ marks a hit, except on an empty interval).
            pub fn $occluded(&mut self, scene: &CommittedScene, rays: &[Ray], out: &mut [bool]) {
                assert!(rays.len() <= $n && out.len() == rays.len(), "{} rays for a packet of {}", rays.len(), $n);
                let mut valid = Valid([0; $n]);
                let mut packet = sys::$RayN::default();
                for (lane, ray) in rays.iter().enumerate() {
                    valid.0[lane] = -1;
                    set_lane!(packet, lane, ray);
                }
                packet_call!($rtc_occluded, occluded, self, valid, scene, &mut packet);
                for (lane, (o, ray)) in out.iter_mut().zip(rays).enumerate() {
                    *o = was_occluded(packet.tfar[lane], ray);
                }
            }
        }
    };
}

packet_queries!(4, intersect4, occluded4, RTCRayHit4, RTCRay4, rtcIntersect4, rtcOccluded4);
packet_queries!(8, intersect8, occluded8, RTCRayHit8, RTCRay8, rtcIntersect8, rtcOccluded8);
packet_queries!(16, intersect16, occluded16, RTCRayHit16, RTCRay16, rtcIntersect16, rtcOccluded16);

/// Embree 3's ray streams (Embree 4 has none): `rtcIntersect1M` over an array of `RTCRayHit`.
#[cfg(embree3)]
impl QueryContext {
    /// Closest hits of `rays` in one `rtcIntersect1M` call; `out[i]` answers `rays[i]`.
    pub fn intersect_stream(&mut self, scene: &CommittedScene, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(out.len(), rays.len());
        let mut stream: Vec<sys::RTCRayHit> = rays.iter().map(rtc_ray_hit).collect();
        let m = u32::try_from(stream.len()).expect("a stream of fewer than 2^32 rays");
        // SAFETY: committed scene; the context is exclusively borrowed; `stream` holds `m` initialised,
        // suitably aligned `RTCRayHit`s spaced by their size.
        unsafe { sys::rtcIntersect1M(scene.raw(), &mut self.0, stream.as_mut_ptr(), m, size_of::<sys::RTCRayHit>()) };
        for (o, rh) in out.iter_mut().zip(&stream) {
            *o = hit_of(rh);
        }
    }
}
