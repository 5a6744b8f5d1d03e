//! The work of `caustica converge SCENE.toml --reference REF.exr [--estimators pt,pm,mis] [--time-budget S]
//! [--region name=x0,y0,x1,y1]... -o DIR` (the command line is `cli::converge`): error against time for
//! each caustic estimator at equal wall-clock budget.
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
use std::path::Path;
use std::sync::atomic::AtomicBool;

use anyhow::Context as _;
use serde::Serialize;

use super::error_log::{ErrorTracker, PassError};
use super::plot::{error_plot, side_by_side, Panel, Series};
use crate::accel::Accel;
use crate::film::io::write_bytes_atomic;
use crate::film::{Image, Tonemap};
use crate::photon::PhotonBudget;
use crate::render::{render, PassInfo, RenderPhaseStats, RenderSettings};
use crate::scene::{Estimator, Scene};


/// Which error the time-to-error table and the targets use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorMetric {
    #[default]
    Rmse,
    Relmse,
}

impl ErrorMetric {
    pub const ALL: [ErrorMetric; 2] = [ErrorMetric::Rmse, ErrorMetric::Relmse];

    #[must_use]
    pub fn name(self) -> &'static str {
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

impl std::str::FromStr for ErrorMetric {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ErrorMetric::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| format!("unknown error metric {s:?} (rmse or relmse)"))
    }
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

/// The default targets of the time-to-error table: errors every estimator reaches within the budget.
/// With `hi` the largest final error and `top` the smallest first-pass error (so every series starts at
/// or above `top` and ends at or below `hi`), three targets spaced geometrically from `top` down to
/// `hi`, `top` itself excluded: `hi·(top/hi)^(2/3)`, `hi·(top/hi)^(1/3)`, `hi`. Only `hi` when no series
/// starts above it.
#[must_use]
pub fn default_targets(series: &[Vec<(f64, f64)>]) -> Vec<f64> {
    let positive = |e: &f64| e.is_finite() && *e > 0.0;
    let finals: Vec<f64> = series.iter().filter_map(|s| s.last().map(|p| p.1)).filter(positive).collect();
    let firsts: Vec<f64> = series.iter().filter_map(|s| s.first().map(|p| p.1)).filter(positive).collect();
    if finals.is_empty() || firsts.is_empty() {
        return Vec::new();
    }
    let hi = finals.iter().copied().fold(0.0f64, f64::max);
    let top = firsts.iter().copied().fold(f64::INFINITY, f64::min);
    if top <= hi {
        return vec![hi];
    }
    let ratio = top / hi;
    vec![hi * ratio.powf(2.0 / 3.0), hi * ratio.powf(1.0 / 3.0), hi]
}

/// The time-to-error table of `runs` for `targets` (empty: [`default_targets`]).
pub fn time_to_error_table(runs: &[EstimatorRun], metric: ErrorMetric, region: Option<&str>, targets: &[f64]) -> TimeToErrorTable {
    let series: Vec<Vec<(f64, f64)>> = runs.iter().map(|r| r.rows.iter().filter_map(|row| metric.of(row, region).map(|e| (row.seconds, e))).collect()).collect();
    let targets: Vec<f64> = if targets.is_empty() { default_targets(&series) } else { targets.to_vec() };
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

#[must_use]
pub fn time_to_error_csv(table: &TimeToErrorTable) -> String {
    let mut s = String::from("metric,region,target,estimator,seconds,ratio_to_fastest\n");
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v:.6}"));
    for r in &table.rows {
        let _ = writeln!(s, "{},{},{:.6e},{},{},{}", table.metric.name(), table.region.as_deref().unwrap_or("whole"), r.target, r.estimator.name(), opt(r.seconds), opt(r.ratio_to_fastest));
    }
    s
}

#[must_use]
pub fn describe_budget(b: PhotonBudget) -> String {
    match b {
        PhotonBudget::Emitted(n) => format!("{n} emitted"),
        PhotonBudget::Stored(m) => format!("{m} stored"),
    }
}

/// Renders `scene` with `settings` (a time-limited, progressive render) on the current rayon pool,
/// comparing the film with the reference after every pass (`tracker`, a fresh clone per estimator);
/// `on_row` sees every pass's figures. The comparison's own time is not counted (see
/// [`crate::render::PassInfo::seconds`]).
pub fn run_estimator(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings, mut tracker: ErrorTracker, cancel: &AtomicBool, mut on_row: impl FnMut(&PassInfo, &PassError)) -> anyhow::Result<EstimatorRun> {
    let mut film = settings.film(&scene.camera)?;
    let mut metric_error: Option<anyhow::Error> = None;
    let stats = render(
        scene,
        accel,
        settings,
        &mut film,
        cancel,
        |film, info| match tracker.record(&film.image(), info) {
            Ok(row) => on_row(info, row),
            Err(e) => {
                metric_error.get_or_insert(anyhow::Error::new(e).context("comparing with --reference"));
            }
        },
        &|_| {},
    )?;
    if let Some(e) = metric_error {
        return Err(e);
    }
    let rows = tracker.rows().to_vec();
    let last = rows.last().cloned();
    Ok(EstimatorRun {
        estimator: settings.estimator,
        seconds: last.as_ref().map_or(0.0, |r| r.seconds),
        spp: stats.spp,
        passes: stats.passes,
        photons_emitted: stats.photons_emitted,
        photons_stored: stats.photons_stored,
        final_error: last,
        stats,
        rows,
        image: film.image(),
    })
}

pub fn write_errors_csv(path: &Path, template: &ErrorTracker, runs: &[EstimatorRun]) -> anyhow::Result<()> {
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
#[must_use]
pub fn format_final_table(runs: &[EstimatorRun], template: &ErrorTracker) -> String {
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

pub fn write_plots(dir: &Path, template: &ErrorTracker, runs: &[EstimatorRun]) -> anyhow::Result<()> {
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

pub fn write_side_by_side(dir: &Path, template: &ErrorTracker, runs: &[EstimatorRun], exposure: f32, tonemap: Tonemap) -> anyhow::Result<()> {
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
