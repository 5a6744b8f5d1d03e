//! `caustica bench`: build time and ray throughput of the intersection backends on meshes, and how
//! closely the backends agree.
//!
//! ```text
//! caustica bench scenes/assets/models/teapot.obj build/dragon/dragon_vrip.ply.gz \
//!     --rays 1000000 --threads 2 --backends embree,bvh --json out/bench.json
//! ```
//!
//! For every input and backend: the median of 3 builds, then Mrays/s (median of 3 runs) on three ray
//! sets that are generated once per input, deterministically, and traced identically by every backend:
//! - *primary*: a pinhole camera outside the bounding sphere looking at its centre; a square image whose
//!   rays are stored tile by tile (16×16 pixels, scanline order inside a tile and between tiles), so each
//!   parallel work item is one coherent tile;
//! - *incoherent*: origins uniform over the surface area, offset by the one offset rule
//!   ([`crate::math::offset_ray_origin`]), cosine-distributed directions about the geometric normal of a
//!   randomly chosen side;
//! - *shadow*: occlusion between two random surface points, both ends offset, `t ∈ [0, 1 − 10⁻⁴]` with the
//!   unnormalised direction `p2 − p1` (pbrt-v4's `SpawnRayTo`).
//!
//! With Embree, the incoherent set is also traced by the raw `rtcIntersect1` loop
//! (`EmbreeAccel::intersect_raw_baseline`) to show what our wrapper costs. When two backends are built,
//! every primary/incoherent hit and every shadow answer is compared.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use rayon::prelude::*;
use rayon::ThreadPool;
use serde::Serialize;

use crate::accel::{build_accel, embree_version, Accel, BackendKind, Hit};
use crate::math::{barycentric_point_error, offset_ray_origin, Frame, Ray, Vec3};
use crate::mesh::{load_mesh, TriangleMesh};
use crate::sampler::Sampler;

/// Arguments of `caustica bench`.
#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Mesh files (.obj, .ply, .ply.gz) to benchmark, each on its own.
    #[arg(required = true, value_name = "MESH_OR_SCENE")]
    pub inputs: Vec<PathBuf>,
    /// Rays per ray set (the primary set uses the nearest square image made of whole 16×16 tiles).
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
    pub rays: u64,
    /// Worker threads for building and tracing [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub threads: Option<u64>,
    /// Also write the results as JSON to this file (atomically).
    #[arg(long, value_name = "OUT")]
    pub json: Option<PathBuf>,
    /// Backends to measure, comma-separated [default: embree,bvh when Embree is compiled in, else bvh].
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub backends: Option<Vec<BackendKind>>,
}

/// Seed of every benchmark ray set (fixed: runs are comparable across machines and commits).
const SEED: u64 = 0xbe7c_4000;
/// Timed repetitions; the median is reported.
const RUNS: usize = 3;
/// Image tile edge in pixels; one tile (or the same number of rays of the other sets) is one work item.
const TILE: usize = 16;
const CHUNK: usize = TILE * TILE;
/// The camera's vertical (and horizontal) field of view.
const FOV_DEGREES: f32 = 40.0;
/// Shadow rays stop this far (in units of `p2 − p1`) before their end point (pbrt-v4's `ShadowEpsilon`).
const SHADOW_EPSILON: f32 = 1e-4;
/// Closest hits at different triangles still agree when their distances differ by at most this fraction.
const T_TOLERANCE: f32 = 1e-4;

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

