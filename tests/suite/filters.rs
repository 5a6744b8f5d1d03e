//! Pixel reconstruction filters (`film::filter`) against Mitsuba 3.9.1, and how scene files choose them.
//!
//! **Against Mitsuba.** `tests/data/filters/filters.toml` (light rectangles seen directly, their edges
//! tilted across the pixels, in front of a wall under a constant sky) rendered by caustica's `pt` with each
//! of Mitsuba's filters at their default parameters, compared with Mitsuba's `path` render with the same
//! filter (`tests/data/filters/<filter>-ref.exr`, 32×24, 16,384 spp, scalar_rgb; written by
//! `scripts/make-filter-references`; provenance in `tests/data/filters/README.md`). Blur is what a filter
//! does, so the comparison is per pixel (the whole-image and 8×8-block means of `mitsuba_features` barely
//! see a filter): `z = (ours − ref)/σ` on the luminance, σ² our value's variance (the film's
//! `value_variance`, the ratio estimator's: it counts the edge within the filter's reach as noise, so it
//! errs high at edges) plus the reference's, modelled as κ·ours·spp/16384 with κ = 2 as in
//! `mitsuba_features`, plus (10⁻³·ref)² for the pixels inside a light, which have no noise. Bounds: every
//! pixel |z| ≤ 5 (P ≈ 6·10⁻⁷ per pixel for a Gaussian z), and the mean z² ≤ 2 (1 expected, less where σ
//! errs high, and less for the stratified samples: measured 0.09 to 0.23). A test that cannot fail? Each
//! filter's image is also compared with the other filters' references, and must fail there (worst |z| >
//! 10; measured: 19 or more for every pair, 218 for the box filter against the Gaussian reference).
//!
//! **Scene files.** No rfilter → Mitsuba's Gaussian in TOML (XML: `scene_xml`); each type with its
//! parameters and defaults; keys that do not apply and values out of range are errors naming the key.

use crate::common;

use caustica::film::{read_exr, PixelFilter};
use caustica::render::RenderSettings;
use caustica::scene::{Estimator, Scene};
use common::*;

const REF_SPP: f64 = 16384.0;
const SPP: u32 = 1024;
const KAPPA: f64 = 2.0;

/// Mitsuba's filters at their default parameters, with the reference's name.
const FILTERS: [(&str, PixelFilter); 6] = [
    ("box", PixelFilter::Box),
    ("tent", PixelFilter::Tent { radius: 1.0 }),
    ("gaussian", PixelFilter::Gaussian { stddev: 0.5 }),
    ("mitchell", PixelFilter::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 }),
    ("catmullrom", PixelFilter::CatmullRom),
    ("lanczos", PixelFilter::Lanczos { lobes: 3 }),
];

/// caustica's render of the filter scene with `filter`.
fn render(filter: PixelFilter) -> Rendered {
    let mut scene = Scene::load(&repo_path("tests/data/filters/filters.toml")).unwrap_or_else(|e| panic!("{e}"));
    scene.camera.set_filter(filter);
    let mut s = RenderSettings::from_scene(&scene);
    s.spp = SPP;
    s.seed = 3;
    s.estimator = Estimator::Pt;
    render_with_variance(&scene, backend(), &s)
}

