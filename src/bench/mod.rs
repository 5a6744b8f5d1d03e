//! The measurements of `caustica bench`: build time and ray throughput of the intersection backends on meshes, and how
//! closely the backends agree.
//!
//! ```text
//! caustica bench scenes/assets/models/teapot.obj build/dragon/dragon_vrip.ply.gz \
//!     --rays 1000000 --threads 2 --backends embree,bvh --json out/bench.json
//! ```
//!
//! For every input and backend: the median of 3 builds, then Mrays/s (median of 3 runs, rayon chunks on
//! a pool of `--threads`) on the three ray sets of [`rays`] (primary, incoherent, shadow), generated once
//! per input and traced identically by every backend.
//!
//! `--instances N` places each input N times as a shapegroup's instances (`instances`; `--flatten`: the same
//! placements as one soup), and `--backends-only` leaves out the extra Embree scenes of the raw baseline and the
//! batching comparison, so that the process's peak memory is the input's and its accelerator's
//! (`scripts/bench-instancing`).
//!
//! With Embree, the incoherent set is also traced by the raw `rtcIntersect1` loop
//! (`EmbreeAccel::intersect_raw_baseline`) to show what our wrapper costs. When two backends are built,
//! every primary/incoherent hit and every shadow answer is compared.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use rayon::prelude::*;
use rayon::ThreadPool;
use serde::Serialize;

mod batching;
pub mod instances;
pub mod rays;

use self::rays::{RaySets, CHUNK};
use crate::accel::{build_accel, embree_version, Accel, BackendKind, Hit};
use crate::math::Ray;
use crate::mesh::{load_mesh, TriangleMesh};

/// Timed repetitions; the median is reported.
const RUNS: usize = 3;
/// Closest hits at different triangles still agree when their distances differ by at most this fraction.
pub const T_TOLERANCE: f32 = 1e-4;

/// The whole report, as written by `--json`.
#[derive(Serialize, Debug)]
pub struct BenchReport {
    pub threads: usize,
    pub inputs: Vec<InputReport>,
}

#[derive(Serialize, Debug)]
pub struct InputReport {
    pub file: String,
    pub triangles: usize,
    pub load_seconds: f64,
    pub ray_counts: RaySetCounts,
    pub backends: Vec<BackendReport>,
    /// Comparison of the first two backends; `null` when only one was built.
    pub agreement: Option<Agreement>,
}

#[derive(Serialize, Debug, Clone, Copy)]
pub struct RaySetCounts {
    pub primary: usize,
    pub incoherent: usize,
    pub shadow: usize,
}

#[derive(Serialize, Debug)]
pub struct BackendReport {
    pub name: &'static str,
    pub version: Option<&'static str>,
    pub build_seconds: f64,
    pub mrays_per_second: Throughput,
    /// Raw `rtcIntersect1` loop on the incoherent set, Mrays/s (Embree only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub raw_embree_incoherent: Option<f64>,
    /// Embree only: the incoherent and shadow sets handed to Embree one ray per call, in packets of
    /// 4/8/16, or as streams, and one ray per call on the scene built without ROBUST (`embree_batching`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub embree_batching: Vec<BatchingRate>,
}

/// Mrays/s of one way of handing rays to Embree (`EmbreeAccel::intersect_batched`), timed in the same
/// interleaved runs as the others; `differ`: rays whose answer is not bit-identical to one call per ray
/// (`norobust`, single rays on the scene built without ROBUST: whose primitive hit, or occlusion, differs).
#[derive(Serialize, Debug, Clone)]
pub struct BatchingRate {
    pub batching: &'static str,
    pub incoherent: f64,
    /// `None`: no occlusion variant (streams).
    pub shadow: Option<f64>,
    /// Median over the interleaved runs of (single-ray time / this variant's time).
    pub incoherent_vs_single: f64,
    pub shadow_vs_single: Option<f64>,
    /// The primary set (coherent: a tile per chunk), for contrast.
    pub primary: f64,
    pub primary_vs_single: f64,
    pub differ: usize,
}

