//! `caustica render SCENE.toml ...`: loads a scene, builds the chosen backend, renders, writes the
//! EXR (and PNG preview, stats JSON, error log) atomically.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context};
use serde::Serialize;

use crate::accel::{build_accel, embree_version, BackendKind};
use crate::film::{write_exr, write_png, Film, Rect, Tonemap};
use crate::cmd::photon_args::PhotonArgs;
use crate::render::part::{self, Part, PartInfo};
use crate::render::{render_share, RenderSettings, Share, TILE_SIZE};
use crate::report::error_log::{ErrorTracker, PassError};
use crate::scene::{Estimator, Scene};

/// Arguments of `caustica render`. Command-line values override the scene file.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output EXR (float32 RGB). Default: the scene's name with `.exr`, in the current directory.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Also write an sRGB PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview, in stops.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Tone mapping of the PNG preview.
    #[arg(long, value_enum, default_value_t = Tonemap::Clamp)]
    pub tonemap: Tonemap,
    /// Samples per pixel.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render whole passes until this many seconds are spent (ignores --spp).
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Samples per pixel of one pass (time-limited renders; default 4).
    #[arg(long)]
    pub pass_spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long)]
    pub seed: Option<u64>,
    #[arg(long, value_enum)]
    pub backend: Option<BackendKind>,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// Crop window x0,y0,x1,y1 in pixels (end exclusive).
    #[arg(long)]
    pub crop: Option<String>,
    /// Caustic estimator.
    #[arg(long, value_enum)]
    pub estimator: Option<Estimator>,
    #[command(flatten)]
    pub photon: PhotonArgs,
    /// Write statistics as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// A reference image (OpenEXR, the size of the rendered crop window): after every pass the render is
    /// compared with it (RMSE, relMSE, regions); the figures go to the progress line, `--error-log` and
    /// the stats JSON (key `error`).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// With --reference: write one CSV row per pass here (seconds, spp, photons, RMSE, relMSE, regions).
    #[arg(long, requires = "reference")]
    pub error_log: Option<PathBuf>,
    /// With --reference: a region to report separately, `name=x0,y0,x1,y1` (pixels or percentages like
    /// `62%`, exclusive ends). Repeatable.
    #[arg(long = "region", requires = "reference")]
    pub regions: Vec<String>,
    /// Render only part I (0-based) of N of the image (a share of its passes, or of its tiles when it has
    /// fewer passes than N) into a partial film at -o, for `caustica merge`. Needs a fixed sample count.
    #[arg(long, value_name = "I/N", value_parser = |s: &str| s.parse::<Part>())]
    pub part: Option<Part>,
    /// No progress bar.
    #[arg(long, short = 'q')]
    pub quiet: bool,
}


/// The statistics JSON of a render (`--stats`).
#[derive(Debug, Serialize)]
pub struct RenderStatsJson {
    pub scene: String,
    pub backend: &'static str,
    pub embree_version: Option<&'static str>,
    pub width: u32,
    pub height: u32,
    pub crop: [u32; 4],
    pub spp: u32,
    pub passes: u32,
    pub threads: usize,
    pub seed: u64,
    pub estimator: Estimator,
    pub seconds_total: f64,
    pub seconds_setup: f64,
    pub seconds_render: f64,
    pub seconds_photons: f64,
    pub seconds_kdtree: f64,
    pub rays_traced: u64,
    pub rays_per_second: f64,
    pub samples_per_second: f64,
    pub knn: u32,
    pub knn_queries: u64,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub photon_bytes: u64,
    pub photon_chains_capped: u64,
    pub nan_pixels: u64,
    pub inf_pixels: u64,
    pub partial: bool,
    /// Phases the scene did not need, each with the reason.
    pub skipped: std::collections::BTreeMap<String, String>,
    /// `a` of the progressive area schedule: pass p's density estimate uses (p+1)^(a−1) of its k-NN area.
    pub area_exponent: f64,
    /// With --reference: the error after the last pass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<ErrorJson>,
    /// With --part: which part, its share and the render's fingerprint.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub part: Option<PartJson>,
}

