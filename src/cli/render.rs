//! `caustica render SCENE.toml ...`: loads a scene, builds the chosen backend, renders, writes the
//! EXR (and PNG preview, stats JSON, error log) atomically.
//!
//! Every output path is checked before anything is rendered, and the EXR is written first, before any
//! later output can fail: a finished render is never thrown away.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};
use serde::Serialize;

use super::args::{self, named, PngArgs, RunArgs};
use super::photon_args::PhotonArgs;
use super::log::{self, debug, info, note, warning, Level};
use super::progress::Progress;
use super::Outcome;
use crate::accel::{build_accel, embree_version, BackendKind};
use crate::film::io::{write_bytes_atomic, write_json_atomic};
use crate::denoise::{denoised_path, Denoiser};
use crate::display::{Display, Event as DisplayEvent};
use crate::film::io::write_exr_channels;
use crate::film::{write_exr, write_png, Film, Rect};
use crate::scene::aov::Aovs;
use crate::photon::PhotonBudget;
use crate::render::part::{self, Part, PartInfo};
use crate::render::{render_share, RenderPhaseStats, RenderSettings, Share, TILE_SIZE};
use crate::report::error_log::{progress_text, ErrorTracker, PassError};
use crate::scene::settings::defaults;
use crate::scene::{Estimator, LoadOptions, NoteKind, Scene};

/// Arguments of `caustica render`. Command-line values override the scene file.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// The scene file(s): TOML, or Mitsuba 3 XML (.xml). With several, each is rendered in turn to `<scene name>.exr` in the
    /// current directory (then -o, --png, --stats, --crop, --reference and --error-log are refused).
    #[arg(required = true, num_args = 1.., value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    #[command(flatten)]
    pub params: args::SceneParams,
    /// Output EXR (float32 RGB). Default: the scene's name with `.exr`, in the current directory.
    #[arg(short = 'o', long = "output", visible_alias = "outfile")]
    pub output: Option<PathBuf>,
    /// Also write an sRGB PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    #[command(flatten)]
    pub png_args: PngArgs,
    /// Samples per pixel [default: the scene's `integrator.samples_per_pixel`, else 16].
    #[arg(long, value_parser = args::spp)]
    pub spp: Option<u32>,
    /// Render passes until this many seconds are spent, the last pass cut at the limit (ignores --spp).
    #[arg(long, value_parser = args::seconds)]
    pub time_limit: Option<f64>,
    /// Samples per pixel of one pass (time-limited renders) [default: 4].
    #[arg(long, value_parser = args::pass_spp)]
    pub pass_spp: Option<u32>,
    /// A pass traces one sample per pixel over the whole frame, then rounds of about this many seconds;
    /// after each round the image is whole at the samples per pixel it says (Ctrl-C, SIGTERM and
    /// --checkpoint keep it) [default: 10].
    #[arg(long, value_parser = args::seconds, value_name = "SECONDS")]
    pub round_seconds: Option<f64>,
    /// Rewrite the image (-o, and --png and --stats when given; atomically) after the first round that ends
    /// this many seconds after the last write (0: after every round), with the stats of what it holds
    /// (`partial: true` until the render ends).
    #[arg(long, value_parser = args::seconds_or_zero, value_name = "SECONDS")]
    pub checkpoint: Option<f64>,
    /// pbrt-v4's flag: rewrite the image after every round, as `--checkpoint 0`.
    #[arg(long, conflicts_with = "checkpoint")]
    pub write_partial_images: bool,
    #[command(flatten)]
    pub run: RunArgs,
    /// Crop window x0,y0,x1,y1 in pixels (end exclusive).
    #[arg(long, value_parser = crop)]
    pub crop: Option<Rect>,
    /// Caustic estimator [default: the scene's `integrator.caustics.estimator`, else pt].
    #[arg(long, value_parser = named::<Estimator>())]
    pub estimator: Option<Estimator>,
    #[command(flatten)]
    pub photon: PhotonArgs,
    /// Write statistics as JSON here (`-`: standard output).
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
    /// AOVs written as extra channels of the EXR, first-hit values filtered like the image: types
    /// (albedo, normal, depth, position, uv, geo_normal, sh_normal, prim_index, shape_index,
    /// material_index) or Mitsuba's `name:type` pairs (`dd.y:depth,nn:sh_normal`: channels `dd.y.T`,
    /// `nn.X`…) [default: the scene's `integrator.aovs`, Mitsuba's `aov` integrator].
    #[arg(long, value_name = "LIST", value_parser = args::aovs)]
    pub aov: Option<crate::scene::aov::Aovs>,
    /// Also write the image denoised by Intel Open Image Denoise to `<output>.denoised.exr`, with the albedo
    /// and normal AOVs (added to --aov when missing); the raw image is written as always. Needs OIDN 2:
    /// run scripts/setup-oidn, or see --oidn.
    #[arg(long)]
    pub denoise: bool,
    /// Open Image Denoise's library (`libOpenImageDenoise.so.2`) or its directory, for --denoise
    /// [default: $CAUSTICA_OIDN, else build/oidn/lib of the checkout (scripts/setup-oidn), else the system's].
    #[arg(long, value_name = "PATH", requires = "denoise")]
    pub oidn: Option<PathBuf>,
    /// Render only part I (0-based) of N of the image (a share of its passes, or of its tiles when it has
    /// fewer passes than N) into a partial film at -o, for `caustica merge`. Needs a fixed sample count.
    #[arg(long, value_name = "I/N", value_parser = |s: &str| s.parse::<Part>())]
    pub part: Option<Part>,
    /// Show the image in the tev viewer while it renders, after every round (pbrt-v4's flag; tev listens on
    /// 127.0.0.1:14158). A viewer that is absent or goes away is warned about once and never stops the
    /// render; each later round tries to connect again.
    #[arg(long, value_name = "HOST:PORT", value_parser = display_address)]
    pub display_server: Option<String>,
    /// Without a terminal (a CI log, a batch job), a progress line on stderr every SECONDS (at log level
    /// info and above); 0: none.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0, value_parser = non_negative_seconds)]
    pub log_every: f64,
}

