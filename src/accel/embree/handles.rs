//! RAII owners of Embree's reference-counted handles, and the device's error log.
//!
//! Each handle is wrapped in its owner the moment Embree returns it, so every early return releases
//! it exactly once. Reference counting follows the Embree API manual: `rtcAttachGeometry` makes the
//! scene hold its own reference to the geometry, so [`Scene::attach`] consumes the [`Geometry`] and
//! releases ours right away; a scene likewise retains its device.

use std::ffi::{c_char, c_void, CStr};
use std::mem::MaybeUninit;
use std::sync::{Mutex, PoisonError};

use super::sys;
use crate::error::AccelError;

/// The last error Embree reported through the device's error callback.
#[derive(Debug, Default)]
struct ErrorLog {
    last: Mutex<Option<String>>,
}

/// Embree's error callback (`RTCErrorFunction`): records the error for [`Device::check`]. Embree may
/// call it from any thread, hence the mutex. Never unwinds (no panicking operation in here).
unsafe extern "C" fn record_error(user_ptr: *mut c_void, code: sys::RTCError, message: *const c_char) {
    // SAFETY: `user_ptr` is the `ErrorLog` registered in `Device::new`; it is boxed (fixed address)
    // and outlives the registration, which `Device::drop` removes before freeing it.
    let log = unsafe { &*user_ptr.cast_const().cast::<ErrorLog>() };
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated message valid for the duration of the call.
        unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
    };
    *log.last.lock().unwrap_or_else(PoisonError::into_inner) = Some(format!("{}: {text}", error_name(code)));
}

/// Name of an `RTCError` code. Unknown codes (a newer Embree) are reported by number.
fn error_name(code: sys::RTCError) -> String {
    match code {
        sys::RTC_ERROR_NONE => "RTC_ERROR_NONE".into(),
        sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN".into(),
        sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT".into(),
        sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION".into(),
        sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY".into(),
        sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU".into(),
        sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED".into(),
        other => format!("Embree error code {other}"),
    }
}

/// An Embree device with an error callback registered.
#[derive(Debug)]
pub(super) struct Device {
    raw: sys::RTCDevice,
    errors: Box<ErrorLog>,
}

impl Device {
    /// A device with Embree's default configuration (all hardware threads for builds).
    pub fn new() -> Result<Self, AccelError> {
        // SAFETY: the configuration string is NUL-terminated (a C string literal).
        let raw = unsafe { sys::rtcNewDevice(c"".as_ptr()) };
        if raw.is_null() {
            // SAFETY: with a null device, rtcGetDeviceError reports why rtcNewDevice failed on this thread.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(AccelError::Embree(format!("rtcNewDevice failed: {}", error_name(code))));
        }
        let device = Self {
            raw,
            errors: Box::default(),
        };
        let log: *const ErrorLog = &*device.errors;
        // SAFETY: `raw` is a live device; `log` points into the box owned by `device`, which stays at
        // the same address and is unregistered in `Drop` before it is freed.
        unsafe { sys::rtcSetDeviceErrorFunction(device.raw, Some(record_error), log.cast_mut().cast()) };
        Ok(device)
    }

    /// `Err` with the pending error (from the callback or `rtcGetDeviceError`) if any, naming `during`.
    /// Called at setup only, never per ray.
    pub fn check(&self, during: &str) -> Result<(), AccelError> {
        let logged = self.errors.last.lock().unwrap_or_else(PoisonError::into_inner).take();
        // SAFETY: `raw` is a live device.
        let code = unsafe { sys::rtcGetDeviceError(self.raw) };
        match logged {
            Some(msg) => Err(AccelError::Embree(format!("{during}: {msg}"))),
            None if code != sys::RTC_ERROR_NONE => Err(AccelError::Embree(format!("{during}: {}", error_name(code)))),
            None => Ok(()),
        }
    }

    /// The error to report when a constructor returned a null handle.
    fn failure(&self, during: &str) -> AccelError {
        self.check(during)
            .err()
            .unwrap_or_else(|| AccelError::Embree(format!("{during} returned no handle")))
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `raw` is live and owned by us. Unregistering first means that even if Embree keeps
        // the device alive a little longer, the callback never sees the freed `ErrorLog`.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
        }
    }
}

/// A geometry not yet attached to a scene.
#[derive(Debug)]
pub(super) struct Geometry {
    raw: sys::RTCGeometry,
}

impl Geometry {
    pub fn new(device: &Device, kind: sys::RTCGeometryType) -> Result<Self, AccelError> {
        // SAFETY: `device.raw` is a live device.
        let raw = unsafe { sys::rtcNewGeometry(device.raw, kind) };
        if raw.is_null() {
            return Err(device.failure("rtcNewGeometry"));
        }
        Ok(Self { raw })
    }