/// Mitsuba's image with the filter named `name`.
fn reference(name: &str) -> LumImage {
    let path = repo_path(&format!("tests/data/filters/{name}-ref.exr"));
    LumImage::from_image(&read_exr(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

/// The worst |z|, where, and the mean z² of `ours` against `reference` (module docs).
fn compare(ours: &Rendered, reference: &LumImage) -> (f64, (u32, u32), f64) {
    assert_eq!((reference.width, reference.height), (ours.lum.width, ours.lum.height));
    let (mut worst, mut sum_z2, mut at) = (0.0f64, 0.0, (0, 0));
    for (i, ((o, var), theirs)) in ours.lum.lum.iter().zip(&ours.lum.var).zip(&reference.lum).enumerate() {
        let sigma2 = var * (1.0 + KAPPA * f64::from(SPP) / REF_SPP) + (1e-3 * theirs).powi(2);
        let z = (o - theirs) / sigma2.sqrt();
        sum_z2 += z * z;
        if z.abs() > worst {
            worst = z.abs();
            at = (i as u32 % reference.width, i as u32 / reference.width);
        }
    }
    (worst, at, sum_z2 / reference.lum.len() as f64)
}

/// Each filter's image against each reference: its own must match (|z| ≤ 5, mean z² ≤ 2), and every
/// other filter's must not (worst |z| > 10), so that the test can fail (the closest references, tent and
/// Mitchell, differ by at most 0.072 in luminance, at an edge between 0.14 and 4).
#[test]
fn every_filter_matches_mitsubas_image_pixel_by_pixel_and_no_other_does() {
    let references: Vec<LumImage> = FILTERS.iter().map(|(name, _)| reference(name)).collect();
    let mut failures = Vec::new();
    for (name, filter) in FILTERS {
        let ours = render(filter);
        for ((other, _), reference) in FILTERS.iter().zip(&references) {
            let (worst, at, mean_z2) = compare(&ours, reference);
            eprintln!("{name} against the {other} reference: worst |z| {worst:.2} at {at:?}, mean z² {mean_z2:.3}");
            let ok = if name == *other { worst <= 5.0 && mean_z2 <= 2.0 } else { worst > 10.0 };
            if !ok {
                failures.push(format!("{name} against the {other} reference: worst |z| {worst:.2} at {at:?}, mean z² {mean_z2:.3}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn filter_of(film: &str) -> Result<PixelFilter, String> {
    let text = format!("[sensor]\nfov = 40\n{film}\n\n[[shape]]\ntype = \"cube\"\n");
    Scene::from_toml_str(&text, &repo_path("tests"), std::path::Path::new("f.toml")).map(|s| s.camera.filter()).map_err(|e| e.to_string())
}

#[test]
fn scene_files_choose_the_filter_and_mitsubas_gaussian_is_the_default() {
    assert_eq!(filter_of("film = { width = 8, height = 6 }"), Ok(PixelFilter::Gaussian { stddev: 0.5 }));
    assert_eq!(filter_of(""), Ok(PixelFilter::default()));
    assert_eq!(filter_of("[sensor.film.rfilter]\ntype = \"gaussian\"\nstddev = 0.25"), Ok(PixelFilter::Gaussian { stddev: 0.25 }));
    assert_eq!(filter_of("film = { rfilter = { type = \"box\" } }"), Ok(PixelFilter::Box));
    assert_eq!(filter_of("film.rfilter = { type = \"tent\", radius = 1.5 }"), Ok(PixelFilter::Tent { radius: 1.5 }));
    assert_eq!(filter_of("film.rfilter = { type = \"mitchell\", B = 0 }"), Ok(PixelFilter::Mitchell { b: 0.0, c: 1.0 / 3.0 }));
    assert_eq!(filter_of("film.rfilter = { type = \"catmullrom\" }"), Ok(PixelFilter::CatmullRom));
    assert_eq!(filter_of("film.rfilter = { type = \"lanczos\", lobes = 2 }"), Ok(PixelFilter::Lanczos { lobes: 2 }));
    for (film, names) in [
        ("film.rfilter = { type = \"gaussian\", radius = 2 }", &["f.toml", "sensor.film.rfilter.radius", "does not apply"][..]),
        ("film.rfilter = { type = \"box\", stddev = 1 }", &["sensor.film.rfilter.stddev", "does not apply"]),
        ("film.rfilter = { type = \"gaussian\", stddev = 0 }", &["sensor.film.rfilter.stddev", "stddev must be in"]),
        ("film.rfilter = { type = \"tent\", radius = 100 }", &["sensor.film.rfilter.radius"]),
        ("film.rfilter = { type = \"lanczos\", lobes = -1 }", &["sensor.film.rfilter.lobes"]),
        ("film.rfilter = { type = \"blackman\" }", &["sensor.film.rfilter.type", "blackman"]),
        ("film.rfilter = { stddev = 1 }", &["sensor.film.rfilter", "type"]),
    ] {
        let e = filter_of(film).expect_err(film);
        for n in names {
            assert!(e.contains(n), "{film}: {e:?} does not name {n:?}");
        }
    }
}