/// `--display-server`: the library's check of `HOST:PORT`.
fn display_address(s: &str) -> Result<String, String> {
    crate::display::check_address(s).map(|()| s.to_string())
}

/// A finite number of seconds ≥ 0.
fn non_negative_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("{s:?} is not a number of seconds ≥ 0")),
    }
}

/// The statistics JSON of a render (`--stats`; the schema is documented in the README).
#[derive(Debug, Serialize)]
pub struct RenderStatsJson {
    /// `caustica <version> (embree <version>)`.
    pub caustica_version: &'static str,
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
    pub max_radius: f32,
    /// What the photon pass aims for: `emitted` (N photons emitted) or `stored` (emit until M caustic
    /// photons are stored), and its count (the same for every pass).
    pub photon_budget: &'static str,
    pub photon_target: u64,
    pub knn_queries: u64,
    /// k-NN searches for ΔA alone (T2 at vertices that skipped their density estimate, method.md §3.1).
    pub knn_area_queries: u64,
    /// The smallest and largest q₁ (method.md §4) that reached the MIS function; null unless `mis`.
    pub mis_q1_range: Option<[f32; 2]>,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub photon_bytes: u64,
    pub photon_chains_capped: u64,
    /// Samples with a NaN channel, and with an infinite one (no NaN): each was counted as a sample of its
    /// pixel with the value 0 (so the pixel's mean is biased low by its share), and a warning was printed.
    pub nan_samples: u64,
    pub inf_samples: u64,
    /// Interrupted by a signal; `true` also in a checkpoint's stats (`--checkpoint`: the render is not done).
    pub partial: bool,
    /// Rounds rendered: after each the image is the whole frame at its samples per pixel.
    pub rounds: u32,
    /// Phases the scene did not need: `{phase: reason}`.
    pub skipped: std::collections::BTreeMap<String, String>,
    /// `a` of the progressive area schedule: pass p's density estimate uses (p+1)^(a−1) of its k-NN area.
    pub area_exponent: f64,
    /// With --reference: the error after the last pass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<ErrorJson>,
    /// With --part: which part, its share and the render's fingerprint.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub part: Option<PartJson>,
    /// The AOV channels written beside R, G, B (`--aov`, `integrator.aovs`); absent without.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub aov_channels: Vec<String>,
    /// With --denoise: the denoised image and the seconds OIDN took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoised: Option<DenoisedJson>,
}

/// The `denoised` key of the stats JSON.
#[derive(Debug, Serialize)]
pub struct DenoisedJson {
    pub path: String,
    pub seconds: f64,
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

/// Parses `--crop x0,y0,x1,y1` (a non-empty window; checked against the film once the scene is read).
fn crop(s: &str) -> Result<Rect, String> {
    let v: Vec<u32> = s.split(',').map(|x| x.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| format!("{s:?}: expected x0,y0,x1,y1"))?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Rect::new(x0, y0, x1, y1)),
        _ => Err(format!("{s:?}: expected x0,y0,x1,y1 with x0 < x1 and y0 < y1")),
    }
}

/// Runs `caustica render`.
pub fn run(args: &RenderArgs) -> anyhow::Result<Outcome> {
    check_scenes(args)?;
    check_outputs(args)?;
    args.run.set_memory_limit();
    let cancel = cancel_on_signals();
    for path in &args.scenes {
        if let interrupted @ Outcome::Interrupted { .. } = render_one(args, path, &cancel)? {
            return Ok(interrupted);
        }
    }
    Ok(Outcome::Done)
}

