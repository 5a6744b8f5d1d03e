//! Shared helpers of the statistical image tests (`render_reference`, `render_analytic`,
//! `render_determinism`): loading scenes and the Mitsuba reference, rendering with per-pixel variance,
//! box downsampling, region means with their standard errors, and z-scores.
//!
//! Statistics are on luminance (Rec. 709, [`caustica::film::luminance`]), the quantity whose per-pixel
//! sample variance the film keeps. For a region `R` of `n` pixels, the mean `m = Σ Yᵢ / n` of independent
//! pixel means has variance `Var m = Σ σᵢ² / n²` with `σᵢ² = s²ᵢ / cᵢ` (the pixel's sample variance over its
//! sample count). That is what [`LumImage::region`] returns.

#![allow(dead_code)] // not every helper is used by the suites of every build (e.g. without Embree)

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use caustica::accel::{build_accel, BackendKind};
use caustica::film::{read_exr, Film, Image, Rect};
use caustica::render::{render, RenderPhaseStats, RenderSettings};
use caustica::scene::Scene;

/// A path inside the repository.
pub fn repo_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Samples per pixel of the Mitsuba 3 reference of `scenes/cornell-caustics.toml`.
pub const REFERENCE_SPP: f64 = 9984.0;

const REFERENCE_REL: &str = "scenes/reference/cornell-caustics/mitsuba-path-9984spp.exr";

/// The reference (256×256, 9,984 spp), shipped in the repository with its provenance
/// (`scenes/reference/cornell-caustics/README.md`).
pub fn reference_path() -> PathBuf {
    repo_path(REFERENCE_REL)
}

