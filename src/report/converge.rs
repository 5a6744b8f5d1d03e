//! `caustica converge SCENE.toml --reference REF.exr [--estimators pt,pm,mis] [--time-budget S]
//! [--region name=x0,y0,x1,y1]... -o DIR`: error against time for each caustic estimator at equal
//! wall-clock budget.
//!
//! Each estimator renders progressively (passes of `--pass-spp` samples, a fresh photon map per pass for
//! `pm`/`mis`, the film averaging all passes) until `--time-budget` seconds of rendering are spent; after
//! every pass the film is compared with the reference (the comparison's own time is not counted, see
//! [`crate::render::PassInfo::seconds`]).
//!
//! **Progressive schedule** (method.md §6, the library's [`crate::render::area_scale_for_pass`]): every
//! pass traces the same photon budget, so the photon pass keeps a fixed share of the time and memory, and
//! the density estimate of pass `p` uses the fraction `(p+1)^(a−1)` of its k-NN area (a = 2/3): the
//! kernel bias of the average falls like `P^(a−1)` and its variance like `P^(−a)` after P passes.
//!
//! Outputs in DIR (all written atomically): `errors.csv` (one row per pass and estimator), `error.svg/png`
//! (log-log RMSE against time, one line per estimator) and `error-<region>.svg/png` per region,
//! `<estimator>.exr/png` (the final images), `side-by-side.png` (the estimators at equal time and the
//! reference) and `side-by-side-<region>.png` (the same, cropped to each region), `time-to-error.csv/json`
//! (the time each estimator needs to reach given errors), and `summary.json`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{bail, Context as _};
use serde::Serialize;

use super::error_log::{progress_text, ErrorTracker, PassError};
use super::plot::{error_plot, side_by_side, Panel, Series};
use crate::accel::{build_accel, BackendKind};
use crate::cmd::photon_args::PhotonArgs;
use crate::cmd::render::{set_resolution, write_json_atomic};
use crate::film::io::write_bytes_atomic;
use crate::film::{write_exr, write_png, Film, Image, Rect, Tonemap};
use crate::photon::PhotonBudget;
use crate::render::{render, RenderPhaseStats, RenderSettings};
use crate::scene::{Estimator, Scene};


/// Which error the time-to-error table and the targets use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorMetric {
    #[default]
    Rmse,
    Relmse,
}

impl ErrorMetric {
    fn name(self) -> &'static str {
        match self {
            ErrorMetric::Rmse => "rmse",
            ErrorMetric::Relmse => "relmse",
        }
    }

    fn of(self, row: &PassError, region: Option<&str>) -> Option<f64> {
        match self {
            ErrorMetric::Rmse => row.rmse_of(region),
            ErrorMetric::Relmse => row.relmse_of(region),
        }
    }
}

/// Arguments of `caustica converge`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The reference image (OpenEXR, the render's size), e.g. a long `render --estimator pt` render.
    #[arg(long)]
    pub reference: PathBuf,
    /// Output directory (created if missing).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Caustic estimators to compare, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "pt,pm,mis")]
    pub estimators: Vec<Estimator>,
    /// Seconds of rendering per estimator (whole passes: the last one may run over).
    #[arg(long, default_value_t = 30.0)]
    pub time_budget: f64,
    /// A region to report separately, `name=x0,y0,x1,y1` (pixels or percentages, exclusive ends). Repeatable.
    #[arg(long = "region")]
    pub regions: Vec<String>,
    /// Samples per pixel of one pass.
    #[arg(long, default_value_t = 4)]
    pub pass_spp: u32,
    #[command(flatten)]
    pub photon: PhotonArgs,
    #[arg(long)]
    pub seed: Option<u64>,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long, value_enum)]
    pub backend: Option<BackendKind>,
    /// Errors to reach, for the time-to-error table (repeatable). Default: the largest and smallest final
    /// error among the estimators and their geometric mean.
    #[arg(long = "target-error")]
    pub target_errors: Vec<f64>,
    /// The region (a --region name) the time-to-error table measures; default the whole image.
    #[arg(long)]
    pub target_region: Option<String>,
    /// The error measure of the time-to-error table.
    #[arg(long, value_enum, default_value_t = ErrorMetric::Rmse)]
    pub target_metric: ErrorMetric,
    /// Exposure of the PNG images, in stops.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Tone mapping of the PNG images.
    #[arg(long, value_enum, default_value_t = Tonemap::Clamp)]
    pub tonemap: Tonemap,
    /// No per-pass progress lines.
    #[arg(long, short = 'q')]
    pub quiet: bool,
}

