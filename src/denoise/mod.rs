//! Denoising with Intel Open Image Denoise (OIDN): `caustica render --denoise` runs OIDN's `RT` filter on
//! the finished image, with the `albedo` and shading-normal AOVs (`scene::aov`) as its auxiliary images,
//! and writes the result beside the raw image (`<output>.denoised.exr`; the raw image is always written).
//!
//! OIDN is not linked: its shared library is loaded when a render asks for it ([`oidn`], the FFI, whose
//! `unsafe` lives in that one file), so the binary runs where OIDN is absent, and `--denoise` then fails
//! before rendering, saying what to install. Where the library is looked for, in order ([`Denoiser::load`]):
//! 1. `--oidn PATH` (a directory holding `libOpenImageDenoise.so.2`, or the file itself);
//! 2. the environment variable [`ENV_VAR`], the same;
//! 3. `build/oidn/lib` of the checkout the binary was built in (`target/<profile>/caustica` →
//!    `../../build/oidn/lib`), where `scripts/setup-oidn` unpacks OIDN from the PyPI wheel `pyoidn`;
//! 4. the system's library path (`libOpenImageDenoise.so.2`, e.g. a distribution's package).
//!
//! The inputs, as OIDN's documentation asks: the colour is HDR (`hdr = true`, linear radiance); the albedo
//! is the first hit's diffuse reflectance in [0, 1] (Mitsuba's `albedo` AOV: 0 on mirrors and glass) and
//! the normal the first hit's world-space shading normal, both filter-weighted means over the pixel's
//! samples like the image (`cleanAux` is left false: at low sample counts they carry some noise at edges).

mod oidn;

use std::path::{Path, PathBuf};

use crate::film::{Film, Image};
use crate::math::Vec3;
use crate::scene::aov::{AovKind, Aovs};

/// The environment variable naming OIDN's library or its directory.
pub const ENV_VAR: &str = "CAUSTICA_OIDN";

/// The library's file name (OIDN 2's soname).
pub const LIBRARY: &str = "libOpenImageDenoise.so.2";