/// With several scenes: no option that names one scene's file or window, and distinct output names.
fn check_scenes(args: &RenderArgs) -> anyhow::Result<()> {
    if args.scenes.len() < 2 {
        return Ok(());
    }
    let single = [
        ("-o/--output", args.output.is_some()),
        ("--png", args.png.is_some()),
        ("--stats", args.stats.is_some()),
        ("--crop", args.crop.is_some()),
        ("--reference", args.reference.is_some()),
        ("--part", args.part.is_some()),
    ];
    if let Some((flag, _)) = single.iter().find(|(_, given)| *given) {
        bail!("{flag} applies to one scene; with several scenes each is written to <scene name>.exr in the current directory");
    }
    let mut stems: Vec<String> = Vec::new();
    for path in &args.scenes {
        let stem = args::scene_stem(path);
        if stems.contains(&stem) {
            bail!("{}: another scene is also named {stem:?}, and both would be written to {stem}.exr", path.display());
        }
        stems.push(stem);
    }
    Ok(())
}

/// Renders one scene and writes its outputs.
fn render_one(args: &RenderArgs, scene_path: &Path, cancel: &AtomicBool) -> anyhow::Result<Outcome> {
    let t_start = Instant::now();
    let scene = load_scene(args, scene_path)?;
    print_notes(&scene);
    let settings = settings(args, &scene)?;
    if args.part.is_some() && !settings.aovs.is_empty() {
        bail!("--part: AOV channels (--aov, --denoise, or the scene's integrator.aovs / Mitsuba's aov integrator) are not kept in partial films; render the AOVs in one process");
    }
    // OIDN is loaded before anything is rendered: a missing library is said at once, not after the render.
    let denoiser = if args.denoise { Some(Denoiser::load(args.oidn.as_deref())?) } else { None };
    args.run.check_memory(&scene, &settings)?;
    let tracker = load_reference(args, &scene)?;
    let backend = args.run.backend();
    let threads = args.run.threads();
    let pool = args.run.pool()?;
    let accel = pool.install(|| build_accel(backend, &scene.geometry()))?;
    if log::enabled(Level::Info) {
        pool.install(|| warn_long_photon_pass(&scene, accel.as_ref(), &settings));
    }
    let seconds_setup = t_start.elapsed().as_secs_f64();

    let mut pass_log = PassLog { tracker, error_log: args.error_log.as_deref(), failure: None };
    // (No progress line where the stats JSON goes to standard output.)
    let stats_to_stdout = args.stats.as_deref().is_some_and(is_stdout);
    let terminal = std::io::stdout().is_terminal();
    let info = log::enabled(Level::Info);
    let show = info && !stats_to_stdout && terminal;
    let log_every = (info && !terminal && args.log_every > 0.0).then(|| Duration::from_secs_f64(args.log_every));
    let progress = Progress::new(show, log_every, &settings, crop_window(&scene).area());
    let mut film = settings.film(&scene.camera)?;
    let share = match args.part {
        Some(p) => part::plan(&settings, film.tiles(TILE_SIZE).len(), p).map_err(|e| anyhow::anyhow!("--part {p}: {e}"))?,
        None => Share::All,
    };
    let output = output_path(args, scene_path);
    debug!("{}", describe_settings(&scene, &settings, backend, threads));
    let display = match &args.display_server {
        Some(address) => Some(start_display(address, &output)?),
        None => None,
    };
    let mut checkpoint = args.checkpoint.or(args.write_partial_images.then_some(0.0)).map(|every| Checkpoint { every, last: Instant::now(), warned: false });
    let phases = pool.install(|| {
        render_share(
            &scene,
            accel.as_ref(),
            &settings,
            share,
            &mut film,
            cancel,
            |film, info| {
                debug!("round {}: pass {}{}, {} spp, {:.2} s", info.round, info.pass, if info.pass_done { " done" } else { "" }, info.spp, info.seconds);
                progress.pass_done(info, pass_log.record(film, info).as_ref());
                if let Some(d) = &display {
                    d.show(film.image());
                }
                if let Some(c) = checkpoint.as_mut().filter(|c| c.last.elapsed().as_secs_f64() >= c.every) {
                    let timing = Timing { seconds_total: t_start.elapsed().as_secs_f64(), seconds_setup };
                    let phases = RenderPhaseStats { partial: true, ..info.phases.clone() };
                    let stats = stats_json(args, scene_path, &scene, &settings, &phases, film, &pass_log, backend, threads, timing);
                    c.write(args, &output, film, &settings.aovs, &stats);
                }
            },
            &|samples| {
                progress.tile_done(samples);
            },
        )
    })?;
    progress.finish();

    // The finished image is written first: no later failure may lose it.
    let image = film.image();
    let part_json = match args.part {
        Some(p) => Some(write_part(scene_path, &scene, &settings, &phases, &film, share, p, backend, &output, t_start)?),
        None => {
            write_image(&output, &image, &film, &settings.aovs)?;
            None
        }
    };
    // The viewer has the last round's image (sent after the written one: a lost viewer delays nothing).
    if let Some(d) = display {
        d.finish();
    }
    if let Some(e) = pass_log.failure.take() {
        return Err(e.context(format!("the image was written to {}", output.display())));
    }
    // A later output that fails does not take the first with it: the error says what was written.
    let written = |list: &[&Path]| list.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ");
    let denoised = match &denoiser {
        Some(d) => {
            let t = Instant::now();
            let path = denoised_path(&output);
            let image = pool.install(|| d.denoise_film(&film, &settings.aovs, threads)).with_context(|| format!("--denoise (written: {})", written(&[&output])))?;
            write_exr(&path, &image).with_context(|| format!("--denoise (written: {})", written(&[&output])))?;
            Some(DenoisedJson { path: path.display().to_string(), seconds: t.elapsed().as_secs_f64() })
        }
        None => None,
    };
    if let Some(png) = &args.png {
        write_png(png, &image, args.png_args.exposure, args.png_args.tonemap)
            .with_context(|| format!("--png {} (written: {})", png.display(), written(&[&output])))?;
    }
    warn_non_finite(&film, crop_window(&scene).area() * u64::from(phases.spp));
    let timing = Timing { seconds_total: t_start.elapsed().as_secs_f64(), seconds_setup };
    let mut stats = stats_json(args, scene_path, &scene, &settings, &phases, &film, &pass_log, backend, threads, timing);
    stats.part = part_json;
    stats.denoised = denoised;
    if let Some(p) = &args.stats {
        let mut done: Vec<&Path> = vec![&output];
        done.extend(args.png.as_deref());
        write_json_atomic(p, &stats).with_context(|| format!("--stats {} (written: {})", p.display(), written(&done)))?;
    }
    print_summary(&output, &scene, &settings, &phases, &stats, &pass_log);
    Ok(outcome(phases.partial))
}