/// One estimator's run.
#[derive(Clone, Debug, Serialize)]
pub struct EstimatorRun {
    pub estimator: Estimator,
    pub seconds: f64,
    pub spp: u32,
    pub passes: u32,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub final_error: Option<PassError>,
    pub stats: RenderPhaseStats,
    #[serde(skip)]
    pub rows: Vec<PassError>,
    #[serde(skip)]
    pub image: Image,
}

/// The time one estimator needs to reach one error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimeToError {
    pub estimator: Estimator,
    pub target: f64,
    /// Seconds (log-log interpolated between passes), `None` if not reached within the budget.
    pub seconds: Option<f64>,
    /// The time divided by the fastest estimator's time for the same target.
    pub ratio_to_fastest: Option<f64>,
}

/// The time-to-error table.
#[derive(Clone, Debug, Serialize)]
pub struct TimeToErrorTable {
    pub metric: ErrorMetric,
    /// The region (`None`: the whole image).
    pub region: Option<String>,
    pub targets: Vec<f64>,
    pub rows: Vec<TimeToError>,
}

/// `summary.json`.
#[derive(Debug, Serialize)]
struct Summary<'a> {
    scene: String,
    reference: String,
    width: u32,
    height: u32,
    time_budget: f64,
    pass_spp: u32,
    area_exponent: f64,
    photons: String,
    knn: u32,
    max_radius: f32,
    seed: u64,
    threads: usize,
    backend: &'static str,
    runs: &'a [EstimatorRun],
    time_to_error: &'a TimeToErrorTable,
}

/// The time at which the error series `points` (seconds, error; in time order) first reaches `target`:
/// interpolated linearly in (log t, log e) between the last pass above the target and the first at or
/// below it. Reached at the first pass: that pass's time (nothing earlier was measured). Never reached:
/// `None`.
#[must_use]
pub fn time_to_error(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let i = points.iter().position(|&(_, e)| e <= target)?;
    if i == 0 {
        return Some(points[0].0);
    }
    let (t0, e0) = points[i - 1];
    let (t1, e1) = points[i];
    if !(t0 > 0.0 && t1 > 0.0 && e0 > 0.0 && e1 > 0.0 && target > 0.0) || e0 == e1 {
        return Some(t1);
    }
    let s = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + s.clamp(0.0, 1.0) * (t1.ln() - t0.ln())).exp())
}

/// The time-to-error table of `runs` for `targets` (default targets from the final errors).
pub fn time_to_error_table(runs: &[EstimatorRun], metric: ErrorMetric, region: Option<&str>, targets: &[f64]) -> TimeToErrorTable {
    let series: Vec<Vec<(f64, f64)>> = runs.iter().map(|r| r.rows.iter().filter_map(|row| metric.of(row, region).map(|e| (row.seconds, e))).collect()).collect();
    let targets: Vec<f64> = if targets.is_empty() {
        let finals: Vec<f64> = series.iter().filter_map(|s| s.last().map(|p| p.1)).filter(|e| e.is_finite() && *e > 0.0).collect();
        if finals.is_empty() {
            Vec::new()
        } else {
            let hi = finals.iter().copied().fold(0.0f64, f64::max);
            let lo = finals.iter().copied().fold(f64::INFINITY, f64::min);
            if hi == lo {
                vec![hi]
            } else {
                vec![hi, (hi * lo).sqrt(), lo]
            }
        }
    } else {
        targets.to_vec()
    };
    let mut rows = Vec::new();
    for &target in &targets {
        let times: Vec<Option<f64>> = series.iter().map(|s| time_to_error(s, target)).collect();
        let fastest = times.iter().flatten().copied().fold(f64::INFINITY, f64::min);
        for (run, t) in runs.iter().zip(&times) {
            rows.push(TimeToError { estimator: run.estimator, target, seconds: *t, ratio_to_fastest: t.map(|t| t / fastest).filter(|r| r.is_finite()) });
        }
    }
    TimeToErrorTable { metric, region: region.map(str::to_owned), targets, rows }
}

