//! Splitting a render into parts that separate processes (machines, Slurm array tasks) render, and
//! merging their partial films into the image one process would have made, bit for bit.
//!
//! **Shares.** A render with a fixed sample count has P = ⌈spp / pass spp⌉ passes
//! ([`RenderSettings::pass_count`]) over T tiles ([`TILE_SIZE`]). Part I of N takes
//! - if N ≤ P: the passes p with p mod N = I, every tile ([`Share::Passes`]); each pass keeps its own photon
//!   map and sampler streams (keyed by the seed and the pass index, `Sampler::for_photon`, and by the
//!   sample index, which skipped passes still advance), so the passes of a part are those of the whole;
//! - else if N ≤ T: every pass, the tiles t (scan order) with t mod N = I ([`Share::Tiles`]); every part
//!   builds the same photon maps, a deterministic function of the seed and the pass;
//! - else: an error (more parts than passes and tiles).
//!
//! Round-robin shares spread the expensive passes (later passes may trace more photons) and tiles (a
//! caustic is a few tiles) over the parts.
//!
//! **Exactness.** A (pass, tile) pair is rendered by exactly one part, by the same code and with the same
//! random numbers as in the whole render, into a tile buffer whose f64 sums add the samples in the same
//! order; the film adds those f64 sums into *exact* fixed-point sums (`film::exact`), where addition is
//! associative. So the sum of the parts' films is the whole render's film whatever N, the share and the
//! order of the merge, and the image (the sums divided by the counts, rounded once) is bit-identical. This
//! needs the same binary and the same floating-point results on every machine: the BVH backend is plain
//! Rust; Embree picks its code path by the CPU's instruction set, and the system's libm supplies `powf` and
//! friends, so a heterogeneous cluster should use `--backend bvh` or nodes of one kind. Only the per-pixel
//! luminance² sums (the variance estimate, not the image) are f64 additions in merge order.
//!
//! **Identity.** Every part stores a [`fingerprint`] of the scene (its geometry, materials, lights, camera),
//! the settings (seed included), the backend, the program version and N; `merge` refuses parts whose
//! fingerprints differ, and checks that each index 0..N−1 is there exactly once.
//!
//! **Cut parts.** A part interrupted by a signal (Slurm's SIGTERM at a job's time limit, `scancel`, Ctrl-C)
//! is still written, with what it finished: its completed passes, and the tiles of the pass it was in
//! that were done (the film counts samples per pixel, so every pixel stays the mean of its samples). Its
//! description says so (`phases.partial`, [`PartInfo::is_partial`]). `merge` takes such a part only with
//! `--allow-missing`, as it takes a set with missing parts, and its stats give the samples per pixel really
//! merged ([`MergeStats::spp_merged`]): the image is an unbiased render with fewer samples, not the one the
//! whole render would have made.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::{RenderPhaseStats, RenderSettings, Share, TILE_SIZE};
use crate::accel::BackendKind;
use crate::film::partial::{read_partial_film, write_partial_film, PartialFilmError};
use crate::film::{Film, FilmError, ImageError};
use crate::scene::Scene;

/// The partial-film attribute that holds a part's [`PartInfo`] (JSON).
pub const PART_ATTRIBUTE: &str = "part";

/// Part `index` (0-based) of `count`, as written `I/N` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Part {
    pub index: u32,
    pub count: u32,
}

impl FromStr for Part {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("{s:?}: expected I/N with 0 ≤ I < N (e.g. 0/4)");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u32 = i.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Part { index, count })
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Why a render cannot be split as asked.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum PartError {
    #[error("a time-limited render cannot be split into parts (its number of passes depends on the time, so the parts could not add up to one render): give a fixed sample count (--spp, and --pass-spp for several passes)")]
    TimeLimited,
    #[error("{parts} parts is more than this render's {passes} passes and {tiles} tiles of {TILE_SIZE}×{TILE_SIZE} pixels: use at most {}", passes.max(tiles))]
    TooManyParts { parts: u32, passes: u32, tiles: u32 },
}

/// The share of `part` in a render of `settings` over `tiles` tiles (see the module documentation).
pub fn plan(settings: &RenderSettings, tiles: usize, part: Part) -> Result<Share, PartError> {
    let passes = settings.pass_count().ok_or(PartError::TimeLimited)?;
    let tiles = u32::try_from(tiles).unwrap_or(u32::MAX);
    let Part { index, count } = part;
    if count <= passes {
        Ok(Share::Passes { index, count })
    } else if count <= tiles {
        Ok(Share::Tiles { index, count })
    } else {
        Err(PartError::TooManyParts { parts: count, passes, tiles })
    }
}

