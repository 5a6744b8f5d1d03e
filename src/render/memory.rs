//! The memory a render will need, estimated before anything is allocated, and the one check that refuses
//! a render needing more than the memory it may use (issue "stiff and extreme cases": a film of
//! 100000×100000 or a photon budget beyond memory must be refused up front, not found by the allocator).
//!
//! The estimate counts the largest allocations, each from its element size:
//! - the mesh: positions (and normals, uvs when present) per vertex, indices, material and flag per
//!   triangle, and the triangle's shading record (`scene::TriangleShading`, 96 B) — a shapegroup's
//!   triangles once, however many instances place it — each instance (`accel::Instance`, 144 B) and
//!   each analytic shape (`accel::analytic::Analytic` and `scene::AnalyticShading`);
//! - the film: one [`PixelSum`] per pixel of the crop window (its exact sums make it 136 B), and with a
//!   filter wider than a pixel one [`PixelWeight`] more (64 B); and what a pass keeps per pixel from one
//!   round to the next (`render::round`): two tile buffers' sums (40 B each, 72 B more with a wide
//!   filter; their borders are not counted), the running sum (16 B) and, with a photon pass, the search
//!   memory ([`GatherMemory`], ~190 B); with AOVs, 8 B per AOV channel in the film and in each of the two
//!   tile buffers;
//! - the photon map of one pass (passes do not keep their maps): at most one stored [`Photon`] per emitted
//!   photon with `PhotonBudget::Emitted(N)`, the target with `Stored(M)`, each 180 B: the record (32 B),
//!   the kd-tree's packed position and decoded record (12 + 32 B), its nodes (64 B per 8 to 16
//!   photons: at most 8 B), leaves (48 B per 8 to 16 photons: at most 6 B) and their power and direction
//!   sums (12 B per leaf: at most 2 B), the occupancy grid's per-cell leaf lists and sums (at most
//!   56 B), and the photon counts' summed-volume table (`photon::counts`: at most 8 cells of 4 B). A
//!   photon that meets a blend of delta and non-delta lobes can be
//!   stored more than once, so this is an estimate, not a bound. The occupancy grid's bits (at most 132³
//!   bits, 280 KiB) and the counts table's 2¹⁶ cells that any map may have (256 KiB) are not counted.
//!
//! - the images: textures' texels (each image once) and environment maps (`Scene::image_bytes`, known from
//!   each image's header before it was decoded: `texture::ImageCache` refuses one that does not fit).
//!
//! The intersection backend's own structure is not counted (it is built from the mesh and is about its
//! size for both backends).
//!
//! A mesh file's part is known before the file's arrays are read: each reader (`crate::mesh`) takes its
//! vertex and triangle counts from the header (PLY, serialized) or a count of the lines (OBJ) and asks
//! [`check_mesh`] whether they fit in what the limit leaves, so a file that promises more than memory holds
//! is refused before anything of its size is allocated; the whole render's check then counts every mesh.
//!
//! The limit ([`MemoryLimit::process`]) is `--memory-limit` where given, else the smallest of the machine's
//! physical memory, the process's cgroup limit and its address-space limit ([`crate::sys::memory_bound`]).

use crate::film::{PixelSum, PixelWeight, TileBuffer};
use crate::integrator::GatherMemory;
use crate::math::Vec3;
use crate::photon::counts::MAX_CELLS_PER_PHOTON;
use crate::photon::occupancy::LIST_BYTES_PER_PHOTON;
use crate::photon::{DecodedPhoton, Photon, PhotonBudget};
use crate::scene::{Scene, TriangleShading};
use crate::sys::{gb, MemorySource};
use std::sync::atomic::{AtomicU64, Ordering};

use super::{photon_pass_needed, RenderSettings};

/// Bytes of the largest structures of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    pub mesh: u64,
    pub film: u64,
    pub photon_map: u64,
    pub images: u64,
}