/// The table as text: one row per target, one column per estimator (seconds and × the fastest).
#[must_use]
pub fn format_time_to_error(table: &TimeToErrorTable, estimators: &[Estimator]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "time to reach a {} of … in {} (log-log interpolation between passes; ×: relative to the fastest):", table.metric.name(), table.region.as_deref().unwrap_or("the whole image"));
    let _ = write!(s, "{:>12}", table.metric.name());
    for e in estimators {
        let _ = write!(s, " {:>20}", e.name());
    }
    s.push('\n');
    for &target in &table.targets {
        let _ = write!(s, "{target:>12.4e}");
        for e in estimators {
            let cell = match table.rows.iter().find(|r| r.target == target && r.estimator == *e) {
                Some(TimeToError { seconds: Some(t), ratio_to_fastest: Some(x), .. }) => format!("{t:.2} s ({x:.2}×)"),
                Some(TimeToError { seconds: Some(t), .. }) => format!("{t:.2} s"),
                _ => "not reached".to_string(),
            };
            let _ = write!(s, " {cell:>20}");
        }
        s.push('\n');
    }
    s
}

fn time_to_error_csv(table: &TimeToErrorTable) -> String {
    let mut s = String::from("metric,region,target,estimator,seconds,ratio_to_fastest\n");
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:.6}"));
    for r in &table.rows {
        let _ = writeln!(s, "{},{},{:.6e},{},{},{}", table.metric.name(), table.region.as_deref().unwrap_or("whole"), r.target, r.estimator.name(), opt(r.seconds), opt(r.ratio_to_fastest));
    }
    s
}

fn describe_budget(b: PhotonBudget) -> String {
    match b {
        PhotonBudget::Emitted(n) => format!("{n} emitted"),
        PhotonBudget::Stored(m) => format!("{m} stored"),
    }
}