/// Why denoising could not run.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    #[error(
        "Intel Open Image Denoise (OIDN 2) was not found ({tried}): run scripts/setup-oidn in the caustica checkout (it unpacks OIDN from the PyPI wheel pyoidn into build/oidn/lib), \
         install a package that provides {LIBRARY}, or point --oidn or {ENV_VAR} at the library or its directory"
    )]
    NotFound { tried: String },
    #[error("{path}: cannot load Intel Open Image Denoise ({reason}); run scripts/setup-oidn in the caustica checkout, or point --oidn or {ENV_VAR} at a copy of {LIBRARY}")]
    Load { path: PathBuf, reason: String },
    #[error("Intel Open Image Denoise failed ({stage}): {message}")]
    Oidn { stage: &'static str, message: String },
    #[error("denoising reads the {kind} AOV, which the render did not make")]
    MissingAov { kind: &'static str },
    #[error("denoising needs images of {pixels} pixels; got {got} values for {what}")]
    Size { pixels: usize, got: usize, what: &'static str },
}

/// OIDN, loaded ([`Denoiser::load`]).
pub struct Denoiser {
    lib: &'static oidn::Oidn,
    /// Where it was loaded from, for messages.
    pub path: PathBuf,
}

impl Denoiser {
    /// Loads OIDN from the first place of the module documentation's list that has it: `explicit`
    /// (`--oidn`), then [`ENV_VAR`], the checkout's `build/oidn/lib`, and the system's library path.
    pub fn load(explicit: Option<&Path>) -> Result<Self, DenoiseError> {
        let env = std::env::var_os(ENV_VAR).filter(|v| !v.is_empty()).map(PathBuf::from);
        // A place named by the user must work: it is not passed over for the next.
        if let Some(given) = explicit.map(Path::to_path_buf).or(env) {
            let file = if given.is_dir() { given.join(LIBRARY) } else { given };
            let lib = oidn::Oidn::load(&file).map_err(|reason| DenoiseError::Load { path: file.clone(), reason })?;
            return Ok(Denoiser { lib, path: file });
        }
        let mut tried = Vec::new();
        if let Some(dir) = checkout_lib_dir() {
            let file = dir.join(LIBRARY);
            if file.is_file() {
                let lib = oidn::Oidn::load(&file).map_err(|reason| DenoiseError::Load { path: file.clone(), reason })?;
                return Ok(Denoiser { lib, path: file });
            }
            tried.push(file.display().to_string());
        }
        match oidn::Oidn::load(Path::new(LIBRARY)) {
            Ok(lib) => Ok(Denoiser { lib, path: PathBuf::from(LIBRARY) }),
            Err(reason) => {
                tried.push(format!("{LIBRARY} on the system's library path: {reason}"));
                Err(DenoiseError::NotFound { tried: tried.join("; ") })
            }
        }
    }

    /// The denoised `color` (HDR), with the auxiliary `albedo` and `normal` (one value per pixel each, the
    /// image's order), on `threads` threads (0: OIDN's choice).
    pub fn denoise(&self, color: &Image, albedo: &[Vec3], normal: &[Vec3], threads: usize) -> Result<Image, DenoiseError> {
        let (w, h) = (color.width() as usize, color.height() as usize);
        let pixels = w * h;
        for (what, got) in [("the albedo", albedo.len()), ("the normal", normal.len())] {
            if got != pixels {
                return Err(DenoiseError::Size { pixels, got, what });
            }
        }
        let flat = |v: &mut dyn Iterator<Item = Vec3>| -> Vec<f32> { v.flat_map(|p| [p.x, p.y, p.z]).collect() };
        let color_in = flat(&mut color.pixels().iter().copied());
        let albedo_in = flat(&mut albedo.iter().copied());
        let normal_in = flat(&mut normal.iter().copied());
        let mut out = vec![0.0f32; 3 * pixels];
        self.lib.denoise_rt(w, h, &color_in, &albedo_in, &normal_in, &mut out, threads).map_err(|(stage, message)| DenoiseError::Oidn { stage, message })?;
        Ok(Image::from_fn(w as u32, h as u32, |x, y| {
            let i = 3 * (y as usize * w + x as usize);
            Vec3::new(out[i], out[i + 1], out[i + 2])
        }))
    }
}

impl Denoiser {
    /// The AOVs the denoiser reads: the albedo and the shading normal.
    pub const AOVS: [AovKind; 2] = [AovKind::Albedo, AovKind::ShNormal];

    /// [`Denoiser::denoise`] of `film`'s image, with its albedo and shading-normal AOV channels (`aovs`
    /// names the film's channels; they must include both, as [`Denoiser::AOVS`] lists).
    pub fn denoise_film(&self, film: &Film, aovs: &Aovs, threads: usize) -> Result<Image, DenoiseError> {
        let planes = film.aov_planes();
        let plane3 = |kind: AovKind| -> Result<Vec<Vec3>, DenoiseError> {
            let (_, at) = aovs.find(kind).ok_or(DenoiseError::MissingAov { kind: kind.name() })?;
            let [a, b, c] = [&planes[at], &planes[at + 1], &planes[at + 2]];
            Ok(a.iter().zip(b).zip(c).map(|((&x, &y), &z)| Vec3::new(x, y, z)).collect())
        };
        self.denoise(&film.image(), &plane3(AovKind::Albedo)?, &plane3(AovKind::ShNormal)?, threads)
    }
}

/// `build/oidn/lib` of the checkout whose `target/<profile>/` holds the running binary (or a test binary
/// in `target/<profile>/deps/`).
fn checkout_lib_dir() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let mut dir = exe.parent()?;
    if dir.file_name().is_some_and(|n| n == "deps") {
        dir = dir.parent()?;
    }
    let target = dir.parent()?;
    Some(target.parent()?.join("build/oidn/lib"))
}

/// The name of the denoised image beside `raw`: `out.exr` → `out.denoised.exr`.
#[must_use]
pub fn denoised_path(raw: &Path) -> PathBuf {
    let stem = raw.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = raw.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "exr".into());
    raw.with_file_name(format!("{stem}.denoised.{ext}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn denoised_image_goes_beside_the_raw_one() {
        assert_eq!(denoised_path(Path::new("out/cornell.exr")), PathBuf::from("out/cornell.denoised.exr"));
        assert_eq!(denoised_path(Path::new("a.b.exr")), PathBuf::from("a.b.denoised.exr"));
    }

    /// A named place that does not hold OIDN is an error naming it, not a silent fall-back.
    #[test]
    fn a_named_library_that_is_not_there_is_refused_by_name() {
        let e = Denoiser::load(Some(Path::new("/nonexistent/dir/libOpenImageDenoise.so.2"))).err().expect("no OIDN there");
        let text = e.to_string();
        assert!(text.contains("/nonexistent/dir/libOpenImageDenoise.so.2"), "{text}");
    }
}