/// Runs the benchmark, prints the table, and writes the JSON report if asked.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let threads = match args.threads {
        Some(n) => usize::try_from(n).context("--threads is too large")?,
        None => std::thread::available_parallelism().map_or(1, usize::from),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let backends = backend_list(args.backends.as_deref());
    let rays = usize::try_from(args.rays).context("--rays is too large")?;

    let mut report = BenchReport {
        threads: pool.current_num_threads(),
        inputs: Vec::new(),
    };
    for path in &args.inputs {
        let start = Instant::now();
        let (name, mesh) = load_input(path)?;
        let load_seconds = start.elapsed().as_secs_f64();
        eprintln!("{name}: {} triangles, loaded in {load_seconds:.3} s", mesh.triangle_count());
        let input = bench_input(&pool, name, &mesh, load_seconds, rays, &backends)?;
        report.inputs.push(input);
    }
    print!("{}", format_table(&report));
    if let Some(out) = &args.json {
        let json = serde_json::to_string_pretty(&report).context("cannot serialise the report")?;
        write_atomically(out, json.as_bytes()).with_context(|| format!("cannot write {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// Loads one benchmark input as a single triangle soup, with the name shown in the report.
/// Mesh files only for now; scene files (`.toml`) become a branch here once a scene loader exists.
pub fn load_input(path: &Path) -> anyhow::Result<(String, TriangleMesh)> {
    let is_scene = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_scene {
        anyhow::bail!(
            "{}: this build has no scene loader; pass a mesh file (.obj, .ply, .ply.gz)",
            path.display()
        );
    }
    // MeshError's message already names the file and includes its cause: keep it as one message so
    // `{:#}` does not print the cause twice.
    let mesh = load_mesh(path).map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok((path.display().to_string(), mesh))
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
    mesh: &TriangleMesh,
    load_seconds: f64,
    rays: usize,
    backends: &[BackendKind],
) -> anyhow::Result<InputReport> {
    let sets = pool
        .install(|| RaySets::generate(mesh, rays))
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
            build_median(pool, kind, mesh).with_context(|| format!("{file}: cannot build the {} backend", kind.name()))?;
        let (primary, primary_s) = time_closest(pool, accel.as_ref(), &sets.primary);
        let (incoherent, incoherent_s) = time_closest(pool, accel.as_ref(), &sets.incoherent);
        let (shadow, shadow_s) = time_occluded(pool, accel.as_ref(), &sets.shadow);
        drop(accel);
        let raw_embree_incoherent = match kind {
            BackendKind::Embree => {
                Some(raw_embree_mrays(pool, mesh, &sets.incoherent).with_context(|| format!("{file}: raw Embree baseline"))?)
            }
            BackendKind::Bvh => None,
        };
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
fn build_median(pool: &ThreadPool, kind: BackendKind, mesh: &TriangleMesh) -> anyhow::Result<(Box<dyn Accel>, f64)> {
    let mut times = Vec::with_capacity(RUNS);
    let mut accel = None;
    for _ in 0..RUNS {
        drop(accel.take());
        let start = Instant::now();
        accel = Some(pool.install(|| build_accel(kind, &mesh.positions, &mesh.indices))?);
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

/// The three benchmark ray sets of one input.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub incoherent: Vec<Ray>,
    pub shadow: Vec<Ray>,
}

impl RaySets {
    /// Generates `n` incoherent and `n` shadow rays and a square image of about `n` primary rays.
    /// Every ray is a pure function of (seed, set, index), so the sets do not depend on threads.
    pub fn generate(mesh: &TriangleMesh, n: usize) -> anyhow::Result<Self> {
        let surface = SurfaceSampler::new(mesh)?;
        let primary = primary_rays(mesh, n);
        let incoherent = (0..n as u64)
            .into_par_iter()
            .map(|i| {
                let mut s = Sampler::for_key(SEED, 1, i);
                let p = surface.sample(&mut s);
                let ng = if s.next_1d() < 0.5 { p.ng } else { -p.ng };
                let dir = Frame::from_normal(ng).to_world(cosine_hemisphere(s.next_1d(), s.next_1d()));
                Ray::new(offset_ray_origin(p.p, p.p_error, ng, dir), dir)
            })
            .collect();
        let shadow = (0..n as u64)
            .into_par_iter()
            .map(|i| {
                let mut s = Sampler::for_key(SEED, 2, i);
                let (a, b) = (surface.sample(&mut s), surface.sample(&mut s));
                let from = offset_ray_origin(a.p, a.p_error, a.ng, b.p - a.p);
                let to = offset_ray_origin(b.p, b.p_error, b.ng, a.p - b.p);
                Ray::segment(from, to - from, 0.0, 1.0 - SHADOW_EPSILON)
            })
            .collect();
        Ok(Self {
            primary,
            incoherent,
            shadow,
        })
    }
}

/// Edge of the primary image: the multiple of [`TILE`] nearest to √n (at least one tile).
#[must_use]
pub fn primary_side(n: usize) -> usize {
    (((n as f64).sqrt() / TILE as f64).round() as usize).max(1) * TILE
}

/// A pinhole camera outside the mesh's bounding sphere looking at its centre, one jittered ray per
/// pixel, stored tile by tile (see the module docs).
fn primary_rays(mesh: &TriangleMesh, n: usize) -> Vec<Ray> {
    let side = primary_side(n);
    let (center, radius) = mesh.bounds().bounding_sphere();
    let half_fov_tan = (0.5 * FOV_DEGREES).to_radians().tan();
    // The sphere fits in the view when the distance is radius / sin(fov/2); 5% margin.
    let distance = 1.05 * radius.max(f32::MIN_POSITIVE) / (0.5 * FOV_DEGREES).to_radians().sin();
    let back = Vec3::new(0.55, 0.4, 0.75).normalize();
    let eye = center + distance * back;
    let forward = -back;
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tiles_per_row = side / TILE;
    (0..side * side)
        .into_par_iter()
        .map(|i| {
            let (tile, in_tile) = (i / CHUNK, i % CHUNK);
            let x = (tile % tiles_per_row) * TILE + in_tile % TILE;
            let y = (tile / tiles_per_row) * TILE + in_tile / TILE;
            let mut s = Sampler::for_key(SEED, 0, (y * side + x) as u64);
            let ndc_x = 2.0 * (x as f32 + s.next_1d()) / side as f32 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f32 + s.next_1d()) / side as f32;
            let dir = forward + half_fov_tan * (ndc_x * right + ndc_y * up);
            Ray::new(eye, dir.normalize())
        })
        .collect()
}

/// Cosine-weighted direction about +z (Malley's method: uniform disk point lifted to the hemisphere,
/// pbrt-v4 §A.5.3; the plain polar disk map suffices for a benchmark).
#[must_use]
fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

/// A point on the surface with its reconstruction error bound and unit geometric normal.
struct SurfacePoint {
    p: Vec3,
    p_error: Vec3,
    ng: Vec3,
}

/// Samples points uniformly by area over a mesh (triangle by its area, then uniform barycentrics).
struct SurfaceSampler<'a> {
    mesh: &'a TriangleMesh,
    /// Running sums of triangle areas (f64, so a million small triangles sum exactly enough).
    cdf: Vec<f64>,
}

impl<'a> SurfaceSampler<'a> {
    fn new(mesh: &'a TriangleMesh) -> anyhow::Result<Self> {
        let mut total = 0.0f64;
        let cdf: Vec<f64> = (0..mesh.triangle_count())
            .map(|i| {
                let [a, b, c] = mesh.triangle(i);
                total += 0.5 * f64::from((b - a).cross(c - a).length());
                total
            })
            .collect();
        if !(total > 0.0 && total.is_finite()) {
            anyhow::bail!("the mesh has no surface area to sample ray origins on (total area {total})");
        }
        Ok(Self { mesh, cdf })
    }

    fn sample(&self, s: &mut Sampler) -> SurfacePoint {
        let total = *self.cdf.last().expect("checked non-empty in new");
        let target = f64::from(s.next_1d()) * total;
        // First triangle whose running sum exceeds the target; zero-area triangles are never chosen.
        let tri = self.cdf.partition_point(|&c| c <= target).min(self.cdf.len() - 1);
        let corners = self.mesh.triangle(tri);
        // Uniform barycentrics: b0 = 1 − √u1, b1 = u2·√u1 (pbrt-v4 §6.5.4, SampleUniformTriangle).
        let (u1, u2) = (s.next_1d(), s.next_1d());
        let su = u1.sqrt();
        let b = [1.0 - su, u2 * su, su - u2 * su];
        let p = b[0] * corners[0] + b[1] * corners[1] + b[2] * corners[2];
        let ng = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .try_normalize()
            .unwrap_or(Vec3::Z);
        SurfacePoint {
            p,
            p_error: barycentric_point_error(b, corners),
            ng,
        }
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

/// Writes `bytes` to a temporary file next to `path`, then renames it over `path`.
fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"))?;
    let tmp = path.with_file_name(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.write_all(b"\n")?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::mesh::shapes;

    #[test]
    fn ray_sets_are_deterministic_and_hit_the_mesh() {
        let mesh = shapes::sphere(Vec3::ZERO, 1.0, 16, 32);
        let a = RaySets::generate(&mesh, 1000).unwrap();
        let b = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| RaySets::generate(&mesh, 1000).unwrap());
        assert_eq!(a.primary, b.primary);
        assert_eq!(a.incoherent, b.incoherent);
        assert_eq!(a.shadow, b.shadow);
        assert_eq!(a.primary.len(), 32 * 32);
        let brute = BruteForce::new(&mesh.positions, &mesh.indices);
        // The camera frames the bounding sphere: the tiles at the image centre all hit the sphere, the
        // corner pixels miss it.
        let tiles_per_row = 32 / TILE;
        let pixel = |x: usize, y: usize| a.primary[((y / TILE) * tiles_per_row + x / TILE) * CHUNK + (y % TILE) * TILE + x % TILE];
        for (x, y) in (12..20).flat_map(|x| (12..20).map(move |y| (x, y))) {
            assert!(brute.intersect(&pixel(x, y)).is_some(), "pixel {x} {y}");
        }
        assert!(brute.intersect(&pixel(31, 31)).is_none() && brute.intersect(&pixel(31, 0)).is_none());
        assert!(brute.intersect(&a.primary[0]).is_none());
        // Origins are offset off the surface: no ray re-hits the surface it starts on. The sphere is
        // convex and closed, so rays that clearly leave it escape and rays that clearly enter it hit the
        // far side (facet normals deviate from the radial direction by < 0.1 rad here, hence 0.3).
        let mut checked = 0;
        for r in &a.incoherent {
            let hit = brute.intersect(r);
            assert!(!matches!(hit, Some(h) if h.t <= 1e-3), "{r:?} {hit:?}");
            let cos = r.dir.normalize().dot(r.origin.normalize());
            if cos.abs() > 0.3 {
                assert_eq!(hit.is_none(), cos > 0.0, "{r:?} {hit:?}");
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked}");
    }

    #[test]
    fn shadow_rays_between_different_faces_of_a_convex_body_are_unoccluded() {
        // Two points on different faces of a cube see each other through its inside; both end offsets
        // must keep the segment off both faces. (Pairs on one face are coplanar: the two offsets may put
        // the ends on opposite sides of the plane, so those are not checked.)
        let cube = shapes::cube();
        let sets = RaySets::generate(&cube, 2000).unwrap();
        let brute = BruteForce::new(&cube.positions, &cube.indices);
        let face = |p: Vec3| (0..3).find(|&k| (p[k].abs() - 1.0).abs() < 1e-4).map(|k| (k, p[k] > 0.0));
        let mut checked = 0;
        for r in &sets.shadow {
            let (from, to) = (face(r.origin), face(r.origin + r.dir));
            assert!(from.is_some() && to.is_some(), "{r:?}");
            if from != to {
                assert!(!brute.occluded(r), "{r:?}");
                checked += 1;
            }
        }
        // Different faces with probability 5/6.
        assert!(checked > 1500, "{checked}");
        // The same segments through a wall in the middle of the cube are blocked when they cross it.
        let mut walled = cube.clone();
        let mut wall = shapes::rectangle();
        wall.positions.iter_mut().for_each(|p| *p *= 2.0);
        walled.append(&wall);
        let brute = BruteForce::new(&walled.positions, &walled.indices);
        for r in &sets.shadow {
            let (z0, z1) = (r.origin.z, (r.origin + r.dir).z);
            if z0 * z1 < -0.01 {
                assert!(brute.occluded(r), "{r:?}");
            }
        }
    }

    #[test]
    fn agreement_counts_disagreements() {
        let h = |t: f32, prim: u32| Some(Hit { t, prim, u: 0.0, v: 0.0 });
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
        assert_eq!(primary_side(1), TILE);
        assert_eq!(primary_side(1_000_000), 1008);
    }
}
