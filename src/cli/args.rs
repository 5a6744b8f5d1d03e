//! Value parsers and argument groups shared by the subcommands. Every check of a render setting is
//! the library's ([`crate::scene::settings::check`]); this file only turns its reason into clap's error,
//! which names the flag and exits with code 2.

use std::str::FromStr;

use clap::builder::{PossibleValuesParser, TypedValueParser};

use crate::accel::BackendKind;
use crate::film::Tonemap;
use crate::report::converge::ErrorMetric;
use crate::scene::settings::check::{self, Invalid};
use crate::scene::Estimator;

/// A library enum that the command line offers by name.
pub trait Named: Copy + Send + Sync + 'static {
    const ALL: &'static [Self];
    fn name(self) -> &'static str;
}

impl Named for Estimator {
    const ALL: &'static [Self] = &Estimator::ALL;
    fn name(self) -> &'static str {
        Estimator::name(self)
    }
}

impl Named for BackendKind {
    const ALL: &'static [Self] = &BackendKind::ALL;
    fn name(self) -> &'static str {
        BackendKind::name(self)
    }
}

impl Named for Tonemap {
    const ALL: &'static [Self] = &Tonemap::ALL;
    fn name(self) -> &'static str {
        Tonemap::name(self)
    }
}

impl Named for ErrorMetric {
    const ALL: &'static [Self] = &ErrorMetric::ALL;
    fn name(self) -> &'static str {
        ErrorMetric::name(self)
    }
}

/// A parser that offers `T::ALL` by name (shown in `--help`) and returns the value.
#[must_use]
pub fn named<T: Named>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(T::ALL.iter().map(|v| v.name())).map(|s: String| T::ALL.iter().copied().find(|v| v.name() == s).unwrap_or(T::ALL[0]))
}

/// Parses with `FromStr`, then applies the library's check.
fn checked<T: FromStr + Copy>(s: &str, check: fn(T) -> Result<(), Invalid>) -> Result<T, String>
where
    T::Err: std::fmt::Display,
{
    let v: T = s.trim().parse().map_err(|e: T::Err| e.to_string())?;
    check(v).map_err(|e| e.0)?;
    Ok(v)
}

pub fn spp(s: &str) -> Result<u32, String> {
    checked(s, check::spp)
}

pub fn pass_spp(s: &str) -> Result<u32, String> {
    checked(s, check::pass_spp)
}

pub fn threads(s: &str) -> Result<usize, String> {
    checked(s, check::threads)
}

pub fn resolution(s: &str) -> Result<u32, String> {
    checked(s, check::resolution)
}

pub fn knn(s: &str) -> Result<u32, String> {
    checked(s, check::knn)
}

pub fn photons(s: &str) -> Result<u64, String> {
    checked(s, check::photons)
}

pub fn max_radius(s: &str) -> Result<f32, String> {
    checked(s, check::max_radius)
}

pub fn seconds(s: &str) -> Result<f64, String> {
    checked(s, check::positive)
}

/// Seconds, 0 allowed (`--checkpoint 0`: after every round).
pub fn seconds_or_zero(s: &str) -> Result<f64, String> {
    checked(s, check::non_negative)
}

pub fn exposure(s: &str) -> Result<f32, String> {
    checked(s, check::exposure)
}

/// Mitsuba's `-D name=value`: values of the `$name` parameters of a Mitsuba XML scene.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SceneParams {
    /// Sets parameter NAME of a Mitsuba XML scene (its `$NAME`, overriding `<default name="NAME">`), as
    /// Mitsuba's -D; repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = scene_param)]
    pub define: Vec<(String, String)>,
}

impl SceneParams {
    /// The parameters by name (a name given twice: the last value).
    #[must_use]
    pub fn map(&self) -> std::collections::BTreeMap<String, String> {
        self.define.iter().cloned().collect()
    }
}

/// Parses `NAME=VALUE` (NAME: letters, digits and `_`).
fn scene_param(s: &str) -> Result<(String, String), String> {
    let (name, value) = s.split_once('=').ok_or_else(|| format!("{s:?} is not NAME=VALUE"))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!("parameter name {name:?} must be letters, digits and _"));
    }
    Ok((name.to_string(), value.to_string()))
}