/// The `part` key of the stats JSON.
#[derive(Debug, Serialize)]
pub struct PartJson {
    pub index: u32,
    pub count: u32,
    pub share: &'static str,
    pub fingerprint: String,
    pub passes_rendered: u32,
}

/// The `error` key of the stats JSON: the reference and the last pass's figures.
#[derive(Debug, Serialize)]
pub struct ErrorJson {
    pub reference: String,
    #[serde(flatten)]
    pub last: PassError,
}

/// `--width` / `--height` over the scene's film size (either may be given alone).
pub fn set_resolution(scene: &mut Scene, width: Option<u32>, height: Option<u32>) -> anyhow::Result<()> {
    if width.is_some() || height.is_some() {
        let w = width.unwrap_or(scene.camera.width());
        let h = height.unwrap_or(scene.camera.height());
        if w == 0 || h == 0 {
            bail!("--width/--height must be positive");
        }
        scene.camera.set_resolution(w, h).map_err(|e| anyhow::anyhow!("--width/--height: {e}"))?;
    }
    Ok(())
}

fn parse_crop(s: &str) -> anyhow::Result<[u32; 4]> {
    let v: Vec<u32> = s.split(',').map(|x| x.trim().parse::<u32>()).collect::<Result<_, _>>().with_context(|| format!("--crop {s:?}: expected x0,y0,x1,y1"))?;
    if v.len() != 4 || v[0] >= v[2] || v[1] >= v[3] {
        bail!("--crop {s:?}: expected x0,y0,x1,y1 with x0 < x1 and y0 < y1");
    }
    Ok([v[0], v[1], v[2], v[3]])
}

/// Checks a user-given positive finite number.
fn positive(name: &str, v: f32) -> anyhow::Result<f32> {
    if !(v.is_finite() && v > 0.0) {
        bail!("{name} must be a positive finite number, got {v}");
    }
    Ok(v)
}

/// Checks the command-line values that need no scene, before anything slow happens: counts that must be
/// ≥ 1 (`--spp`, `--pass-spp`, `--knn`, `--threads`, `--photons`, `--caustic-photons`, `--width`,
/// `--height`) are rejected, not clamped; `--max-radius` must be positive and finite; and the directories
/// of `-o`, `--png` and `--stats` must exist, so that a long render is never lost to a typo in an output
/// path.
pub fn validate_args(args: &RenderArgs) -> anyhow::Result<()> {
    let counts: [(&str, Option<u64>); 5] = [
        ("--spp", args.spp.map(u64::from)),
        ("--pass-spp", args.pass_spp.map(u64::from)),
        ("--threads", args.threads.map(|t| t as u64)),
        ("--width", args.width.map(u64::from)),
        ("--height", args.height.map(u64::from)),
    ];
    for (flag, value) in counts {
        if value == Some(0) {
            bail!("{flag} must be at least 1, got 0");
        }
    }
    args.photon.validate()?;
    if args.part.is_some() {
        if args.reference.is_some() {
            bail!("--part renders a share of the image: compare the merged image instead of using --reference");
        }
        if args.time_limit.is_some() {
            bail!("--part: {}", part::PartError::TimeLimited);
        }
    }
    check_outputs(&[("-o/--output", args.output.as_deref()), ("--png", args.png.as_deref()), ("--stats", args.stats.as_deref())])
}

/// Checks that each output path names a file in an existing directory (before anything slow happens).
pub fn check_outputs(outputs: &[(&str, Option<&Path>)]) -> anyhow::Result<()> {
    for &(flag, path) in outputs {
        let Some(path) = path else { continue };
        if path.file_name().is_none() {
            bail!("{flag} {}: not a file name", path.display());
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            bail!("{flag} {}: directory {} does not exist", path.display(), dir.display());
        }
        if path.is_dir() {
            bail!("{flag} {}: is a directory", path.display());
        }
    }
    Ok(())
}

