//! The FFI to Intel Open Image Denoise's C API (OIDN 2, `OpenImageDenoise/oidn.h`), loaded at run time
//! with `libloading`: the few functions one `RT` filter on host memory needs. With `accel/embree`, one
//! of the two places with `unsafe` code; every `unsafe` block says why it is sound.
//!
//! The library and its dependencies are loaded once and never unloaded (OIDN's TBB worker threads outlive
//! any one call: unloading them under those threads would crash), so the handle is `'static`.

#![allow(unsafe_code)]

use std::ffi::{c_char, c_void, CStr, CString};
use std::path::Path;

use libloading::Library;

/// `OIDN_DEVICE_TYPE_CPU` (oidn.h: `OIDNDeviceType`).
const DEVICE_TYPE_CPU: i32 = 1;
/// `OIDN_FORMAT_FLOAT3` (oidn.h: `OIDNFormat`, `OIDN_FORMAT_FLOAT = 1` then FLOAT2, FLOAT3).
const FORMAT_FLOAT3: i32 = 3;
/// `OIDN_ERROR_NONE`.
const ERROR_NONE: i32 = 0;

type Handle = *mut c_void;

/// The functions of OIDN's C API used here, resolved from the loaded library.
pub(super) struct Oidn {
    new_device: unsafe extern "C" fn(i32) -> Handle,
    set_device_int: unsafe extern "C" fn(Handle, *const c_char, i32),
    commit_device: unsafe extern "C" fn(Handle),
    get_device_error: unsafe extern "C" fn(Handle, *mut *const c_char) -> i32,
    release_device: unsafe extern "C" fn(Handle),
    new_filter: unsafe extern "C" fn(Handle, *const c_char) -> Handle,
    set_shared_filter_image: unsafe extern "C" fn(Handle, *const c_char, *mut c_void, i32, usize, usize, usize, usize, usize),
    set_filter_bool: unsafe extern "C" fn(Handle, *const c_char, bool),
    commit_filter: unsafe extern "C" fn(Handle),
    execute_filter: unsafe extern "C" fn(Handle),
    release_filter: unsafe extern "C" fn(Handle),
}

/// Loads one library, kept loaded for the rest of the process.
fn open(path: &Path) -> Result<&'static Library, String> {
    // SAFETY: loading a shared library runs its initialisers. The libraries loaded here are OIDN and the
    // TBB and OIDN core libraries it links against (from the directory the user or scripts/setup-oidn
    // chose), whose initialisers only set up their own state.
    let lib = unsafe { Library::new(path) }.map_err(|e| e.to_string())?;
    Ok(Box::leak(Box::new(lib)))
}

/// The function `names[0]` (or an older name of it, `names[1..]`) of `lib`, as type `T`.
fn symbol<T: Copy>(lib: &'static Library, names: &[&str]) -> Result<T, String> {
    for name in names {
        // SAFETY: each call site names `T` as the C prototype of that function in OIDN 2's oidn.h (the
        // field types of `Oidn`, checked against the header); the library stays loaded for the process's
        // life, so the function pointer copied out of the symbol stays valid.
        if let Ok(f) = unsafe { lib.get::<T>(name.as_bytes()) } {
            return Ok(*f);
        }
    }
    Err(format!("it has no function {}", names[0]))
}