impl MemoryEstimate {
    /// The render of `scene` with `settings` (its crop window, its estimator and photon budget).
    #[must_use]
    pub fn of(scene: &Scene, settings: &RenderSettings) -> Self {
        let m = &scene.mesh;
        let analytic = scene.analytic.len() * (crate::accel::analytic::Analytic::BYTES + size_of::<crate::scene::AnalyticShading>());
        let instances = (scene.instances.len() * size_of::<crate::accel::Instance>() + analytic) as u64;
        let mesh = mesh_bytes(m.positions.len() as u64, m.indices.len() as u64, m.normals.is_some(), m.uvs.is_some()).saturating_add(instances);
        let photons = photon_pass_needed(scene, settings.estimator).is_ok();
        let filter = scene.camera.filter();
        let rounds = 2 * TileBuffer::bytes_per_pixel(filter) + size_of::<(Vec3, u32)>() + if photons { size_of::<GatherMemory>() } else { 0 };
        // AOV channels: an f64 sum per channel in the film and in each of the two tile buffers.
        let aovs = 3 * size_of::<f64>() * settings.aovs.channel_count();
        let per_pixel = size_of::<PixelSum>() + if filter.is_box() { 0 } else { size_of::<PixelWeight>() } + rounds + aovs;
        let film = scene.camera.crop().area().saturating_mul(per_pixel as u64);
        let photon_map = if photons { photon_map_bytes(settings.photons) } else { 0 };
        Self { mesh, film, photon_map, images: scene.image_bytes }
    }

    #[must_use]
    pub fn total(&self) -> u64 {
        self.mesh.saturating_add(self.film).saturating_add(self.photon_map).saturating_add(self.images)
    }

    /// `Ok` if the estimate fits in `limit` bytes; else the error naming each part and the limit.
    pub fn check(&self, limit: MemoryLimit) -> Result<(), MemoryError> {
        if self.total() <= limit.bytes {
            Ok(())
        } else {
            Err(MemoryError { need: *self, limit })
        }
    }
}

/// The mesh part of the estimate (module docs): `vertices` positions (and normals, uvs), `triangles` index
/// triples, materials, flags and shading records.
#[must_use]
pub fn mesh_bytes(vertices: u64, triangles: u64, normals: bool, uvs: bool) -> u64 {
    let vertex = size_of::<Vec3>() as u64 * (1 + u64::from(normals)) + if uvs { 8 } else { 0 };
    vertices.saturating_mul(vertex).saturating_add(triangles.saturating_mul(12 + 4 + 1 + size_of::<TriangleShading>() as u64))
}

/// Whether a mesh file's `vertices` and `triangles` (from its header, before its arrays are read) fit in
/// what the process's limit leaves beside the memory it already holds (the meshes read before it among
/// them); `extra`: bytes the reader holds besides the mesh (an OBJ file's text). The error says what the
/// mesh needs and what is left.
pub fn check_mesh(vertices: u64, triangles: u64, normals: bool, uvs: bool, extra: u64) -> Result<(), String> {
    let Some(limit) = MemoryLimit::process() else { return Ok(()) };
    let need = mesh_bytes(vertices, triangles, normals, uvs).saturating_add(extra);
    let held = crate::sys::resident_bytes().saturating_sub(BASELINE.load(Ordering::Relaxed));
    let left = limit.bytes.saturating_sub(held);
    if need <= left {
        return Ok(());
    }
    Err(format!(
        "its {vertices} vertices and {triangles} triangles need about {} to render, more than the {} left of {} ({})",
        gb(need),
        gb(left),
        limit.source.describe(),
        gb(limit.bytes),
    ))
}

/// `--memory-limit` in bytes (0: not given), set once by the command line before any scene is read.
static USER_LIMIT: AtomicU64 = AtomicU64::new(0);
/// The resident memory when the limit was set: the program itself, not counted against the meshes.
static BASELINE: AtomicU64 = AtomicU64::new(0);