/// FNV-1a over 128 bits: a stable hash (the same on every machine and build), for telling renders apart,
/// not for security.
struct Fnv128(u128);

impl Fnv128 {
    fn new() -> Self {
        Fnv128(0x6c62_272e_07bb_0142_62b8_2175_6295_c58d)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u128::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0000_0100_0000_0000_0000_0000_013b);
        }
    }

    /// A labelled field, so that moving bytes between fields changes the hash.
    fn field(&mut self, label: &str, bytes: &[u8]) {
        self.bytes(label.as_bytes());
        self.bytes(&(bytes.len() as u64).to_le_bytes());
        self.bytes(bytes);
    }
}

impl std::fmt::Write for Fnv128 {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// The identity of a split render: a hash of the scene as loaded (geometry as raw bits; materials,
/// lights with their textures, camera with its resolution and crop, integrator), the settings (seed,
/// samples, estimator, photons …), the backend (and Embree's version), the program's version and the
/// number of parts. Parts with equal fingerprints render shares of the same image.
#[must_use]
pub fn fingerprint(scene: &Scene, settings: &RenderSettings, backend: BackendKind, parts: u32) -> String {
    let mut h = Fnv128::new();
    h.field("version", env!("CARGO_PKG_VERSION").as_bytes());
    h.field("backend", backend.name().as_bytes());
    if backend == BackendKind::Embree {
        h.field("embree", crate::accel::embree_version().unwrap_or("").as_bytes());
    }
    let floats = |h: &mut Fnv128, label: &str, xs: &mut dyn Iterator<Item = f32>| {
        let bytes: Vec<u8> = xs.flat_map(|x| x.to_bits().to_le_bytes()).collect();
        h.field(label, &bytes);
    };
    let mesh = &scene.mesh;
    floats(&mut h, "positions", &mut mesh.positions.iter().flat_map(|p| p.to_array()));
    floats(&mut h, "normals", &mut mesh.normals.iter().flatten().flat_map(|p| p.to_array()));
    floats(&mut h, "uvs", &mut mesh.uvs.iter().flatten().flat_map(|p| p.to_array()));
    let ints: Vec<u8> = mesh.indices.iter().flatten().chain(&scene.tri_material).flat_map(|i| i.to_le_bytes()).collect();
    h.field("indices+materials", &ints);
    let flat: Vec<u8> = scene.tri_flat.iter().map(|&b| u8::from(b)).collect();
    h.field("flat", &flat);
    // Debug output streams into the hash (no string is built): f32 Debug prints the shortest text that
    // reads back to the same bits, so equal text means equal values.
    let _ = write!(h, "materials {:?} lights {:?} camera {:?} integrator {:?}", scene.materials, scene.lights, scene.camera, scene.integrator);
    // The rounds' length changes no image (`render::round`): left out.
    let settings = RenderSettings { round_seconds: 0.0, ..settings.clone() };
    let _ = write!(h, "settings {settings:?} parts {parts}");
    format!("{:032x}", h.0)
}

/// What a part file says about itself (JSON in its [`PART_ATTRIBUTE`] attribute, and in its stats).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PartInfo {
    pub part: Part,
    pub fingerprint: String,
    /// `"passes"` or `"tiles"`.
    pub share: String,
    /// Passes and tiles of the whole render.
    pub passes: u32,
    pub tiles: u32,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The scene file as given to the part.
    pub scene: String,
    /// Wall-clock seconds of the part, from start to its film (setup included).
    pub seconds_total: f64,
    pub phases: RenderPhaseStats,
}

impl PartInfo {
    /// The part was interrupted and holds only the passes (and tiles of its last pass) it finished.
    #[must_use]
    pub fn is_partial(&self) -> bool {
        self.phases.partial
    }

    /// The passes of the whole render that this part's share takes: its own with a share of the passes
    /// (p mod N = I), all of them with a share of the tiles.
    #[must_use]
    pub fn passes_in_share(&self) -> u32 {
        match self.share.as_str() {
            "passes" => self.passes.saturating_sub(self.part.index).div_ceil(self.part.count.max(1)),
            _ => self.passes,
        }
    }

    /// The share's name as stored in [`PartInfo::share`].
    #[must_use]
    pub fn share_name(share: Share) -> &'static str {
        match share {
            Share::All => "all",
            Share::Passes { .. } => "passes",
            Share::Tiles { .. } => "tiles",
        }
    }
}