#[derive(Serialize, Debug, Clone, Copy)]
pub struct Throughput {
    pub primary: f64,
    pub incoherent: f64,
    pub shadow: f64,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Agreement {
    pub backends: [&'static str; 2],
    /// Fraction of primary + incoherent rays whose closest hits agree.
    pub closest: f64,
    /// Fraction of shadow rays with the same answer.
    pub shadow: f64,
    /// Number of primary + incoherent rays compared.
    pub rays: usize,
    pub shadow_rays: usize,
    pub closest_disagreements: usize,
    pub shadow_disagreements: usize,
}

/// Measures every input (each on its own) with `backends` (`None`: embree and bvh when Embree is
/// compiled in, else bvh) on ray sets of `rays` rays, on `pool`. Prints one line per input loaded.
/// `backends_only`: no raw-Embree baseline and no batching comparison; `placed`: each input placed N times,
/// instanced or flattened (`instances`).
#[allow(clippy::too_many_arguments)]
pub fn measure(
    pool: &ThreadPool,
    inputs: &[PathBuf],
    params: &BTreeMap<String, String>,
    rays: usize,
    backends: Option<&[BackendKind]>,
    backends_only: bool,
    placed: Option<(usize, bool)>,
) -> anyhow::Result<BenchReport> {
    let backends = backend_list(backends);
    let mut report = BenchReport {
        threads: pool.current_num_threads(),
        inputs: Vec::new(),
    };
    for path in inputs {
        let start = Instant::now();
        let (name, mut input) = load_input(path, params)?;
        if let Some((n, flatten)) = placed {
            input = instances::placed(input, n, flatten)?;
        }
        let load_seconds = start.elapsed().as_secs_f64();
        let instances = match input.instances.len() {
            0 => String::new(),
            n => format!(" ({} in {n} instances of {} prototypes)", input.mesh.triangle_count() - input.flat as usize, input.prototypes.len()),
        };
        eprintln!("{name}: {} triangles{instances}, loaded in {load_seconds:.3} s", input.mesh.triangle_count());
        let input = bench_input(pool, name, &input, load_seconds, rays, &backends, backends_only)?;
        report.inputs.push(input);
    }
    Ok(report)
}

/// Loads one benchmark input as a single triangle soup, with the name shown in the report.
/// Mesh files (.obj, .ply, .ply.gz, .serialized) and scene files (.toml or Mitsuba XML .xml with its parameters
/// `params`: every shape of the scene, flattened).
pub fn load_input(path: &Path, params: &BTreeMap<String, String>) -> anyhow::Result<(String, BenchInput)> {
    let is_scene = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) || crate::scene::is_xml(path);
    let input = if is_scene {
        let scene = crate::scene::Scene::load_with_params(path, params)?;
        BenchInput { mesh: scene.mesh, flat: scene.flat_triangles, prototypes: scene.prototypes, instances: scene.instances, analytic: scene.analytic }
    } else {
        let mesh = load_mesh(path)?;
        BenchInput { flat: mesh.triangle_count() as u32, mesh, prototypes: Vec::new(), instances: Vec::new(), analytic: Vec::new() }
    };
    Ok((path.display().to_string(), input))
}

/// A benchmark input: the scene's soup with its prototypes, instances and analytic shapes (none for a mesh file), as
/// `Scene` holds them.
pub struct BenchInput {
    pub mesh: TriangleMesh,
    pub flat: u32,
    pub prototypes: Vec<std::ops::Range<u32>>,
    pub instances: Vec<crate::accel::Instance>,
    /// The scene's analytic shapes (none for a mesh file).
    pub analytic: Vec<crate::accel::analytic::Analytic>,
}

impl BenchInput {
    #[must_use]
    pub fn geometry(&self) -> crate::accel::Geometry<'_> {
        crate::accel::Geometry { positions: &self.mesh.positions, indices: &self.mesh.indices, flat: self.flat, prototypes: &self.prototypes, instances: &self.instances, analytic: &self.analytic }
    }
}

