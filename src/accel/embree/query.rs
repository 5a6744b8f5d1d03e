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
use crate::math::Ray;

/// `RTC_INVALID_GEOMETRY_ID` (`(unsigned int)-1`): `hit.geomID` after a miss.
pub(super) const INVALID_ID: u32 = sys::RTC_INVALID_GEOMETRY_ID;

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