/// The photon map of one pass with `budget` (module docs).
#[must_use]
pub fn photon_map_bytes(budget: PhotonBudget) -> u64 {
    let (PhotonBudget::Emitted(n) | PhotonBudget::Stored(n)) = budget;
    let per_photon = size_of::<Photon>() + size_of::<[f32; 3]>() + size_of::<DecodedPhoton>() + 8 + 6 + 2 + LIST_BYTES_PER_PHOTON + MAX_CELLS_PER_PHOTON * size_of::<u32>();
    n.saturating_mul(per_photon as u64)
}

/// The memory a render may use, and where that figure came from (for the error message).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    pub bytes: u64,
    /// The machine's, the cgroup's or the address space's bound, or the user's `--memory-limit`.
    pub source: MemorySource,
}

impl MemoryLimit {
    /// The smallest bound of the machine and the process ([`crate::sys::memory_bound`]), or `None` where
    /// none can be read (then no limit is applied).
    #[must_use]
    pub fn machine() -> Option<Self> {
        crate::sys::memory_bound().map(|(bytes, source)| Self { bytes, source })
    }

    /// `--memory-limit` where the command line set it ([`MemoryLimit::set_user`]), else [`MemoryLimit::machine`].
    #[must_use]
    pub fn process() -> Option<Self> {
        match USER_LIMIT.load(Ordering::Relaxed) {
            0 => Self::machine(),
            bytes => Some(Self { bytes, source: MemorySource::User }),
        }
    }

    /// Sets the process's limit to `--memory-limit` (`None`: the machine's), before any scene is read; the
    /// memory held now is the program's own, not counted against the meshes read after.
    pub fn set_user(bytes: Option<u64>) {
        USER_LIMIT.store(bytes.unwrap_or(0).max(u64::from(bytes.is_some())), Ordering::Relaxed);
        BASELINE.store(crate::sys::resident_bytes(), Ordering::Relaxed);
    }
}

/// A render that would need more memory than it may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "the render needs about {} (film {}, photon map {}, mesh {}, images {}), more than {} ({}); lower the resolution or the photon budget{}",
    gb(need.total()),
    gb(need.film),
    gb(need.photon_map),
    gb(need.mesh),
    gb(need.images),
    gb(limit.bytes),
    limit.source.describe(),
    if limit.source == MemorySource::Physical { ", or raise the limit with --memory-limit GB if swap or a larger machine will take it" } else { "" }
)]
pub struct MemoryError {
    pub need: MemoryEstimate,
    pub limit: MemoryLimit,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photon_map_counts_photons_and_nodes() {
        assert_eq!(photon_map_bytes(PhotonBudget::Emitted(1000)), 180_000);
        assert_eq!(photon_map_bytes(PhotonBudget::Stored(1000)), 180_000);
        // Absurd budgets saturate instead of wrapping to a small number.
        assert_eq!(photon_map_bytes(PhotonBudget::Emitted(u64::MAX)), u64::MAX);
    }

    #[test]
    fn check_names_each_part_and_the_way_out() {
        let need = MemoryEstimate { mesh: 1_000_000, film: 2_000_000_000, photon_map: 160_000_000_000, images: 3_000_000 };
        let limit = MemoryLimit { bytes: 24_000_000_000, source: MemorySource::Physical };
        let msg = need.check(limit).unwrap_err().to_string();
        for part in ["162.00 GB", "film 2.00 GB", "photon map 160.00 GB", "mesh 0.00 GB", "images 0.00 GB", "24.00 GB", "physical memory", "--memory-limit"] {
            assert!(msg.contains(part), "{part:?} missing from {msg:?}");
        }
        let user = MemoryLimit { bytes: 1_000_000_000, source: MemorySource::User };
        assert!(!need.check(user).unwrap_err().to_string().contains("--memory-limit GB if"));
        assert_eq!(need.check(MemoryLimit { bytes: need.total(), source: MemorySource::User }), Ok(()));
    }
}