/// Starts sending the image to the display server at `address` (`--display-server`), shown in the viewer
/// under the output's name; what happens to the connection is logged (`crate::display` module docs).
fn start_display(address: &str, output: &Path) -> anyhow::Result<Display> {
    let addr = address.to_string();
    Display::start(address, &output.display().to_string(), move |event| match event {
        DisplayEvent::Connected { again: false } => debug!("display server {addr}: connected"),
        DisplayEvent::Connected { again: true } => note!("display server {addr}: connected"),
        DisplayEvent::Failed { error, first: true } => {
            warning!("--display-server {addr}: {error}; the render goes on without the viewer (each later round tries again)");
        }
        DisplayEvent::Failed { error, first: false } => debug!("display server {addr}: {error}"),
        DisplayEvent::Sent { bytes, seconds } => debug!("display server {addr}: sent {:.1} kB in {:.1} ms", bytes as f64 / 1e3, seconds * 1e3),
    })
    .context("--display-server: starting its thread")
}

/// The settings a render runs with, for `--log-level debug`.
fn describe_settings(scene: &Scene, settings: &RenderSettings, backend: BackendKind, threads: usize) -> String {
    let crop = crop_window(scene);
    let spp = match settings.time_limit {
        Some(t) => format!("passes of {} spp for {t} s", settings.effective_pass_spp()),
        None => format!("{} spp in {} pass(es)", settings.spp, settings.pass_count().unwrap_or(1)),
    };
    format!(
        "{}x{} film, crop {crop}; {spp}, rounds of {} s; estimator {}, {}, knn {}, max radius {}; seed {}; {} threads, backend {}",
        scene.camera.width(),
        scene.camera.height(),
        settings.round_seconds,
        settings.estimator.name(),
        describe_photons(settings.photons),
        settings.knn,
        settings.max_radius,
        settings.seed,
        threads,
        backend.name(),
    )
}

/// Writes the image and its AOV channels (`aovs`, the film's) to `path`, atomically.
fn write_image(path: &Path, image: &crate::film::Image, film: &Film, aovs: &Aovs) -> Result<(), crate::film::ImageError> {
    let extra: Vec<(String, Vec<f32>)> = aovs.channel_names().zip(film.aov_planes()).collect();
    write_exr_channels(path, image, &extra)
}

