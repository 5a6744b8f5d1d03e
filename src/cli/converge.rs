//! `caustica converge SCENE.toml --reference REF.exr [--estimators pt,pm,mis] [--time-budget S]
//! [--region name=x0,y0,x1,y1]... -o DIR`: error against time for each caustic estimator at equal
//! wall-clock budget. The work and the outputs are described in [`crate::report::converge`].

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{bail, Context as _};
use serde::Serialize;

use super::args::{self, named, PngArgs, RunArgs};
use super::photon_args::PhotonArgs;
use super::log::info;
use super::Outcome;
use crate::accel::build_accel;
use crate::film::io::{write_bytes_atomic, write_json_atomic};
use crate::film::{write_exr, write_png};
use crate::report::converge::{
    describe_budget, format_final_table, format_time_to_error, run_estimator, time_to_error_csv, time_to_error_table, write_errors_csv, write_plots, write_side_by_side,
    ErrorMetric, EstimatorRun, TimeToErrorTable,
};
use crate::report::error_log::{progress_text, ErrorTracker};
use crate::render::RenderSettings;
use crate::scene::settings::defaults;
use crate::scene::{Estimator, LoadOptions, Scene};

/// Arguments of `caustica converge`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// The scene file: TOML, or Mitsuba 3 XML (.xml).
    pub scene: PathBuf,
    #[command(flatten)]
    pub params: args::SceneParams,
    /// The reference image (OpenEXR, the render's size), e.g. a long `render --estimator pt` render.
    #[arg(long)]
    pub reference: PathBuf,
    /// Output directory (created if missing).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Caustic estimators to compare, comma-separated.
    #[arg(long, value_parser = named::<Estimator>(), value_delimiter = ',', default_value = "pt,pm,mis")]
    pub estimators: Vec<Estimator>,
    /// Seconds of rendering per estimator (the last pass is cut at the budget; error evaluation excluded).
    #[arg(long, default_value_t = 30.0, value_parser = args::seconds)]
    pub time_budget: f64,
    /// A region to report separately, `name=x0,y0,x1,y1` (pixels or percentages, exclusive ends). Repeatable.
    #[arg(long = "region")]
    pub regions: Vec<String>,
    /// Samples per pixel of one pass.
    #[arg(long, default_value_t = defaults::PASS_SPP_TIME_LIMITED, value_parser = args::pass_spp)]
    pub pass_spp: u32,
    #[command(flatten)]
    pub photon: PhotonArgs,
    #[command(flatten)]
    pub run: RunArgs,
    /// Errors to reach, for the time-to-error table (repeatable). Default: three errors every estimator
    /// reaches, from the largest final error up towards the smallest first-pass error (geometric steps).
    #[arg(long = "target-error", value_parser = args::seconds)]
    pub target_errors: Vec<f64>,
    /// The region (a --region name) the time-to-error table measures; default the whole image.
    #[arg(long)]
    pub target_region: Option<String>,
    /// The error measure of the time-to-error table.
    #[arg(long, value_parser = named::<ErrorMetric>(), default_value = "rmse")]
    pub target_metric: ErrorMetric,
    #[command(flatten)]
    pub png_args: PngArgs,
}

/// `summary.json`.
#[derive(Debug, Serialize)]
struct Summary<'a> {
    caustica_version: &'static str,
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

/// Checks what clap's value parsers cannot: the estimator list, the target region, the reference's size.
fn check(args: &ConvergeArgs, template: &ErrorTracker, width: u32, height: u32) -> anyhow::Result<()> {
    for (i, e) in args.estimators.iter().enumerate() {
        if args.estimators[..i].contains(e) {
            bail!("--estimators: {} is listed twice", e.name());
        }
    }
    template.check_size(width, height, &args.reference)?;
    if let Some(name) = &args.target_region {
        if !template.regions().iter().any(|r| &r.name == name) {
            bail!("--target-region {name:?}: no --region of that name");
        }
    }
    Ok(())
}