/// The options of how a render runs that `render` and `converge` share.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RunArgs {
    /// Worker threads [default: all cores].
    #[arg(short = 't', long, visible_alias = "nthreads", value_parser = threads)]
    pub threads: Option<usize>,
    /// Seed of the random streams [default: the scene's `integrator.seed`, else 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Intersection backend [default: embree when compiled in, else bvh].
    #[arg(long, value_parser = named::<BackendKind>())]
    pub backend: Option<BackendKind>,
    /// Film width in pixels; alone, the height follows the scene's aspect ratio [default: the scene's].
    #[arg(long, value_parser = resolution)]
    pub width: Option<u32>,
    /// Film height in pixels; alone, the width follows the scene's aspect ratio [default: the scene's].
    #[arg(long, value_parser = resolution)]
    pub height: Option<u32>,
    /// Refuse a render whose film, photon map and mesh need more than this many GB [default: the
    /// machine's physical memory, or the cgroup's or address-space limit where smaller].
    #[arg(long, value_name = "GB", value_parser = gigabytes)]
    pub memory_limit: Option<f64>,
}

/// Parses `--memory-limit GB`: a positive, finite number of gigabytes (10⁹ bytes).
fn gigabytes(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{s:?}: expected a positive number of gigabytes")),
    }
}

impl RunArgs {
    /// `--threads` or every core.
    #[must_use]
    pub fn threads(&self) -> usize {
        worker_threads(self.threads)
    }

    /// `--backend` or the default one.
    #[must_use]
    pub fn backend(&self) -> BackendKind {
        self.backend.unwrap_or_else(BackendKind::default_available)
    }

    /// Refuses, before anything is allocated, a render needing more memory than `--memory-limit` (or the
    /// machine's physical memory): [`crate::render::memory`].
    pub fn check_memory(&self, scene: &crate::scene::Scene, settings: &crate::render::RenderSettings) -> anyhow::Result<()> {
        use crate::render::memory::{MemoryEstimate, MemoryLimit};
        if let Some(limit) = MemoryLimit::process() {
            MemoryEstimate::of(scene, settings).check(limit).map_err(|e| anyhow::anyhow!("{}: {e}", scene.path.display()))?;
        }
        Ok(())
    }

    /// Makes `--memory-limit` (or the machine's bound) the process's limit, which the mesh readers check
    /// before they allocate ([`crate::render::memory::check_mesh`]): call before reading any scene.
    pub fn set_memory_limit(&self) {
        crate::render::memory::MemoryLimit::set_user(self.memory_limit.map(|gb| (gb * 1e9) as u64));
    }

    /// A rayon pool of [`RunArgs::threads`] workers.
    pub fn pool(&self) -> anyhow::Result<rayon::ThreadPool> {
        use anyhow::Context as _;
        rayon::ThreadPoolBuilder::new().num_threads(self.threads()).build().context("creating the worker threads")
    }

    /// `--width` / `--height` over the scene's film size. One of them alone keeps the scene's aspect
    /// ratio (the other side rounded to the nearest pixel, at least 1).
    pub fn set_resolution(&self, scene: &mut crate::scene::Scene) -> anyhow::Result<()> {
        let (sw, sh) = (u64::from(scene.camera.width()), u64::from(scene.camera.height()));
        // round(a·b/c) in integers, at least 1, saturating at u32::MAX.
        let scaled = |a: u32, b: u64, c: u64| u32::try_from(((u64::from(a) * b + c / 2) / c).max(1)).unwrap_or(u32::MAX);
        let (w, h) = match (self.width, self.height) {
            (None, None) => return Ok(()),
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, scaled(w, sh, sw)),
            (None, Some(h)) => (scaled(h, sw, sh), h),
        };
        scene.camera.set_resolution(w, h).map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
        Ok(())
    }
}

/// The options of the PNG images a subcommand writes.
#[derive(clap::Args, Debug, Clone)]
pub struct PngArgs {
    /// Exposure of the PNG images, in stops (a finite number; 0 = as rendered).
    #[arg(long, default_value_t = 0.0, value_parser = exposure)]
    pub exposure: f32,
    /// Tone mapping of the PNG images.
    #[arg(long, value_parser = named::<Tonemap>(), default_value = "clamp")]
    pub tonemap: Tonemap,
}