/// The requested backends without repeats, or the default set.
fn backend_list(requested: Option<&[BackendKind]>) -> Vec<BackendKind> {
    let default: &[BackendKind] = if embree_version().is_some() {
        &[BackendKind::Embree, BackendKind::Bvh]
    } else {
        &[BackendKind::Bvh]
    };
    let mut list: Vec<BackendKind> = Vec::new();
    for &kind in requested.unwrap_or(default) {
        if !list.contains(&kind) {
            list.push(kind);
        }
    }
    list
}

/// What one backend answered on the three ray sets (kept for the agreement check).
struct Answers {
    primary: Vec<Option<Hit>>,
    incoherent: Vec<Option<Hit>>,
    shadow: Vec<bool>,
}

fn bench_input(
    pool: &ThreadPool,
    file: String,
    input: &BenchInput,
    load_seconds: f64,
    rays: usize,
    backends: &[BackendKind],
    backends_only: bool,
) -> anyhow::Result<InputReport> {
    let mesh = &input.mesh;
    let instanced = !input.instances.is_empty();
    let sets = pool
        .install(|| RaySets::generate_for(&input.geometry(), rays))
        .with_context(|| format!("{file}: cannot generate rays"))?;
    let ray_counts = RaySetCounts {
        primary: sets.primary.len(),
        incoherent: sets.incoherent.len(),
        shadow: sets.shadow.len(),
    };
    let mut reports = Vec::new();
    let mut answers: Vec<Answers> = Vec::new();
    for &kind in backends {
        let (accel, build_seconds) =
            build_median(pool, kind, &input.geometry()).with_context(|| format!("{file}: cannot build the {} backend", kind.name()))?;
        let (primary, primary_s) = time_closest(pool, accel.as_ref(), &sets.primary);
        let (incoherent, incoherent_s) = time_closest(pool, accel.as_ref(), &sets.incoherent);
        let (shadow, shadow_s) = time_occluded(pool, accel.as_ref(), &sets.shadow);
        drop(accel);
        // The raw-Embree and batching comparisons build the flat soup alone: not for instanced inputs.
        let (raw_embree_incoherent, embree_batching) = match kind {
            BackendKind::Embree if !instanced && !backends_only => (
                Some(raw_embree_mrays(pool, mesh, &sets.incoherent).with_context(|| format!("{file}: raw Embree baseline"))?),
                batching::rates(pool, mesh, &sets).with_context(|| format!("{file}: Embree packets"))?,
            ),
            BackendKind::Embree | BackendKind::Bvh => (None, Vec::new()),
        };
        for b in &embree_batching {
            eprintln!(
                "{file}: embree {:<8} Mrays/s incoherent {:.3} ({:.3}x single), shadow {} ({}x single), primary {:.3} ({:.3}x single); {} answers differ from single rays",
                b.batching,
                b.incoherent,
                b.incoherent_vs_single,
                b.shadow.map_or("-".to_string(), |m| format!("{m:.3}")),
                b.shadow_vs_single.map_or("-".to_string(), |m| format!("{m:.3}")),
                b.primary,
                b.primary_vs_single,
                b.differ
            );
        }
        let version = match kind {
            BackendKind::Embree => embree_version(),
            BackendKind::Bvh => None,
        };
        let mrays_per_second = Throughput {
            primary: mrays(sets.primary.len(), primary_s),
            incoherent: mrays(sets.incoherent.len(), incoherent_s),
            shadow: mrays(sets.shadow.len(), shadow_s),
        };
        let m = mrays_per_second;
        eprintln!(
            "{file}: {} built in {build_seconds:.3} s; Mrays/s primary {:.3}, incoherent {:.3}, shadow {:.3}",
            kind.name(),
            m.primary,
            m.incoherent,
            m.shadow
        );
        reports.push(BackendReport {
            name: kind.name(),
            version,
            build_seconds,
            mrays_per_second,
            raw_embree_incoherent,
            embree_batching,
        });
        answers.push(Answers {
            primary,
            incoherent,
            shadow,
        });
    }
    let agreement = match (answers.first(), answers.get(1)) {
        (Some(a), Some(b)) => Some(compare(a, b, [reports[0].name, reports[1].name])),
        _ => None,
    };
    Ok(InputReport {
        file,
        triangles: mesh.triangle_count(),
        load_seconds,
        ray_counts,
        backends: reports,
        agreement,
    })
}