/// Loads the reference; its absence is a test failure, not a skip (the test would otherwise pass
/// without checking anything).
pub fn load_reference() -> Image {
    let path = reference_path();
    read_exr(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
}

/// Loads a scene shipped in `scenes/`.
pub fn load_scene(name: &str) -> Scene {
    let path = repo_path("scenes").join(name);
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Builds a scene from TOML text written in the test (no files referenced).
pub fn scene_from_toml(name: &str, text: &str) -> Scene {
    Scene::from_toml_str(text, &repo_path("tests"), Path::new(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Per-pixel luminance of an image and the variance of each pixel's estimate (0 for a reference whose
/// noise is accounted for separately).
#[derive(Clone, Debug)]
pub struct LumImage {
    pub width: u32,
    pub height: u32,
    pub lum: Vec<f64>,
    /// Variance of each pixel's mean (s² / count).
    pub var: Vec<f64>,
}

/// Mean of a region and the variance of that mean.
#[derive(Clone, Copy, Debug)]
pub struct Stat {
    pub mean: f64,
    pub var: f64,
}

impl Stat {
    pub fn sigma(&self) -> f64 {
        self.var.sqrt()
    }
}

/// z-score of `a − b` for independent estimates (variances add).
pub fn z(a: Stat, b: Stat) -> f64 {
    (a.mean - b.mean) / (a.var + b.var).sqrt()
}

impl LumImage {
    /// Luminance of an image with zero variance (the caller adds its noise model).
    pub fn from_image(image: &Image) -> Self {
        let lum = image.pixels().iter().map(|p| f64::from(caustica::film::luminance(*p))).collect::<Vec<_>>();
        let n = lum.len();
        LumImage { width: image.width(), height: image.height(), lum, var: vec![0.0; n] }
    }

    /// Mean of `[x0, x1) × [y0, y1)` and its variance `Σ σᵢ² / n²`.
    pub fn region(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Stat {
        assert!(x0 < x1 && y0 < y1 && x1 <= self.width && y1 <= self.height, "region {x0},{y0},{x1},{y1} outside");
        let (mut s, mut v) = (0.0, 0.0);
        for y in y0..y1 {
            for x in x0..x1 {
                let i = (y * self.width + x) as usize;
                s += self.lum[i];
                v += self.var[i];
            }
        }
        let n = f64::from((x1 - x0) * (y1 - y0));
        Stat { mean: s / n, var: v / (n * n) }
    }

    pub fn whole(&self) -> Stat {
        self.region(0, 0, self.width, self.height)
    }

    /// The `b × b` blocks tiling the image (the image size must be a multiple of `b`), row by row.
    pub fn blocks(&self, b: u32) -> Vec<(u32, u32, Stat)> {
        assert!(self.width % b == 0 && self.height % b == 0, "{}×{} is not tiled by {b}", self.width, self.height);
        let mut out = Vec::new();
        for by in (0..self.height).step_by(b as usize) {
            for bx in (0..self.width).step_by(b as usize) {
                out.push((bx, by, self.region(bx, by, bx + b, by + b)));
            }
        }
        out
    }

    /// The `b × b` blocks covering the image row by row, those at its right and bottom edges cut to the
    /// image (the same blocks as [`LumImage::blocks`] when `b` tiles the image).
    pub fn blocks_covering(&self, b: u32) -> Vec<(u32, u32, Stat)> {
        let mut out = Vec::new();
        for by in (0..self.height).step_by(b as usize) {
            for bx in (0..self.width).step_by(b as usize) {
                out.push((bx, by, self.region(bx, by, (bx + b).min(self.width), (by + b).min(self.height))));
            }
        }
        out
    }

    /// 2×2 box average (pixel `(x, y)` = mean of `(2x..2x+2, 2y..2y+2)`); variances average as `Σσ²/16`.
    pub fn downsample2(&self) -> Self {
        assert!(self.width % 2 == 0 && self.height % 2 == 0);
        let (w, h) = (self.width / 2, self.height / 2);
        let mut lum = Vec::with_capacity((w * h) as usize);
        let mut var = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let (mut s, mut v) = (0.0, 0.0);
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let i = ((2 * y + dy) * self.width + 2 * x + dx) as usize;
                    s += self.lum[i];
                    v += self.var[i];
                }
                lum.push(s / 4.0);
                var.push(v / 16.0);
            }
        }
        LumImage { width: w, height: h, lum, var }
    }
}

/// A render with its per-pixel luminance variance.
pub struct Rendered {
    pub image: Image,
    pub lum: LumImage,
    /// Per-pixel *sample* variance s² (not divided by the count), for noise models of other renders.
    pub sample_var: Vec<f64>,
    pub stats: RenderPhaseStats,
    pub seconds: f64,
}

/// Renders like `caustica::render::render_image`, but keeps the film so that the per-pixel sample
/// variance of the luminance is available.
pub fn render_with_variance(scene: &Scene, backend: BackendKind, settings: &RenderSettings) -> Rendered {
    let accel = build_accel(backend, &scene.geometry()).unwrap_or_else(|e| panic!("{e}"));
    let Rect { x0, y0, x1, y1 } = scene.camera.crop();
    let mut film = Film::for_camera(&scene.camera).expect("film");
    let cancel = AtomicBool::new(false);
    let t = std::time::Instant::now();
    let stats = render(scene, accel.as_ref(), settings, &mut film, &cancel, |_, _| {}, &|_| {}).unwrap_or_else(|e| panic!("{e}"));
    let seconds = t.elapsed().as_secs_f64();
    assert_eq!(film.nan_count() + film.inf_count(), 0, "non-finite samples");
    let image = film.image();
    let mut lum = LumImage::from_image(&image);
    let mut sample_var = Vec::with_capacity(lum.lum.len());
    for y in y0..y1 {
        for x in x0..x1 {
            let count = film.pixel(x, y).expect("pixel in crop").count;
            let s2 = film.luminance_variance(x, y).unwrap_or_else(|| panic!("pixel ({x}, {y}) has {count} samples; need ≥ 2"));
            sample_var.push(s2);
            lum.var[((y - y0) * (x1 - x0) + (x - x0)) as usize] = film.value_variance(x, y).expect("variance");
        }
    }
    Rendered { image, lum, sample_var, stats, seconds }
}

/// The available backend (Embree when compiled in).
pub fn backend() -> BackendKind {
    BackendKind::default_available()
}

/// SplitMix64: the seeded random numbers of the fuzz and mutation tests (the same inputs every run).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// How a render is compared with Mitsuba's image of the same scene (`mitsuba_features`, `real_scenes`).
pub struct MitsubaBounds {
    /// Mitsuba's samples per pixel: its pixel variance is modelled as `kappa·s²/ref_spp`, `s²` ours per sample.
    pub ref_spp: f64,
    pub kappa: f64,
    /// A systematic difference allowed on top of the noise, relative to Mitsuba's value.
    pub slack: f64,
    /// The whole-image mean must also lie within this fraction of Mitsuba's, when given.
    pub whole_rel: Option<f64>,
}

/// Asserts that render `r` matches Mitsuba's `reference` (`name` in messages): the whole-image luminance
/// within 4σ + slack (and `whole_rel`), every 8×8 block (cut at the image's edges) within 4.5σ + slack (a
/// block black in both is 0σ).
pub fn assert_matches_mitsuba(name: &str, r: &Rendered, reference: &Image, b: &MitsubaBounds) {
    let mut reference = LumImage::from_image(reference);
    reference.var = r.sample_var.iter().map(|s2| b.kappa * s2 / b.ref_spp).collect();
    let (ours, theirs) = (r.lum.whole(), reference.whole());
    let dev = (ours.mean - theirs.mean).abs();
    let sigma = (ours.var + theirs.var).sqrt();
    eprintln!("{name}: caustica {:.5} ± {:.5}, Mitsuba {:.5}: ratio {:.4}, {:.2}σ", ours.mean, ours.sigma(), theirs.mean, ours.mean / theirs.mean, dev / sigma);
    if let Some(rel) = b.whole_rel {
        assert!(dev <= rel * theirs.mean, "{name}: whole image {} vs Mitsuba {}: beyond {rel}", ours.mean, theirs.mean);
    }
    assert!(dev <= 4.0 * sigma + b.slack * theirs.mean, "{name}: whole image {} vs Mitsuba {} ({:.2}σ)", ours.mean, theirs.mean, dev / sigma);
    let mut worst: f64 = 0.0;
    for ((x, y, o), (_, _, t)) in r.lum.blocks_covering(8).into_iter().zip(reference.blocks_covering(8)) {
        let beyond = (o.mean - t.mean).abs() - b.slack * t.mean;
        let excess = if beyond <= 0.0 { 0.0 } else { beyond / (o.var + t.var).sqrt() };
        worst = worst.max(excess);
        assert!(excess <= 4.5, "{name}: block at ({x}, {y}): {} vs Mitsuba {} ({excess:.2}σ beyond the slack)", o.mean, t.mean);
    }
    eprintln!("{name}: worst 8×8 block {worst:.2}σ beyond the {} slack", b.slack);
}