/// Errors of reading, checking and merging parts; each names the file(s) or the part(s).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error(transparent)]
    Read(#[from] PartialFilmError),
    #[error("{path}: a partial film without a valid part description ({reason})")]
    NoPartInfo { path: PathBuf, reason: String },
    #[error("no part to merge")]
    Empty,
    #[error("{}: from another render than {first} (fingerprint {found} ≠ {expected}): the scene, settings, seed or number of parts differ", paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    Foreign { paths: Vec<PathBuf>, first: String, found: String, expected: String },
    #[error("part {part} is given twice: {} and {}", first.display(), second.display())]
    Duplicate { part: Part, first: PathBuf, second: PathBuf },
    #[error("{} missing (have {}): run {} again, or merge with --allow-missing", missing_text(*count, missing), have.iter().map(|i| format!("{i}/{count}")).collect::<Vec<_>>().join(", "), if missing.len() == 1 { "it" } else { "them" })]
    Missing { count: u32, missing: Vec<u32>, have: Vec<u32> },
    #[error("{}: part {part} was interrupted after {done} of its {of} passes: run it again, or merge with --allow-missing (the image then has fewer samples)", path.display())]
    Partial { path: PathBuf, part: Part, done: u32, of: u32 },
    #[error("{path}: {source}")]
    Film { path: PathBuf, source: FilmError },
}

/// "part 1/4 is" / "parts 1/4, 3/4 are".
fn missing_text(count: u32, missing: &[u32]) -> String {
    let list = missing.iter().map(|i| format!("{i}/{count}")).collect::<Vec<_>>().join(", ");
    if missing.len() == 1 {
        format!("part {list} is")
    } else {
        format!("parts {list} are")
    }
}

/// A part read back from its file.
#[derive(Clone, Debug)]
pub struct PartFile {
    pub path: PathBuf,
    pub film: Film,
    pub info: PartInfo,
}

/// Writes a part's film and description to `path` (atomically: a killed part leaves no file).
pub fn write_part(path: &Path, film: &Film, info: &PartInfo) -> Result<(), ImageError> {
    let json = serde_json::to_string(info).map_err(|e| ImageError::Io { path: path.to_owned(), source: std::io::Error::other(e) })?;
    write_partial_film(path, film, &BTreeMap::from([(PART_ATTRIBUTE.to_string(), json)]))
}

/// Reads a part file written by [`write_part`].
pub fn read_part(path: &Path) -> Result<PartFile, MergeError> {
    let (film, attributes) = read_partial_film(path)?;
    let no_info = |reason: String| MergeError::NoPartInfo { path: path.to_owned(), reason };
    let json = attributes.get(PART_ATTRIBUTE).ok_or_else(|| no_info(format!("no {PART_ATTRIBUTE} attribute")))?;
    let info: PartInfo = serde_json::from_str(json).map_err(|e| no_info(e.to_string()))?;
    if info.part.count == 0 || info.part.index >= info.part.count {
        return Err(no_info(format!("part {}/{}", info.part.index, info.part.count)));
    }
    Ok(PartFile { path: path.to_owned(), film, info })
}

/// Checks that `parts` belong to one render (one fingerprint: the one most parts have, the first part's
/// on a tie) and hold each index at most once; unless `allow_missing`, every index 0..N−1 exactly once,
/// and none of them cut short ([`PartInfo::is_partial`]). Returns the missing indices (empty for a full set).
pub fn check_set(parts: &[PartFile], allow_missing: bool) -> Result<Vec<u32>, MergeError> {
    let first = parts.first().ok_or(MergeError::Empty)?;
    let mut votes: Vec<(&str, usize)> = Vec::new();
    for p in parts {
        match votes.iter_mut().find(|(f, _)| *f == p.info.fingerprint) {
            Some(v) => v.1 += 1,
            None => votes.push((&p.info.fingerprint, 1)),
        }
    }
    let best = votes.iter().map(|v| v.1).max().unwrap_or(0);
    let expected = votes.iter().find(|v| v.1 == best).map_or(first.info.fingerprint.as_str(), |v| v.0);
    let reference = parts.iter().find(|p| p.info.fingerprint == expected).unwrap_or(first);
    let foreign: Vec<&PartFile> = parts.iter().filter(|p| p.info.fingerprint != expected).collect();
    if let Some(f) = foreign.first() {
        return Err(MergeError::Foreign {
            paths: foreign.iter().map(|p| p.path.clone()).collect(),
            first: format!("{} (part {})", reference.path.display(), reference.info.part),
            found: format!("{} of part {}", f.info.fingerprint, f.info.part),
            expected: expected.to_string(),
        });
    }
    let count = reference.info.part.count;
    let mut seen: Vec<Option<&Path>> = vec![None; count as usize];
    for p in parts {
        let slot = &mut seen[p.info.part.index as usize];
        if let Some(firstpath) = slot {
            return Err(MergeError::Duplicate { part: p.info.part, first: firstpath.to_path_buf(), second: p.path.clone() });
        }
        *slot = Some(&p.path);
    }
    let missing: Vec<u32> = (0..count).filter(|&i| seen[i as usize].is_none()).collect();
    if !missing.is_empty() && !allow_missing {
        let have = (0..count).filter(|&i| seen[i as usize].is_some()).collect();
        return Err(MergeError::Missing { count, missing, have });
    }
    if let Some(p) = parts.iter().find(|p| p.info.is_partial()).filter(|_| !allow_missing) {
        return Err(MergeError::Partial { path: p.path.clone(), part: p.info.part, done: p.info.phases.passes_rendered, of: p.info.passes_in_share() });
    }
    Ok(missing)
}