/// Builds `kind` [`RUNS`] times and keeps the last build; returns it with the median build time.
fn build_median(pool: &ThreadPool, kind: BackendKind, geometry: &crate::accel::Geometry) -> anyhow::Result<(Box<dyn Accel>, f64)> {
    let mut times = Vec::with_capacity(RUNS);
    let mut accel = None;
    for _ in 0..RUNS {
        drop(accel.take());
        let start = Instant::now();
        accel = Some(pool.install(|| build_accel(kind, geometry))?);
        times.push(start.elapsed().as_secs_f64());
    }
    let accel = accel.expect("RUNS > 0 builds ran");
    Ok((accel, median(times)))
}

/// Traces every ray for its closest hit, [`RUNS`] times; returns the answers and the median time.
fn time_closest(pool: &ThreadPool, accel: &dyn Accel, rays: &[Ray]) -> (Vec<Option<Hit>>, f64) {
    let mut out = vec![None; rays.len()];
    let seconds = median_time(|| {
        pool.install(|| {
            out.par_chunks_mut(CHUNK).zip(rays.par_chunks(CHUNK)).for_each(|(out, rays)| {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = accel.intersect(r);
                }
            });
        });
    });
    (out, seconds)
}

/// Traces every ray for occlusion, [`RUNS`] times; returns the answers and the median time.
fn time_occluded(pool: &ThreadPool, accel: &dyn Accel, rays: &[Ray]) -> (Vec<bool>, f64) {
    let mut out = vec![false; rays.len()];
    let seconds = median_time(|| {
        pool.install(|| {
            out.par_chunks_mut(CHUNK).zip(rays.par_chunks(CHUNK)).for_each(|(out, rays)| {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = accel.occluded(r);
                }
            });
        });
    });
    (out, seconds)
}

/// Mrays/s of Embree's raw `rtcIntersect1` loop on `rays` (same chunks and threads as the others).
#[cfg(feature = "embree")]
fn raw_embree_mrays(pool: &ThreadPool, mesh: &TriangleMesh, rays: &[Ray]) -> anyhow::Result<f64> {
    let raw = crate::accel::embree::EmbreeAccel::new(&mesh.positions, &mesh.indices)?;
    let mut hits = 0usize;
    let seconds = median_time(|| {
        hits = pool.install(|| rays.par_chunks(CHUNK).map(|c| raw.intersect_raw_baseline(c)).sum::<usize>());
    });
    std::hint::black_box(hits);
    Ok(mrays(rays.len(), seconds))
}

/// Without the `embree` feature no Embree backend is ever built, so there is no baseline to run.
#[cfg(not(feature = "embree"))]
fn raw_embree_mrays(_pool: &ThreadPool, _mesh: &TriangleMesh, _rays: &[Ray]) -> anyhow::Result<f64> {
    Err(crate::error::AccelError::EmbreeNotCompiled.into())
}