/// Photons traced to time a large photon pass before it starts ([`warn_long_photon_pass`]).
const PHOTON_PROBE: u64 = 100_000;
/// A photon pass longer than this many seconds is announced.
const LONG_PHOTON_PASS: f64 = 120.0;

/// With a photon budget of more than ten times [`PHOTON_PROBE`], times a pass of `PHOTON_PROBE` emitted
/// photons (the render's first pass's own photons: its first `PHOTON_PROBE`) and, when the budget's pass
/// would take more than [`LONG_PHOTON_PASS`] at that rate, says how long on stderr before the render
/// starts (`--photons 1e8` takes minutes per pass without a word otherwise). A `stored` budget is scaled by
/// the emitted photons the probe needed per stored one. The probe costs at most a tenth of the pass.
fn warn_long_photon_pass(scene: &Scene, accel: &dyn crate::accel::Accel, settings: &RenderSettings) {
    let (PhotonBudget::Emitted(n) | PhotonBudget::Stored(n)) = settings.photons;
    if n <= 10 * PHOTON_PROBE || crate::render::photon_pass_needed(scene, settings.estimator).is_err() {
        return;
    }
    let t = Instant::now();
    let Ok((_, probe)) = crate::photon::trace_photons(scene, accel, PhotonBudget::Emitted(PHOTON_PROBE), settings.seed, 0, &|| false) else { return };
    let per_photon = t.elapsed().as_secs_f64() / PHOTON_PROBE as f64;
    let emitted = match settings.photons {
        PhotonBudget::Emitted(n) => n as f64,
        PhotonBudget::Stored(m) if probe.stored > 0 => m as f64 * PHOTON_PROBE as f64 / probe.stored as f64,
        PhotonBudget::Stored(m) => {
            note!("no caustic photon among the first {PHOTON_PROBE} emitted: the photon pass may emit many times its target of {m} stored");
            return;
        }
    };
    let seconds = emitted * per_photon;
    if seconds > LONG_PHOTON_PASS {
        let passes = settings.pass_count().map_or(String::new(), |p| if p > 1 { format!(", {p} passes: about {:.0} min in all", seconds * f64::from(p) / 60.0) } else { String::new() });
        note!(
            "the photon pass of {} will take about {:.0} min at the rate of its first {PHOTON_PROBE} photons ({:.1} µs each){passes}",
            describe_photons(settings.photons),
            seconds / 60.0,
            per_photon * 1e6,
        );
    }
}

/// `1e+08 photons emitted`, `5000000 caustic photons stored`.
fn describe_photons(budget: PhotonBudget) -> String {
    match budget {
        PhotonBudget::Emitted(n) => format!("{n} photons emitted"),
        PhotonBudget::Stored(m) => format!("{m} caustic photons stored"),
    }
}

/// The scene's notes (what was read but not used as written) on stderr: those that change what is rendered
/// (an integrator read as or replaced by the path tracer) in full, the ignored properties counted.
fn print_notes(scene: &Scene) {
    let (ignored, other): (Vec<_>, Vec<_>) = scene.notes.iter().partition(|n| n.kind == NoteKind::Ignored);
    for n in other {
        note!("{n}");
    }
    if !ignored.is_empty() {
        note!("{} properties that change no image were ignored (`caustica info` lists them)", ignored.len());
    }
}

/// Says how many samples were NaN or infinite and what was done with them (`film` module docs).
fn warn_non_finite(film: &Film, samples: u64) {
    if film.nan_count() + film.inf_count() > 0 {
        warning!(
            "{} NaN and {} infinite samples (of {}) were counted as zero-valued samples of their pixels, \
             whose means are biased low by that share (stats keys nan_samples, inf_samples)",
            film.nan_count(),
            film.inf_count(),
            samples,
        );
    }
}

/// Checks that every output can be written (directories exist, names are files), and that `--part`
/// goes with a fixed sample count and no reference, before rendering.
fn check_outputs(args: &RenderArgs) -> anyhow::Result<()> {
    if args.part.is_some() {
        if args.reference.is_some() {
            bail!("--part renders a share of the image: compare the merged image instead of using --reference");
        }
        if args.time_limit.is_some() {
            bail!("--part: {}", part::PartError::TimeLimited);
        }
        if args.checkpoint.is_some() || args.write_partial_images {
            bail!("--part writes a partial film for `caustica merge` once the part is done: --checkpoint and --write-partial-images do not apply");
        }
    }
    let outputs = [
        ("-o/--output", args.output.as_deref()),
        ("--png", args.png.as_deref()),
        ("--stats", args.stats.as_deref()),
        ("--error-log", args.error_log.as_deref()),
    ];
    let inputs: Vec<&Path> = args.scenes.iter().map(PathBuf::as_path).chain(args.reference.as_deref()).collect();
    for (flag, path) in outputs {
        if let Some(path) = path {
            if flag == "--stats" {
                args::check_output_or_stdout(flag, path)?;
            } else {
                args::check_output(flag, path)?;
            }
            args::check_not_input(flag, path, &inputs)?;
        }
    }
    if let Some(o) = &args.output {
        args::check_image_extension("-o/--output", o, "exr", " (for a PNG preview, add --png FILE.png)")?;
        if args.denoise {
            let d = denoised_path(o);
            args::check_output("--denoise", &d)?;
            args::check_not_input("--denoise", &d, &inputs)?;
        }
    }
    if args.part.is_some() && (args.aov.is_some() || args.denoise) {
        bail!("--part: AOV channels (--aov, --denoise) are not kept in partial films; render the AOVs in one process");
    }
    if let Some(p) = &args.png {
        args::check_image_extension("--png", p, "png", "")?;
    }
    Ok(())
}