/// Runs `caustica converge`.
pub fn run(args: &ConvergeArgs) -> anyhow::Result<()> {
    // Check every argument before any rendering.
    if !(args.time_budget.is_finite() && args.time_budget > 0.0) {
        bail!("--time-budget must be a positive number of seconds, got {}", args.time_budget);
    }
    if args.estimators.is_empty() {
        bail!("--estimators: give at least one of pt, pm, mis");
    }
    for (i, e) in args.estimators.iter().enumerate() {
        if args.estimators[..i].contains(e) {
            bail!("--estimators: {} is listed twice", e.name());
        }
    }
    if args.pass_spp == 0 {
        bail!("--pass-spp must be ≥ 1");
    }
    if let Some(t) = args.target_errors.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
        bail!("--target-error must be a positive number, got {t}");
    }
    args.photon.validate()?;
    let mut scene = Scene::load(&args.scene)?;
    set_resolution(&mut scene, args.width, args.height)?;
    let (x0, y0, x1, y1) = scene.camera.crop();
    let (width, height) = (x1 - x0, y1 - y0);
    let template = ErrorTracker::load(&args.reference, &args.regions)?;
    template.check_size(width, height, &args.reference)?;
    if let Some(name) = &args.target_region {
        if !template.regions().iter().any(|r| &r.name == name) {
            bail!("--target-region {name:?}: no --region of that name");
        }
    }

    let mut base = RenderSettings::from_scene(&scene);
    base.pass_spp = args.pass_spp;
    base.time_limit = Some(args.time_budget);
    args.photon.apply(&mut base);
    if let Some(s) = args.seed {
        base.seed = s;
    }
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())).max(1);
    let backend = args.backend.unwrap_or_else(BackendKind::default_available);
    std::fs::create_dir_all(&args.output).with_context(|| format!("-o {}: cannot create the directory", args.output.display()))?;

    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("creating the worker threads")?;
    let accel = pool.install(|| build_accel(backend, &scene.mesh.positions, &scene.mesh.indices))?;
    let cancel = AtomicBool::new(false);

    let mut runs: Vec<EstimatorRun> = Vec::new();
    for &estimator in &args.estimators {
        let mut settings = base.clone();
        settings.estimator = estimator;
        let mut tracker = template.clone();
        let mut film = Film::with_crop(scene.camera.width(), scene.camera.height(), Rect::new(x0, y0, x1, y1))?;
        let mut metric_error: Option<anyhow::Error> = None;
        if !args.quiet {
            eprintln!("converge: {} for {} s ({} spp per pass, photons {} per pass)", estimator.name(), args.time_budget, args.pass_spp, describe_budget(settings.photons));
        }
        let t = Instant::now();
        let stats = pool.install(|| {
            render(
                &scene,
                accel.as_ref(),
                &settings,
                &mut film,
                &cancel,
                |film, info| match tracker.record(&film.image(), info) {
                    Ok(row) => {
                        if !args.quiet {
                            eprintln!("  {} pass {:>3} {:>8.2} s {:>5} spp {:>11} photons  {}", estimator.name(), info.pass, info.seconds, info.spp, info.photons_emitted, progress_text(row));
                        }
                    }
                    Err(e) => {
                        metric_error.get_or_insert(anyhow::Error::new(e).context("comparing with --reference"));
                    }
                },
                &|_| {},
            )
        })?;
        if let Some(e) = metric_error {
            return Err(e);
        }
        let wall = t.elapsed().as_secs_f64();
        let rows = tracker.rows().to_vec();
        let last = rows.last().cloned();
        let image = film.image();
        let stem = args.output.join(estimator.name());
        write_exr(stem.with_extension("exr"), &image)?;
        write_png(stem.with_extension("png"), &image, args.exposure, args.tonemap)?;
        if !args.quiet {
            eprintln!("converge: {} done: {} passes, {} spp, {:.2} s rendering ({wall:.2} s with error evaluation)", estimator.name(), stats.passes, stats.spp, last.as_ref().map_or(0.0, |r| r.seconds));
        }
        runs.push(EstimatorRun {
            estimator,
            seconds: last.as_ref().map_or(0.0, |r| r.seconds),
            spp: stats.spp,
            passes: stats.passes,
            photons_emitted: stats.photons_emitted,
            photons_stored: stats.photons_stored,
            final_error: last,
            stats,
            rows,
            image,
        });
        // errors.csv grows after every estimator, so a long run can be inspected while it goes on.
        write_errors_csv(&args.output.join("errors.csv"), &template, &runs)?;
    }

    write_plots(&args.output, &template, &runs)?;
    write_side_by_side(&args.output, &template, &runs, args.exposure, args.tonemap)?;

    let table = time_to_error_table(&runs, args.target_metric, args.target_region.as_deref(), &args.target_errors);
    let text = format_time_to_error(&table, &args.estimators);
    println!("{}", format_final_table(&runs, &template));
    print!("{text}");
    write_bytes_atomic(args.output.join("time-to-error.csv"), time_to_error_csv(&table).as_bytes())?;
    write_json_atomic(&args.output.join("time-to-error.json"), &table)?;
    let summary = Summary {
        scene: args.scene.display().to_string(),
        reference: args.reference.display().to_string(),
        width,
        height,
        time_budget: args.time_budget,
        pass_spp: args.pass_spp,
        area_exponent: crate::render::PROGRESSIVE_AREA_EXPONENT,
        photons: describe_budget(base.photons),
        knn: base.knn,
        max_radius: base.max_radius,
        seed: base.seed,
        threads,
        backend: backend.name(),
        runs: &runs,
        time_to_error: &table,
    };
    write_json_atomic(&args.output.join("summary.json"), &summary)?;
    println!("wrote {}", args.output.display());
    Ok(())
}

fn write_errors_csv(path: &Path, template: &ErrorTracker, runs: &[EstimatorRun]) -> anyhow::Result<()> {
    let mut csv = template.csv_header(true);
    for run in runs {
        let mut t = template.clone();
        // Rebuild the rows through the tracker's formatter so both logs share one format.
        t = t.with_rows(run.rows.clone());
        csv.push_str(&t.csv_rows(Some(run.estimator.name())));
    }
    write_bytes_atomic(path, csv.as_bytes())?;
    Ok(())
}