/// The statistics of a merge (`merge --stats`).
#[derive(Clone, Debug, Serialize)]
pub struct MergeStats {
    pub fingerprint: String,
    pub scene: String,
    pub parts: u32,
    pub share: String,
    pub merged: Vec<u32>,
    /// Indices of the parts that were missing (only with `--allow-missing`).
    pub missing: Vec<u32>,
    /// Indices of the parts that were interrupted and merged with what they finished (only with
    /// `--allow-missing`).
    pub partial: Vec<u32>,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Samples per pixel really merged: their mean over the crop window, and the fewest any pixel has
    /// (`spp` for a full set; less with missing or partial parts; 0 where a missing part's tiles are).
    pub spp_merged: f64,
    pub spp_merged_min: u64,
    pub passes: u32,
    /// Σ over the parts of their wall-clock seconds (the machine time the render cost), and the longest.
    pub seconds_parts_sum: f64,
    pub seconds_parts_max: f64,
    /// Seconds of the merge itself (reading, adding, writing); set by the caller.
    pub seconds_merge: f64,
    pub rays_traced: u64,
    pub knn_queries: u64,
    pub knn_area_queries: u64,
    /// The parts' q₁ ranges combined (`mis` only).
    pub mis_q1_range: Option<[f32; 2]>,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub nan_samples: u64,
    pub inf_samples: u64,
    pub part_stats: Vec<PartInfo>,
}

/// Checks the set ([`check_set`]) and adds the films in part order: the whole render's film when no
/// part is missing (see the module documentation).
pub fn merge_parts(mut parts: Vec<PartFile>, allow_missing: bool) -> Result<(Film, MergeStats), MergeError> {
    let missing = check_set(&parts, allow_missing)?;
    parts.sort_by_key(|p| p.info.part.index);
    let first = &parts[0];
    let mut film = first.film.clone();
    for p in &parts[1..] {
        film.add_film(&p.film).map_err(|source| MergeError::Film { path: p.path.clone(), source })?;
    }
    let info = &first.info;
    let sum = |f: fn(&PartInfo) -> u64| parts.iter().map(|p| f(&p.info)).sum::<u64>();
    let stats = MergeStats {
        fingerprint: info.fingerprint.clone(),
        scene: info.scene.clone(),
        parts: info.part.count,
        share: info.share.clone(),
        merged: parts.iter().map(|p| p.info.part.index).collect(),
        missing,
        partial: parts.iter().filter(|p| p.info.is_partial()).map(|p| p.info.part.index).collect(),
        spp: info.spp,
        spp_merged: film.samples_per_pixel(),
        spp_merged_min: film.sums().iter().map(|p| p.count).min().unwrap_or(0),
        passes: info.passes,
        seconds_parts_sum: parts.iter().map(|p| p.info.seconds_total).sum(),
        seconds_parts_max: parts.iter().map(|p| p.info.seconds_total).fold(0.0, f64::max),
        seconds_merge: 0.0,
        rays_traced: sum(|i| i.phases.rays_traced),
        knn_queries: sum(|i| i.phases.knn_queries),
        knn_area_queries: sum(|i| i.phases.knn_area_queries),
        mis_q1_range: parts.iter().filter_map(|p| p.info.phases.mis_q1_range).reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])]),
        photons_emitted: sum(|i| i.phases.photons_emitted),
        photons_stored: sum(|i| i.phases.photons_stored),
        nan_samples: film.nan_count(),
        inf_samples: film.inf_count(),
        part_stats: parts.iter().map(|p| p.info.clone()).collect(),
    };
    Ok((film, stats))
}