/// The scene file's settings with the command line's over them: a progressive render of `--time-budget`.
fn base_settings(args: &ConvergeArgs, scene: &Scene) -> RenderSettings {
    let mut base = RenderSettings::from_scene(scene);
    base.pass_spp = args.pass_spp;
    base.time_limit = Some(args.time_budget);
    args.photon.apply(&mut base, scene);
    if let Some(s) = args.run.seed {
        base.seed = s;
    }
    // Error curves of the image: the scene's AOVs (`integrator.aovs`) are not written here, so not traced.
    base.aovs = crate::scene::aov::Aovs::default();
    base
}

/// Runs `caustica converge`.
pub fn run(args: &ConvergeArgs) -> anyhow::Result<Outcome> {
    args.run.set_memory_limit();
    // The estimators are the command line's: an integrator caustica does not have is replaced.
    let mut scene = Scene::load_with(&args.scene, &LoadOptions { params: args.params.map(), replace_integrator: true })?;
    args.run.set_resolution(&mut scene)?;
    let (width, height) = (scene.camera.crop().width(), scene.camera.crop().height());
    let base = base_settings(args, &scene);
    // The largest of the three renders: one with a photon map.
    args.run.check_memory(&scene, &RenderSettings { estimator: Estimator::Mis, ..base.clone() })?;
    let template = ErrorTracker::load(&args.reference, &args.regions)?;
    check(args, &template, width, height)?;
    let threads = args.run.threads();
    let backend = args.run.backend();
    std::fs::create_dir_all(&args.output).with_context(|| format!("-o {}: cannot create the directory", args.output.display()))?;

    let pool = args.run.pool()?;
    let accel = pool.install(|| build_accel(backend, &scene.geometry()))?;
    let cancel = AtomicBool::new(false);

    let mut runs: Vec<EstimatorRun> = Vec::new();
    for &estimator in &args.estimators {
        let mut settings = base.clone();
        settings.estimator = estimator;
        info!("converge: {} for {} s ({} spp per pass, photons {} per pass)", estimator.name(), args.time_budget, args.pass_spp, describe_budget(settings.photons));
        let t = Instant::now();
        let run = pool.install(|| {
            run_estimator(&scene, accel.as_ref(), &settings, template.clone(), &cancel, |info, row| {
                info!("  {} pass {:>3} {:>8.2} s {:>5} spp {:>11} photons  {}", estimator.name(), info.pass, info.seconds, info.spp, info.photons_emitted, progress_text(row));
            })
        })?;
        let wall = t.elapsed().as_secs_f64();
        let stem = args.output.join(estimator.name());
        write_exr(stem.with_extension("exr"), &run.image)?;
        write_png(stem.with_extension("png"), &run.image, args.png_args.exposure, args.png_args.tonemap)?;
        info!("converge: {} done: {} passes, {} spp, {:.2} s rendering ({wall:.2} s with error evaluation)", estimator.name(), run.passes, run.spp, run.seconds);
        runs.push(run);
        // errors.csv grows after every estimator, so a long run can be inspected while it goes on.
        write_errors_csv(&args.output.join("errors.csv"), &template, &runs)?;
    }

    write_plots(&args.output, &template, &runs)?;
    write_side_by_side(&args.output, &template, &runs, args.png_args.exposure, args.png_args.tonemap)?;

    let table = time_to_error_table(&runs, args.target_metric, args.target_region.as_deref(), &args.target_errors);
    println!("{}", format_final_table(&runs, &template));
    print!("{}", format_time_to_error(&table, &args.estimators));
    write_bytes_atomic(args.output.join("time-to-error.csv"), time_to_error_csv(&table).as_bytes())?;
    write_json_atomic(args.output.join("time-to-error.json"), &table)?;
    let summary = Summary {
        caustica_version: super::VERSION.as_str(),
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
    write_json_atomic(args.output.join("summary.json"), &summary)?;
    println!("wrote {}", args.output.display());
    Ok(Outcome::Done)
}