/// The final figures of every run: time, spp, photons, RMSE / relMSE overall and per region.
fn format_final_table(runs: &[EstimatorRun], template: &ErrorTracker) -> String {
    let mut s = String::new();
    let _ = write!(s, "{:<10} {:>9} {:>6} {:>7} {:>12} {:>11} {:>11}", "estimator", "seconds", "spp", "passes", "photons", "rmse", "relmse");
    for r in template.regions() {
        let _ = write!(s, " {:>16}", format!("{}_rmse", r.name));
    }
    s.push('\n');
    for run in runs {
        let (rmse, relmse) = run.final_error.as_ref().map_or((f64::NAN, f64::NAN), |e| (e.rmse, e.relmse));
        let _ = write!(s, "{:<10} {:>9.2} {:>6} {:>7} {:>12} {:>11.4e} {:>11.4e}", run.estimator.name(), run.seconds, run.spp, run.passes, run.photons_emitted, rmse, relmse);
        for r in template.regions() {
            let v = run.final_error.as_ref().and_then(|e| e.rmse_of(Some(&r.name))).unwrap_or(f64::NAN);
            let _ = write!(s, " {v:>16.4e}");
        }
        s.push('\n');
    }
    s
}

fn write_plots(dir: &Path, template: &ErrorTracker, runs: &[EstimatorRun]) -> anyhow::Result<()> {
    let mut targets: Vec<(Option<&str>, String)> = vec![(None, "error".to_string())];
    for r in template.regions() {
        targets.push((Some(r.name.as_str()), format!("error-{}", r.name)));
    }
    for (region, stem) in targets {
        let series: Vec<Series> = runs
            .iter()
            .map(|run| Series { label: run.estimator.name().to_string(), points: run.rows.iter().filter_map(|row| row.rmse_of(region).map(|e| (row.seconds, e))).collect() })
            .collect();
        let title = match region {
            None => "RMSE against time (whole image)".to_string(),
            Some(name) => format!("RMSE against time (region {name})"),
        };
        let (svg, png) = error_plot(&title, "RMSE", &series)?;
        write_bytes_atomic(dir.join(format!("{stem}.svg")), svg.as_bytes())?;
        write_bytes_atomic(dir.join(format!("{stem}.png")), &png)?;
    }
    Ok(())
}

fn write_side_by_side(dir: &Path, template: &ErrorTracker, runs: &[EstimatorRun], exposure: f32, tonemap: Tonemap) -> anyhow::Result<()> {
    let label = |run: &EstimatorRun, region: Option<&str>| -> String {
        let e = run.final_error.as_ref().and_then(|e| e.rmse_of(region)).unwrap_or(f64::NAN);
        format!("{} ({} spp)\n{:.1} s, RMSE {:.2e}", run.estimator.name(), run.spp, run.seconds, e)
    };
    let mut panels: Vec<Panel<'_>> = runs.iter().map(|run| Panel { label: label(run, None), image: &run.image }).collect();
    panels.push(Panel { label: "reference".into(), image: template.reference() });
    write_bytes_atomic(dir.join("side-by-side.png"), &side_by_side(&panels, exposure, tonemap)?)?;
    for r in template.regions() {
        let crop = |img: &Image| img.crop(r.x0, r.y0, r.x1, r.y1).with_context(|| format!("region {} outside the image", r.name));
        let crops: Vec<Image> = runs.iter().map(|run| crop(&run.image)).chain(std::iter::once(crop(template.reference()))).collect::<anyhow::Result<_>>()?;
        let mut labels: Vec<String> = runs.iter().map(|run| label(run, Some(&r.name))).collect();
        labels.push("reference".into());
        let panels: Vec<Panel<'_>> = labels.into_iter().zip(&crops).map(|(label, image)| Panel { label, image }).collect();
        write_bytes_atomic(dir.join(format!("side-by-side-{}.png", r.name)), &side_by_side(&panels, exposure, tonemap)?)?;
    }
    Ok(())
}