/// The scene with `--width`/`--height` and `--crop` applied.
fn load_scene(args: &RenderArgs, path: &Path) -> anyhow::Result<Scene> {
    let options = LoadOptions { params: args.params.map(), replace_integrator: args.estimator.is_some() };
    let mut scene = Scene::load_with(path, &options)?;
    args.run.set_resolution(&mut scene)?;
    if let Some(c) = args.crop {
        let (w, h) = (scene.camera.width(), scene.camera.height());
        if c.x1 > w || c.y1 > h {
            bail!("--crop {c}: outside the {w}x{h} film");
        }
        scene.camera.set_crop(c).map_err(|e| anyhow::anyhow!("--crop: {e}"))?;
    }
    Ok(scene)
}

/// The scene's crop window.
fn crop_window(scene: &Scene) -> Rect {
    scene.camera.crop()
}

/// The scene file's settings with the command line's over them.
fn settings(args: &RenderArgs, scene: &Scene) -> anyhow::Result<RenderSettings> {
    let mut settings = RenderSettings::from_scene(scene);
    if let Some(spp) = args.spp {
        settings.spp = spp;
    }
    settings.time_limit = args.time_limit;
    settings.pass_spp = args.pass_spp.unwrap_or(if args.time_limit.is_some() { defaults::PASS_SPP_TIME_LIMITED } else { u32::MAX });
    if let Some(seed) = args.run.seed {
        settings.seed = seed;
    }
    if let Some(t) = args.round_seconds {
        settings.round_seconds = t;
    }
    if let Some(estimator) = args.estimator {
        settings.estimator = estimator;
    }
    args.photon.apply(&mut settings, scene);
    if let Some(aovs) = &args.aov {
        settings.aovs = aovs.clone();
    }
    if args.denoise {
        settings.aovs = std::mem::take(&mut settings.aovs).with_kinds(&Denoiser::AOVS).map_err(|e| anyhow::anyhow!("--denoise adds the AOVs albedo and sh_normal: {e}"))?;
    }
    Ok(settings)
}

/// `--reference` read and checked against the crop window's size, before anything is rendered.
fn load_reference(args: &RenderArgs, scene: &Scene) -> anyhow::Result<Option<ErrorTracker>> {
    let Some(path) = &args.reference else { return Ok(None) };
    let tracker = ErrorTracker::load(path, &args.regions)?;
    let crop = crop_window(scene);
    tracker.check_size(crop.width(), crop.height(), path)?;
    Ok(Some(tracker))
}

/// `-o`, or the scene's name with `.exr` in the current directory.
/// With `--part I/N`: `<scene name>.part-I-of-N.exr`.
fn output_path(args: &RenderArgs, scene_path: &Path) -> PathBuf {
    let stem = args::scene_stem(scene_path);
    args.output.clone().unwrap_or_else(|| match args.part {
        Some(p) => PathBuf::from(format!("{stem}.part-{}-of-{}.exr", p.index, p.count)),
        None => PathBuf::from(format!("{stem}.exr")),
    })
}

/// Writes the partial film of `--part`. An interrupted part is written too, with the passes (and tiles of
/// its last pass) it finished, marked partial: `merge --allow-missing` takes it (`render::part`).
#[allow(clippy::too_many_arguments)]
fn write_part(
    scene_path: &Path,
    scene: &Scene,
    settings: &RenderSettings,
    phases: &RenderPhaseStats,
    film: &Film,
    share: Share,
    p: Part,
    backend: BackendKind,
    output: &Path,
    t_start: Instant,
) -> anyhow::Result<PartJson> {
    let fingerprint = part::fingerprint(scene, settings, backend, p.count);
    let info = PartInfo {
        part: p,
        fingerprint: fingerprint.clone(),
        share: PartInfo::share_name(share).to_string(),
        passes: settings.pass_count().unwrap_or(0),
        tiles: film.tiles(TILE_SIZE).len() as u32,
        spp: settings.spp,
        scene: scene_path.display().to_string(),
        seconds_total: t_start.elapsed().as_secs_f64(),
        phases: phases.clone(),
    };
    part::write_part(output, film, &info)?;
    if info.is_partial() {
        warning!(
            "part {p} was interrupted after {} of its {} passes and written as partial to {}: merge it with --allow-missing (fewer samples), or run it again",
            phases.passes_rendered,
            info.passes_in_share(),
            output.display()
        );
    }
    Ok(PartJson { index: p.index, count: p.count, share: PartInfo::share_name(share), fingerprint, passes_rendered: phases.passes_rendered })
}