/// Checks that an output file can be written before anything slow happens: a file name whose directory
/// exists and that is not a directory itself, or an existing stream (a FIFO or character device such as
/// `/dev/stdout`, written through: `film::io::OutputTarget`). `-` (standard output) is refused here: only
/// the flags that take it check with [`check_output_or_stdout`].
pub fn check_output(flag: &str, path: &std::path::Path) -> anyhow::Result<()> {
    use crate::film::io::OutputTarget;
    use anyhow::bail;
    match OutputTarget::of(path) {
        Ok(OutputTarget::Stdout) => bail!("{flag} -: standard output takes only the JSON of --stats or --json; name a file (./- for a file named -)"),
        Ok(OutputTarget::Stream) => return Ok(()),
        Ok(OutputTarget::File(_)) => {}
        Err(e) => bail!("{flag} {}: {e}", path.display()),
    }
    if path.file_name().is_none() {
        bail!("{flag} {}: not a file name", path.display());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => std::path::Path::new("."),
    };
    if !dir.is_dir() {
        bail!("{flag} {}: directory {} does not exist", path.display(), dir.display());
    }
    if path.is_dir() {
        bail!("{flag} {}: is a directory", path.display());
    }
    check_writable(flag, path, dir)
}

/// [`check_output`] for a flag that takes `-` for standard output (`--stats`, `--json`).
pub fn check_output_or_stdout(flag: &str, path: &std::path::Path) -> anyhow::Result<()> {
    if path == std::path::Path::new("-") {
        return Ok(());
    }
    check_output(flag, path)
}

/// Refuses an output that is one of the command's inputs (the same file under any name: same device and
/// inode, or the same canonical path), which writing it would destroy.
pub fn check_not_input(flag: &str, output: &std::path::Path, inputs: &[&std::path::Path]) -> anyhow::Result<()> {
    let Ok(out) = std::fs::metadata(output) else { return Ok(()) };
    for input in inputs {
        let Ok(inp) = std::fs::metadata(input) else { continue };
        if same_file(&out, &inp) || std::fs::canonicalize(output).ok() == std::fs::canonicalize(input).ok() {
            anyhow::bail!("{flag} {}: is the input {}, which writing it would overwrite", output.display(), input.display());
        }
    }
    Ok(())
}

#[cfg(unix)]
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(_a: &std::fs::Metadata, _b: &std::fs::Metadata) -> bool {
    false
}

/// Whether `dir` accepts a new file: one is created and removed (a read-only directory must be found before
/// the render, not after it).
fn check_writable(flag: &str, path: &std::path::Path, dir: &std::path::Path) -> anyhow::Result<()> {
    let probe = dir.join(format!(".caustica-write-test-{}", std::process::id()));
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => anyhow::bail!("{flag} {}: cannot write to directory {}: {e}", path.display(), dir.display()),
    }
}

/// At most this many worker threads, whatever `--threads` asks (more only cost memory and start-up time:
/// `--threads 100000` spent 100 s creating threads).
pub const MAX_THREADS: usize = 1024;

/// `--threads` (default: all cores), capped at [`MAX_THREADS`] with a warning.
#[must_use]
pub fn worker_threads(requested: Option<usize>) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    match requested {
        Some(t) if t > MAX_THREADS => {
            super::log::warning!("--threads {t}: capped at {MAX_THREADS} (the limit; this machine has {cores} cores)");
            MAX_THREADS
        }
        Some(t) => t,
        None => cores,
    }
}

/// Checks that an image output's name ends in the extension of the format written there (`exr` or
/// `png`, any case): `-o a.png` would otherwise get EXR bytes under a PNG name.
pub fn check_image_extension(flag: &str, path: &std::path::Path, ext: &str, hint: &str) -> anyhow::Result<()> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
        anyhow::bail!("{flag} {}: writes {} and needs a name ending in .{ext}{hint}", path.display(), ext.to_uppercase());
    }
    Ok(())
}

/// The scene file's stem (`scenes/cornell.toml` → `cornell`), for default output names.
#[must_use]
pub fn scene_stem(scene: &std::path::Path) -> String {
    scene.file_stem().map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned())
}

/// `--aov`: the library's reading of an AOV list (`crate::scene::aov::Aovs::parse`).
pub fn aovs(s: &str) -> Result<crate::scene::aov::Aovs, String> {
    check::aovs(s).map_err(|e| e.0)
}