    /// Has Embree allocate slot 0 of buffer `kind` (with the tail padding its SIMD loads need, unlike
    /// a shared buffer) and fills it with `items`, each of `size_of::<T>()` bytes in `format`.
    pub fn set_new_buffer<T: Copy>(
        &mut self,
        device: &Device,
        kind: sys::RTCBufferType,
        format: sys::RTCFormat,
        items: &[T],
    ) -> Result<(), AccelError> {
        // SAFETY: `raw` is a live geometry; stride and count describe `items`.
        let ptr = unsafe { sys::rtcSetNewGeometryBuffer(self.raw, kind, 0, format, size_of::<T>(), items.len()) };
        if ptr.is_null() {
            return Err(device.failure("rtcSetNewGeometryBuffer"));
        }
        debug_assert!(ptr.align_offset(align_of::<T>()) == 0, "Embree buffers are 16-byte aligned");
        // SAFETY: Embree allocated `items.len()` items of `size_of::<T>()` bytes, 16-byte aligned (T is
        // f32/u32 triples, align 4). The memory belongs to this geometry, which `&mut self` borrows
        // exclusively; it is uninitialised, hence `MaybeUninit`.
        let dst = unsafe { std::slice::from_raw_parts_mut(ptr.cast::<MaybeUninit<T>>(), items.len()) };
        for (d, &s) in dst.iter_mut().zip(items) {
            d.write(s);
        }
        Ok(())
    }

    /// Makes an instance geometry place `scene` (`RTC_GEOMETRY_TYPE_INSTANCE`) by the affine map
    /// `columns` (`RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR`: the three axes, then the translation).
    pub fn set_instance(&mut self, scene: &CommittedScene, columns: &[f32; 12]) {
        // SAFETY: `raw` is a live instance geometry and `scene` a live, committed scene, which Embree
        // retains for as long as the instance refers to it; `columns` holds the 12 floats of the format,
        // which Embree copies before returning.
        unsafe {
            sys::rtcSetGeometryInstancedScene(self.raw, scene.raw());
            sys::rtcSetGeometryTransform(self.raw, 0, sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, columns.as_ptr().cast());
        }
    }

    pub fn commit(&mut self) {
        // SAFETY: `raw` is a live geometry whose buffers are set.
        unsafe { sys::rtcCommitGeometry(self.raw) };
    }
}

impl Drop for Geometry {
    fn drop(&mut self) {
        // SAFETY: releases the one reference we own.
        unsafe { sys::rtcReleaseGeometry(self.raw) };
    }
}

/// A scene being assembled.
#[derive(Debug)]
pub(super) struct Scene {
    raw: sys::RTCScene,
}

impl Scene {
    pub fn new(device: &Device) -> Result<Self, AccelError> {
        // SAFETY: `device.raw` is a live device.
        let raw = unsafe { sys::rtcNewScene(device.raw) };
        if raw.is_null() {
            return Err(device.failure("rtcNewScene"));
        }
        Ok(Self { raw })
    }

    /// Attaches a committed geometry and drops our reference to it (the scene keeps its own).
    /// Returns the geometry ID.
    pub fn attach(&mut self, geometry: Geometry) -> u32 {
        // SAFETY: both handles are live; the scene retains the geometry, and `geometry`'s `Drop`
        // releases our reference when it goes out of scope at the end of this function.
        unsafe { sys::rtcAttachGeometry(self.raw, geometry.raw) }
    }

    /// Attaches a committed geometry under the ID `id` (not yet used in this scene) and drops our
    /// reference to it.
    pub fn attach_by_id(&mut self, geometry: Geometry, id: u32) {
        // SAFETY: as in `attach`; Embree reports an ID already in use through the device's error log,
        // which the caller checks.
        unsafe { sys::rtcAttachGeometryByID(self.raw, geometry.raw, id) }
    }

    pub fn set_flags(&mut self, flags: sys::RTCSceneFlags) {
        // SAFETY: `raw` is a live, uncommitted scene.
        unsafe { sys::rtcSetSceneFlags(self.raw, flags) };
    }

    pub fn set_build_quality(&mut self, quality: sys::RTCBuildQuality) {
        // SAFETY: `raw` is a live, uncommitted scene.
        unsafe { sys::rtcSetSceneBuildQuality(self.raw, quality) };
    }

    /// Builds the BVH. The caller checks the device for errors afterwards.
    pub fn commit(self) -> CommittedScene {
        // SAFETY: `raw` is a live scene whose geometries are all committed.
        unsafe { sys::rtcCommitScene(self.raw) };
        CommittedScene(self)
    }
}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: releases the one reference we own (the scene then releases its geometries).
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// A scene after `rtcCommitScene`: the only state in which `rtcIntersect1` / `rtcOccluded1` may be
/// called on it, from any number of threads at once. It is never modified again.
#[derive(Debug)]
pub(super) struct CommittedScene(Scene);

impl CommittedScene {
    #[inline]
    pub fn raw(&self) -> sys::RTCScene {
        self.0.raw
    }
}