fn median_time(mut f: impl FnMut()) -> f64 {
    median(
        (0..RUNS)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

#[must_use]
fn mrays(count: usize, seconds: f64) -> f64 {
    count as f64 / seconds.max(1e-9) / 1e6
}

/// Whether two closest-hit answers agree: both miss, same triangle, or distances within
/// [`T_TOLERANCE`] relative (a ray through a shared edge or vertex may report either triangle).
#[must_use]
pub fn hits_agree(a: Option<Hit>, b: Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => a.prim == b.prim || (a.t - b.t).abs() <= T_TOLERANCE * a.t.max(b.t),
        _ => false,
    }
}

fn compare(a: &Answers, b: &Answers, backends: [&'static str; 2]) -> Agreement {
    let closest_pairs = a.primary.iter().zip(&b.primary).chain(a.incoherent.iter().zip(&b.incoherent));
    let closest_disagreements = closest_pairs.filter(|(x, y)| !hits_agree(**x, **y)).count();
    let shadow_disagreements = a.shadow.iter().zip(&b.shadow).filter(|(x, y)| x != y).count();
    let rays = a.primary.len() + a.incoherent.len();
    let shadow_rays = a.shadow.len();
    let fraction = |bad: usize, n: usize| if n == 0 { 1.0 } else { 1.0 - bad as f64 / n as f64 };
    Agreement {
        backends,
        closest: fraction(closest_disagreements, rays),
        shadow: fraction(shadow_disagreements, shadow_rays),
        rays,
        shadow_rays,
        closest_disagreements,
        shadow_disagreements,
    }
}

/// The human-readable table: one row per input × backend, then the agreement of each input.
#[must_use]
pub fn format_table(report: &BenchReport) -> String {
    let mut s = format!("threads: {}\n", report.threads);
    s += &format!(
        "{:<32} {:<7} {:<8} {:>10} {:>9} | {:>9} {:>10} {:>9} | {:>12}\n",
        "input", "backend", "version", "triangles", "build s", "primary", "incoherent", "shadow", "vs raw embree"
    );
    s += &format!("{:<32} {:<7} {:<8} {:>10} {:>9} | {:^31} |\n", "", "", "", "", "", "Mrays/s");
    for input in &report.inputs {
        let file = Path::new(&input.file)
            .file_name()
            .map_or(input.file.clone(), |f| f.to_string_lossy().into_owned());
        for b in &input.backends {
            let m = b.mrays_per_second;
            let ratio = b
                .raw_embree_incoherent
                .map_or_else(|| "-".to_string(), |raw| format!("{:.3}x", m.incoherent / raw.max(1e-12)));
            s += &format!(
                "{:<32} {:<7} {:<8} {:>10} {:>9.4} | {:>9.3} {:>10.3} {:>9.3} | {:>12}\n",
                file,
                b.name,
                b.version.unwrap_or("-"),
                input.triangles,
                b.build_seconds,
                m.primary,
                m.incoherent,
                m.shadow,
                ratio
            );
        }
        if let Some(a) = &input.agreement {
            s += &format!(
                "  {file}: {} vs {}: closest hits agree on {:.5}% of {} rays ({} differ), shadow on {:.5}% of {} ({} differ)\n",
                a.backends[0],
                a.backends[1],
                100.0 * a.closest,
                a.rays,
                a.closest_disagreements,
                100.0 * a.shadow,
                a.shadow_rays,
                a.shadow_disagreements
            );
        }
    }
    s
}


#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agreement_counts_disagreements() {
        let h = |t: f32, prim: u32| Some(Hit { t, prim, u: 0.0, v: 0.0, inst: crate::accel::FLAT });
        assert!(hits_agree(None, None) && hits_agree(h(1.0, 3), h(1.1, 3)) && hits_agree(h(1.0, 3), h(1.00005, 4)));
        assert!(!hits_agree(h(1.0, 3), None) && !hits_agree(h(1.0, 3), h(1.001, 4)));
        let a = Answers {
            primary: vec![h(1.0, 0), None],
            incoherent: vec![h(2.0, 1)],
            shadow: vec![true, false],
        };
        let b = Answers {
            primary: vec![h(1.0, 0), h(3.0, 2)],
            incoherent: vec![h(2.0, 1)],
            shadow: vec![true, true],
        };
        let agreement = compare(&a, &b, ["embree", "bvh"]);
        assert_eq!(
            (agreement.rays, agreement.closest_disagreements, agreement.shadow_disagreements),
            (3, 1, 1)
        );
        assert!((agreement.closest - 2.0 / 3.0).abs() < 1e-12 && (agreement.shadow - 0.5).abs() < 1e-12);
    }

    #[test]
    fn default_backends_and_deduplication() {
        let expected = if cfg!(feature = "embree") {
            vec![BackendKind::Embree, BackendKind::Bvh]
        } else {
            vec![BackendKind::Bvh]
        };
        assert_eq!(backend_list(None), expected);
        assert_eq!(backend_list(Some(&[BackendKind::Bvh, BackendKind::Bvh])), vec![BackendKind::Bvh]);
    }
}