/// The first of SIGINT (Ctrl-C), SIGTERM and SIGHUP received (0: none): the exit code is 128 + it.
static SIGNAL: AtomicI32 = AtomicI32::new(0);

/// A flag that the first SIGINT (Ctrl-C), SIGTERM or SIGHUP sets: the render then stops at the next tile
/// (or within a few photons) and writes what it has, marked partial, and the process exits with 128 + the
/// signal's number (130, 143, 129). Slurm sends SIGTERM at a job's time limit and on `scancel` (then
/// SIGKILL after its `KillWait`, 30 s by default), so a cut job keeps its work. A second signal while the
/// first is being honoured exits at once. The signals are received by signal-hook's thread, not in a
/// handler, so nothing here runs in signal context.
fn cancel_on_signals() -> Arc<AtomicBool> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let cancel = Arc::new(AtomicBool::new(false));
    let c = cancel.clone();
    match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                for signal in signals.forever() {
                    let _ = SIGNAL.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
                    if c.swap(true, Ordering::SeqCst) {
                        std::process::exit(128 + signal);
                    }
                }
            });
        }
        Err(e) => warning!("cannot catch SIGINT/SIGTERM/SIGHUP ({e}): a signal will end the render without writing it"),
    }
    cancel
}

/// The outcome of a render that `phases` describe: interrupted (by [`SIGNAL`]) when partial.
fn outcome(partial: bool) -> Outcome {
    if partial {
        Outcome::Interrupted { signal: SIGNAL.load(Ordering::SeqCst) }
    } else {
        Outcome::Done
    }
}

/// The name of the signal that interrupted the render, for the summary.
fn signal_name(signal: i32) -> &'static str {
    match signal {
        signal_hook::consts::SIGTERM => "SIGTERM",
        signal_hook::consts::SIGHUP => "SIGHUP",
        _ => "Ctrl-C",
    }
}

/// The error against `--reference` after every pass, and the `--error-log` rewritten (atomically) after
/// every pass so that it is complete whenever it is read. The first failure is kept and reported after
/// the image is written.
struct PassLog<'a> {
    tracker: Option<ErrorTracker>,
    error_log: Option<&'a Path>,
    failure: Option<anyhow::Error>,
}

impl PassLog<'_> {
    /// One row per finished pass, as before rounds (a round inside a pass writes none).
    fn record(&mut self, film: &Film, info: &crate::render::PassInfo) -> Option<PassError> {
        if !info.pass_done {
            return None;
        }
        let tracker = self.tracker.as_mut()?;
        let row = match tracker.record(&film.image(), info) {
            Ok(row) => row.clone(),
            Err(e) => {
                self.failure.get_or_insert(anyhow::Error::new(e).context("comparing with --reference"));
                return None;
            }
        };
        if let Some(log) = self.error_log {
            if let Err(e) = write_bytes_atomic(log, tracker.csv().as_bytes()) {
                self.failure.get_or_insert(anyhow::Error::new(e).context("--error-log"));
            }
        }
        Some(row)
    }

    fn last(&self) -> Option<&PassError> {
        self.tracker.as_ref().and_then(|t| t.rows().last())
    }
}

/// `--checkpoint` / `--write-partial-images`: the outputs rewritten while the render runs.
struct Checkpoint {
    /// Seconds from one write to the next (0: after every round).
    every: f64,
    last: Instant,
    /// A failed write is said once; the render goes on (its end writes the outputs again, and reports).
    warned: bool,
}