impl Oidn {
    /// Loads OIDN from `file` (a path, or a bare file name the system's loader looks for). A path's
    /// directory may hold the libraries it needs and does not find by itself (the PyPI wheel's layout:
    /// `libOpenImageDenoise.so.2` without a run path, beside `libOpenImageDenoise_core.so.*` and
    /// `libtbb.so.12`): those are loaded first, so the loader finds them loaded by their sonames.
    pub(super) fn load(file: &Path) -> Result<&'static Oidn, String> {
        if file.components().count() > 1 {
            if !file.is_file() {
                return Err("no such file".into());
            }
            let dir = file.parent().unwrap_or(Path::new("."));
            let mut deps: Vec<_> = std::fs::read_dir(dir)
                .map_err(|e| e.to_string())?
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n == "libtbb.so.12" || n.starts_with("libOpenImageDenoise_core.so")))
                .collect();
            // TBB first: the core needs nothing of it, the filter library needs both.
            deps.sort_by_key(|p| !p.to_string_lossy().contains("libtbb"));
            for dep in deps {
                open(&dep)?;
            }
        }
        let lib = open(file)?;
        let oidn = Oidn {
            new_device: symbol(lib, &["oidnNewDevice"])?,
            set_device_int: symbol(lib, &["oidnSetDeviceInt", "oidnSetDevice1i"])?,
            commit_device: symbol(lib, &["oidnCommitDevice"])?,
            get_device_error: symbol(lib, &["oidnGetDeviceError"])?,
            release_device: symbol(lib, &["oidnReleaseDevice"])?,
            new_filter: symbol(lib, &["oidnNewFilter"])?,
            set_shared_filter_image: symbol(lib, &["oidnSetSharedFilterImage"])?,
            set_filter_bool: symbol(lib, &["oidnSetFilterBool", "oidnSetFilter1b"])?,
            commit_filter: symbol(lib, &["oidnCommitFilter"])?,
            execute_filter: symbol(lib, &["oidnExecuteFilter"])?,
            release_filter: symbol(lib, &["oidnReleaseFilter"])?,
        };
        Ok(Box::leak(Box::new(oidn)))
    }

    /// The device's pending error, as `(stage, message)`; `Ok` when there is none. `device` may be null
    /// (then the error of a failed `oidnNewDevice`).
    fn check(&self, device: Handle, stage: &'static str) -> Result<(), (&'static str, String)> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: `device` is null or a live device of this library; `message` is a valid out pointer.
        let code = unsafe { (self.get_device_error)(device, &mut message) };
        if code == ERROR_NONE {
            return Ok(());
        }
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: OIDN returns a NUL-terminated string that stays valid until the next call on the
            // device from this thread; it is copied at once.
            unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
        };
        Err((stage, format!("error code {code}: {text}")))
    }

    /// Runs OIDN's `RT` filter on a `w × h` image: `color`, `albedo`, `normal` and `out` hold 3 floats per
    /// pixel, row-major (the caller checks the lengths). `threads` = 0 lets OIDN choose.
    pub(super) fn denoise_rt(&self, w: usize, h: usize, color: &[f32], albedo: &[f32], normal: &[f32], out: &mut [f32], threads: usize) -> Result<(), (&'static str, String)> {
        let n = 3 * w * h;
        if color.len() != n || albedo.len() != n || normal.len() != n || out.len() != n {
            return Err(("input", "image sizes differ".into()));
        }
        let name = |s: &str| CString::new(s).expect("no NUL in a parameter name");
        // SAFETY: a null return is handled (the error is then read with a null device).
        let device = unsafe { (self.new_device)(DEVICE_TYPE_CPU) };
        if device.is_null() {
            self.check(device, "creating the CPU device")?;
            return Err(("creating the CPU device", "no device".into()));
        }
        let result = (|| {
            if threads > 0 {
                // SAFETY: `device` is live and not yet committed; the name is a NUL-terminated string.
                unsafe { (self.set_device_int)(device, name("numThreads").as_ptr(), i32::try_from(threads).unwrap_or(i32::MAX)) };
            }
            // SAFETY: `device` is live.
            unsafe { (self.commit_device)(device) };
            self.check(device, "committing the device")?;
            // SAFETY: `device` is live and committed; the type is a NUL-terminated string.
            let filter = unsafe { (self.new_filter)(device, name("RT").as_ptr()) };
            self.check(device, "creating the RT filter")?;
            if filter.is_null() {
                return Err(("creating the RT filter", "no filter".into()));
            }
            let run = (|| {
                let images: [(&str, *const f32); 4] = [("color", color.as_ptr()), ("albedo", albedo.as_ptr()), ("normal", normal.as_ptr()), ("output", out.as_mut_ptr())];
                for (image, ptr) in images {
                    // SAFETY: `ptr` points to `3·w·h` f32 (checked above), tightly packed (strides 0:
                    // OIDN computes 12 bytes per pixel, 12·w per row), in host memory the CPU device
                    // reads; the slices outlive the filter's execution below. OIDN writes only to
                    // `output` (`out`, borrowed mutably); the inputs are only read, so passing their
                    // const pointers as the C API's `void*` mutates nothing.
                    unsafe { (self.set_shared_filter_image)(filter, name(image).as_ptr(), ptr as *mut c_void, FORMAT_FLOAT3, w, h, 0, 0, 0) };
                }
                // SAFETY: `filter` is live; the name is a NUL-terminated string.
                unsafe { (self.set_filter_bool)(filter, name("hdr").as_ptr(), true) };
                // SAFETY: `filter` is live and its images are set.
                unsafe { (self.commit_filter)(filter) };
                self.check(device, "committing the filter")?;
                // SAFETY: `filter` is committed; its images are valid for the call (above).
                unsafe { (self.execute_filter)(filter) };
                self.check(device, "executing the filter")
            })();
            // SAFETY: `filter` is live and released once.
            unsafe { (self.release_filter)(filter) };
            run
        })();
        // SAFETY: `device` is live and released once, after its filter.
        unsafe { (self.release_device)(device) };
        result
    }
}