/// Runs `caustica render`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    validate_args(args)?;
    let mut scene = Scene::load(&args.scene)?;
    set_resolution(&mut scene, args.width, args.height)?;
    if let Some(c) = &args.crop {
        let [x0, y0, x1, y1] = parse_crop(c)?;
        if x1 > scene.camera.width() || y1 > scene.camera.height() {
            bail!("--crop {c}: outside the {}x{} film", scene.camera.width(), scene.camera.height());
        }
        scene.camera.set_crop(x0, y0, x1, y1).map_err(|e| anyhow::anyhow!("--crop {c}: {e}"))?;
    }
    let (x0, y0, x1, y1) = scene.camera.crop();
    let pixels = u64::from(x1 - x0) * u64::from(y1 - y0);
    let mut settings = RenderSettings::from_scene(&scene);
    if let Some(spp) = args.spp {
        settings.spp = spp;
    }
    settings.pass_spp = args.pass_spp.unwrap_or(if args.time_limit.is_some() { 4 } else { u32::MAX });
    settings.time_limit = match args.time_limit {
        Some(t) => Some(f64::from(positive("--time-limit", t as f32)?)),
        None => None,
    };
    if let Some(seed) = args.seed {
        settings.seed = seed;
    }
    if let Some(estimator) = args.estimator {
        settings.estimator = estimator;
    }
    args.photon.apply(&mut settings);
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let backend = args.backend.unwrap_or_else(BackendKind::default_available);
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args.scene.file_stem().map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
        match args.part {
            Some(p) => PathBuf::from(format!("{stem}.part-{}-of-{}.exr", p.index, p.count)),
            None => PathBuf::from(format!("{stem}.exr")),
        }
    });

    // The reference is read and checked before anything is rendered.
    let mut tracker = match &args.reference {
        Some(path) => {
            let t = ErrorTracker::load(path, &args.regions)?;
            t.check_size(x1 - x0, y1 - y0, path)?;
            Some(t)
        }
        None => None,
    };
    let mut log_error: Option<anyhow::Error> = None;

    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("creating the worker threads")?;
    let accel = pool.install(|| build_accel(backend, &scene.mesh.positions, &scene.mesh.indices))?;
    let seconds_setup = t_start.elapsed().as_secs_f64();

    let cancel = Arc::new(AtomicBool::new(false));
    {
        let c = cancel.clone();
        // A second Ctrl-C while the first is being honoured exits at once.
        let _ = ctrlc::set_handler(move || {
            if c.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let show_progress = !args.quiet && std::io::stdout().is_terminal();
    let progress = crate::cmd::progress::Progress::new(show_progress, &settings, pixels);
    let mut film = Film::with_crop(scene.camera.width(), scene.camera.height(), Rect::new(x0, y0, x1, y1))?;
    let share = match args.part {
        Some(p) => part::plan(&settings, film.tiles(TILE_SIZE).len(), p).map_err(|e| anyhow::anyhow!("--part {p}: {e}"))?,
        None => Share::All,
    };
    let fingerprint = args.part.map(|p| part::fingerprint(&scene, &settings, backend, p.count));
    let phases = pool.install(|| {
        render_share(
            &scene,
            accel.as_ref(),
            &settings,
            share,
            &mut film,
            &cancel,
            |film, info| {
                let row = match tracker.as_mut() {
                    Some(t) => match t.record(&film.image(), info) {
                        Ok(row) => Some(row.clone()),
                        Err(e) => {
                            log_error.get_or_insert(anyhow::Error::new(e).context("comparing with --reference"));
                            None
                        }
                    },
                    None => None,
                };
                progress.pass_done(info, row.as_ref());
                // The log is rewritten (atomically) after every pass, so it is complete whenever it is read.
                if let (Some(t), Some(log)) = (tracker.as_ref(), &args.error_log) {
                    if let Err(e) = crate::film::io::write_bytes_atomic(log, t.csv().as_bytes()) {
                        log_error.get_or_insert(anyhow::Error::new(e).context("--error-log"));
                    }
                }
            },
            &|samples| progress.tile_done(samples),
        )
    })?;
    if let Some(e) = log_error {
        return Err(e);
    }
    progress.finish();

    let image = film.image();
    let part_json = match (args.part, fingerprint) {
        (Some(p), Some(fingerprint)) => {
            if phases.partial {
                bail!("interrupted: part {p} was not written (an incomplete part cannot be merged); run it again");
            }
            let info = PartInfo {
                part: p,
                fingerprint: fingerprint.clone(),
                share: PartInfo::share_name(share).to_string(),
                passes: settings.pass_count().unwrap_or(0),
                tiles: film.tiles(TILE_SIZE).len() as u32,
                spp: settings.spp,
                scene: args.scene.display().to_string(),
                seconds_total: t_start.elapsed().as_secs_f64(),
                phases: phases.clone(),
            };
            part::write_part(&output, &film, &info)?;
            Some(PartJson { index: p.index, count: p.count, share: PartInfo::share_name(share), fingerprint, passes_rendered: phases.passes_rendered })
        }
        _ => {
            write_exr(&output, &image)?;
            None
        }
    };
    if let Some(png) = &args.png {
        write_png(png, &image, args.exposure, args.tonemap)?;
    }
    let seconds_total = t_start.elapsed().as_secs_f64();
    let samples = pixels as f64 * f64::from(phases.spp);
    let stats = RenderStatsJson {
        scene: args.scene.display().to_string(),
        backend: backend.name(),
        embree_version: if backend == BackendKind::Embree { embree_version() } else { None },
        width: scene.camera.width(),
        height: scene.camera.height(),
        crop: [x0, y0, x1, y1],
        spp: phases.spp,
        passes: phases.passes,
        threads,
        seed: settings.seed,
        estimator: settings.estimator,
        seconds_total,
        seconds_setup,
        seconds_render: phases.seconds_render,
        seconds_photons: phases.seconds_photons,
        seconds_kdtree: phases.seconds_kdtree,
        rays_traced: phases.rays_traced,
        rays_per_second: phases.rays_traced as f64 / (phases.seconds_render + phases.seconds_photons).max(1e-9),
        samples_per_second: samples / phases.seconds_render.max(1e-9),
        knn: settings.knn,
        knn_queries: phases.knn_queries,
        photons_emitted: phases.photons_emitted,
        photons_stored: phases.photons_stored,
        photon_bytes: phases.photon_bytes,
        photon_chains_capped: phases.photon_chains_capped,
        nan_pixels: film.nan_count(),
        inf_pixels: film.inf_count(),
        partial: phases.partial,
        skipped: phases.skipped.iter().map(|s| (s.phase.clone(), s.reason.clone())).collect(),
        area_exponent: crate::render::PROGRESSIVE_AREA_EXPONENT,
        error: match (&tracker, &args.reference) {
            (Some(t), Some(r)) => t.rows().last().map(|last| ErrorJson { reference: r.display().to_string(), last: last.clone() }),
            _ => None,
        },
        part: part_json,
    };
    if let Some(p) = &args.stats {
        write_json_atomic(p, &stats)?;
    }
    if !args.quiet {
        eprintln!(
            "{}: {}x{} {} spp ({}) in {:.2} s (setup {:.2} s, photons {:.2} s, render {:.2} s), {:.2} Mrays/s{}",
            output.display(),
            x1 - x0,
            y1 - y0,
            phases.spp,
            format!("{:?}", settings.estimator).to_lowercase(),
            seconds_total,
            seconds_setup,
            phases.seconds_photons + phases.seconds_kdtree,
            phases.seconds_render,
            stats.rays_per_second * 1e-6,
            if phases.partial { " [partial: interrupted]" } else { "" }
        );
        if let Some(last) = tracker.as_ref().and_then(|t| t.rows().last()) {
            eprintln!("error against the reference after {} passes: {}", last.pass, crate::report::error_log::progress_text(last));
        }
    }
    Ok(())
}

/// Writes JSON to `path` atomically (temporary file in the same directory, then rename).
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    crate::film::io::write_bytes_atomic(path, text.as_bytes())?;
    Ok(())
}