impl Checkpoint {
    /// Writes the image as the film holds it now (the whole frame at `stats.spp`), atomically: the EXR, then
    /// the PNG and the stats where asked for, so that a reader finds each file whole, the stats last. The
    /// stats say `partial: true` (the render is not done).
    fn write(&mut self, args: &RenderArgs, output: &Path, film: &Film, aovs: &Aovs, stats: &RenderStatsJson) {
        let image = film.image();
        let result = write_image(output, &image, film, aovs)
            .map_err(anyhow::Error::new)
            .and_then(|()| args.png.as_ref().map_or(Ok(()), |png| write_png(png, &image, args.png_args.exposure, args.png_args.tonemap).map_err(anyhow::Error::new)))
            .and_then(|()| args.stats.as_ref().filter(|p| !is_stdout(p)).map_or(Ok(()), |p| write_json_atomic(p, stats).map_err(anyhow::Error::new)));
        if let Err(e) = result {
            if !self.warned {
                warning!("checkpoint not written ({e:#}); the render goes on");
                self.warned = true;
            }
        }
        self.last = Instant::now();
    }
}

/// Whether `--stats` names standard output (no checkpoint goes there: one JSON document is written).
fn is_stdout(p: &Path) -> bool {
    p == Path::new("-") || p == Path::new("/dev/stdout")
}

/// Wall-clock figures of the whole command.
#[derive(Clone, Copy)]
struct Timing {
    seconds_total: f64,
    seconds_setup: f64,
}

#[allow(clippy::too_many_arguments)]
fn stats_json(args: &RenderArgs, scene_path: &Path, scene: &Scene, settings: &RenderSettings, phases: &RenderPhaseStats, film: &Film, pass_log: &PassLog<'_>, backend: BackendKind, threads: usize, timing: Timing) -> RenderStatsJson {
    let crop = crop_window(scene);
    let samples = crop.area() as f64 * f64::from(phases.spp);
    let (photon_budget, photon_target) = match settings.photons {
        PhotonBudget::Emitted(n) => ("emitted", n),
        PhotonBudget::Stored(m) => ("stored", m),
    };
    RenderStatsJson {
        caustica_version: super::VERSION.as_str(),
        scene: scene_path.display().to_string(),
        backend: backend.name(),
        embree_version: if backend == BackendKind::Embree { embree_version() } else { None },
        width: scene.camera.width(),
        height: scene.camera.height(),
        crop: [crop.x0, crop.y0, crop.x1, crop.y1],
        spp: phases.spp,
        passes: phases.passes,
        threads,
        seed: settings.seed,
        estimator: settings.estimator,
        seconds_total: timing.seconds_total,
        seconds_setup: timing.seconds_setup,
        seconds_render: phases.seconds_render,
        seconds_photons: phases.seconds_photons,
        seconds_kdtree: phases.seconds_kdtree,
        rays_traced: phases.rays_traced,
        rays_per_second: phases.rays_traced as f64 / (phases.seconds_render + phases.seconds_photons).max(1e-9),
        samples_per_second: samples / phases.seconds_render.max(1e-9),
        knn: settings.knn,
        max_radius: settings.max_radius,
        photon_budget,
        photon_target,
        knn_queries: phases.knn_queries,
        knn_area_queries: phases.knn_area_queries,
        mis_q1_range: phases.mis_q1_range,
        photons_emitted: phases.photons_emitted,
        photons_stored: phases.photons_stored,
        photon_bytes: phases.photon_bytes,
        photon_chains_capped: phases.photon_chains_capped,
        nan_samples: film.nan_count(),
        inf_samples: film.inf_count(),
        partial: phases.partial,
        rounds: phases.rounds,
        skipped: phases.skipped.iter().map(|s| (s.phase.clone(), s.reason.clone())).collect(),
        area_exponent: crate::render::PROGRESSIVE_AREA_EXPONENT,
        error: match (pass_log.last(), &args.reference) {
            (Some(last), Some(r)) => Some(ErrorJson { reference: r.display().to_string(), last: last.clone() }),
            _ => None,
        },
        part: None,
        aov_channels: settings.aovs.channel_names().collect(),
        denoised: None,
    }
}

/// The one-line summary on stderr (and the last error against the reference).
fn print_summary(output: &Path, scene: &Scene, settings: &RenderSettings, phases: &RenderPhaseStats, stats: &RenderStatsJson, pass_log: &PassLog<'_>) {
    let crop = crop_window(scene);
    info!(
        "{}: {}x{} {} spp ({}) in {:.2} s (setup {:.2} s, photons {:.2} s, render {:.2} s), {:.2} Mrays/s{}",
        output.display(),
        crop.width(),
        crop.height(),
        phases.spp,
        settings.estimator.name(),
        stats.seconds_total,
        stats.seconds_setup,
        phases.seconds_photons + phases.seconds_kdtree,
        phases.seconds_render,
        stats.rays_per_second * 1e-6,
        if phases.partial { format!(" [partial: interrupted by {}]", signal_name(SIGNAL.load(Ordering::SeqCst))) } else { String::new() }
    );
    if let Some(last) = pass_log.last() {
        info!("error against the reference after {} passes: {}", last.pass, progress_text(last));
    }
}
