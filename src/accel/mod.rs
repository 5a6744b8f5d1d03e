//! Ray–triangle (and ray–quadric) intersection behind one interface.
//!
//! Every backend is built from the scene's geometry ([`Geometry`], module `instance`): a flat triangle
//! soup in world space and, for Mitsuba's `shapegroup` + `instance`, prototypes (object-space triangles
//! of the same soup, stored once) placed by instances. It returns a *preliminary* hit
//! `(t, prim, u, v, inst)` in Embree's barycentric convention, `p = (1 − u − v)·p0 + u·p1 + v·p2`, with
//! `inst` the instance ([`FLAT`] for the flat soup). Shading never reads a backend's normal: the scene
//! builds the shading interaction from `(inst, prim, u, v)` in one place, so both backends shade
//! identically.
//!
//! - [`brute::BruteForce`]: tests every triangle; the oracle for tests, kept forever.
//! - [`bvh::Bvh`]: the pure-Rust BVH.
//! - `embree::EmbreeAccel` (feature `embree`): Embree 3 or 4 through our own bindings.
//!
//! [`build_accel`], the one place a backend is built from a scene, wraps the chosen backend in
//! [`rebase::Rebased`], which traces rays that start far from the scene (reflected by a sky-sized shape)
//! from points of the same line near it; when far geometry surrounds the scene (a sky-sized shape), it
//! builds the backend twice, over the near and over the far triangles (each re-based on its own), and
//! rays that stay near the scene skip the far one ([`shell::Shelled`]).
//!
//! **Instances** (two-level acceleration): Embree places each prototype's scene with
//! `RTC_GEOMETRY_TYPE_INSTANCE`; the BVH backend builds one BVH per prototype and a top level over the
//! instances' world boxes ([`two_level::TwoLevel`]); the brute-force oracle tests every instance's
//! triangles through the same object-space rays. Only the flat soup is split into near and far parts
//! (`shell`): the sky-sized shapes `shell` exists for are single shapes, and instances always belong to
//! the near part (its box grows to hold them). `rebase` treats the instanced scene as one: its box holds
//! the instances' world boxes, and the detail that decides which rays are far is the median triangle of
//! the flat soup and of the prototypes (each scaled by its first instance's mean axis scale).
//!
//! **Analytic primitives** (Mitsuba's `sphere`, `disk`, `cylinder`: [`analytic`]) are traced beside the
//! triangles, outside `rebase` and `shell`: [`build_accel`] wraps whatever it built for the triangles in
//! [`analytic_set::WithAnalytic`] (a box BVH over the primitives, `two_level::TopLevel`) when the geometry
//! has any, and leaves triangle-only scenes as they were. Every backend, and the oracle, intersects them
//! by the one f64 routine `Analytic::intersect`, so their analytic hits are bit-identical; a hit on
//! primitive `k` has `prim = indices.len() + k` and `inst = FLAT` (`scene::Surface`). They are not Embree
//! user geometry (`RTC_GEOMETRY_TYPE_USER`): that would put the same Rust routine behind callbacks, with
//! `unsafe` packet layouts for Embree 3 and 4, for hits that are already identical this way
//! (decision 34).

pub mod analytic;
pub mod analytic_set;
pub mod brute;
pub mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
pub mod instance;
pub mod rebase;
pub mod shell;
pub mod triangle;
pub mod two_level;

pub use instance::{Geometry, Instance, FLAT};

use crate::error::AccelError;
use crate::math::{Ray, Vec3};

/// A preliminary intersection: distance along the ray (in units of `ray.dir`), the triangle's index in
/// the scene's soup (a prototype's triangle for a hit on an instance; past the triangles, an analytic
/// primitive's, with `u = v = 0`), barycentrics in Embree's convention, and the instance hit ([`FLAT`] on
/// the flat soup). 20 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    pub inst: u32,
}

/// The interface every intersection backend implements. Queries are `&self` and thread-safe.
pub trait Accel: Send + Sync {
    /// Closest hit with `t ∈ [ray.t_min, ray.t_max]`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether any hit exists with `t ∈ [ray.t_min, ray.t_max]` (shadow rays).
    fn occluded(&self, ray: &Ray) -> bool;
    /// Short backend name (`"embree"`, `"bvh"`, `"brute"`).
    fn name(&self) -> &'static str;

    /// Closest hits of a batch of rays, `out[i]` for `rays[i]`, each exactly what [`Accel::intersect`]
    /// answers (the path tracer's wave, `integrator::path`). Embree traces them in packets; other
    /// backends one by one.
    fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        intersect_each(self, rays, out);
    }

    /// Occlusion of a batch of rays, `out[i]` for `rays[i]`, each exactly what [`Accel::occluded`]
    /// answers.
    fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        occluded_each(self, rays, out);
    }
}

/// A batch one ray at a time, `out[i] = one(&rays[i])`.
fn each<T>(rays: &[Ray], out: &mut [T], one: impl Fn(&Ray) -> T) {
    assert_eq!(rays.len(), out.len());
    out.iter_mut().zip(rays).for_each(|(o, ray)| *o = one(ray));
}

/// A batch one ray at a time, `out[i] = accel.intersect(&rays[i])`: [`Accel::intersect_many`]'s default
/// (and Embree's one-ray-per-call batching).
pub(crate) fn intersect_each<A: Accel + ?Sized>(accel: &A, rays: &[Ray], out: &mut [Option<Hit>]) {
    each(rays, out, |ray| accel.intersect(ray));
}

/// [`intersect_each`] for occlusion.
pub(crate) fn occluded_each<A: Accel + ?Sized>(accel: &A, rays: &[Ray], out: &mut [bool]) {
    each(rays, out, |ray| accel.occluded(ray));
}

/// A wrapping backend's batch (`Rebased`, `Shelled`): the wrapped backend's `batch` when every ray
/// `qualifies` for it, else ray by ray by `one`; `out[i]` answers `rays[i]`.
pub(crate) fn batch_if_all<T>(rays: &[Ray], out: &mut [T], qualifies: impl Fn(&Ray) -> bool, batch: impl FnOnce(&[Ray], &mut [T]), one: impl Fn(&Ray) -> T) {
    assert_eq!(rays.len(), out.len());
    if rays.iter().all(qualifies) {
        batch(rays, out);
    } else {
        each(rays, out, one);
    }
}

const _: () = assert!(size_of::<Hit>() == 20);

/// Which backend to build, chosen at run time (`--backend embree|bvh`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendKind {
    Embree,
    Bvh,
}

impl BackendKind {
    /// Every backend kind (compiled in or not).
    pub const ALL: [BackendKind; 2] = [BackendKind::Embree, BackendKind::Bvh];

    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Embree => "embree",
            BackendKind::Bvh => "bvh",
        }
    }

    /// The default backend: Embree when compiled in, the BVH otherwise.
    #[must_use]
    pub fn default_available() -> Self {
        if cfg!(feature = "embree") {
            BackendKind::Embree
        } else {
            BackendKind::Bvh
        }
    }
}

impl std::str::FromStr for BackendKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        BackendKind::ALL.into_iter().find(|b| b.name() == s).ok_or_else(|| format!("unknown backend {s:?} (embree or bvh)"))
    }
}

/// Builds the chosen backend over the scene's geometry: the one place every command builds it, the
/// analytic primitives beside the triangles (module docs). Only the
/// chosen backend is built: once, or once over the near and once over the far triangles when far geometry
/// surrounds the scene (`shell`); prototypes once each, whatever the number of their instances.
pub fn build_accel(kind: BackendKind, geometry: &Geometry) -> Result<Box<dyn Accel>, AccelError> {
    let triangles = build_triangles(kind, geometry)?;
    if geometry.analytic.is_empty() {
        return Ok(triangles);
    }
    if geometry.indices.len() as u64 + geometry.analytic.len() as u64 > u64::from(u32::MAX) {
        return Err(AccelError::InvalidGeometry("more than 2^32 triangles and analytic shapes".into()));
    }
    Ok(Box::new(analytic_set::WithAnalytic::new(triangles, geometry.analytic, geometry.first_analytic())))
}

/// The backend over the geometry's triangles (flat soup and instances).
fn build_triangles(kind: BackendKind, geometry: &Geometry) -> Result<Box<dyn Accel>, AccelError> {
    validate_soup(geometry.positions, geometry.indices)?;
    geometry.check().map_err(AccelError::InvalidGeometry)?;
    let (positions, flat) = (geometry.positions, geometry.flat_indices());
    let part = |ids: &[u32]| -> Vec<[u32; 3]> { ids.iter().map(|&i| flat[i as usize]).collect() };
    if geometry.instances.is_empty() {
        return match shell::split(positions, flat) {
            Some(split) => {
                let near = build_rebased(kind, positions, &part(&split.near))?;
                let far = build_rebased(kind, positions, &part(&split.far))?;
                Ok(Box::new(shell::Shelled::new(near, far, split)))
            }
            None => build_rebased(kind, positions, flat),
        };
    }
    let instance_bounds = geometry.instance_bounds();
    match shell::split(positions, flat) {
        Some(mut split) => {
            split.near_bounds = instance_bounds.iter().fold(split.near_bounds, |b, &i| b.union(i));
            let near = build_instanced(kind, geometry, &part(&split.near), &instance_bounds)?;
            let far = build_rebased(kind, positions, &part(&split.far))?;
            Ok(Box::new(shell::Shelled::new(near, far, split)))
        }
        None => build_instanced(kind, geometry, flat, &instance_bounds),
    }
}

/// The backend over `flat` (its hits numbered in `flat`) and the geometry's instances, re-based as one.
fn build_instanced(kind: BackendKind, g: &Geometry, flat: &[[u32; 3]], instance_bounds: &[crate::math::Aabb]) -> Result<Box<dyn Accel>, AccelError> {
    let inner: Box<dyn Accel> = match kind {
        BackendKind::Bvh => {
            let prototypes = (0..g.prototypes.len()).map(|p| Box::new(bvh::Bvh::build(g.positions, g.prototype_indices(p))) as Box<dyn Accel>).collect();
            let first = g.prototypes.iter().map(|r| r.start).collect();
            Box::new(two_level::TwoLevel::new(Box::new(bvh::Bvh::build(g.positions, flat)), prototypes, first, g.instances, instance_bounds))
        }
        #[cfg(feature = "embree")]
        BackendKind::Embree => Box::new(embree::EmbreeAccel::instanced(g, flat)?),
        #[cfg(not(feature = "embree"))]
        BackendKind::Embree => return Err(AccelError::EmbreeNotCompiled),
    };
    let (bounds, detail) = rebase::instanced_detail(g, flat, instance_bounds);
    Ok(Box::new(rebase::Rebased::with_detail(inner, bounds, detail)))
}

/// One backend over the soup, wrapped so that far rays (reflected by a sky-sized shape) are re-based near
/// the soup's detail (`rebase`).
fn build_rebased(kind: BackendKind, positions: &[Vec3], indices: &[[u32; 3]]) -> Result<Box<dyn Accel>, AccelError> {
    let inner: Box<dyn Accel> = match kind {
        BackendKind::Bvh => Box::new(bvh::Bvh::build(positions, indices)),
        #[cfg(feature = "embree")]
        BackendKind::Embree => Box::new(embree::EmbreeAccel::new(positions, indices)?),
        #[cfg(not(feature = "embree"))]
        BackendKind::Embree => return Err(AccelError::EmbreeNotCompiled),
    };
    Ok(Box::new(rebase::Rebased::new(inner, positions, indices)))
}

/// The Embree version the build detected (e.g. `"3.13.5"`), or `None` without the `embree` feature.
#[must_use]
pub fn embree_version() -> Option<&'static str> {
    #[cfg(feature = "embree")]
    {
        Some(embree::VERSION)
    }
    #[cfg(not(feature = "embree"))]
    {
        None
    }
}

/// Rejects soups no backend can index: out-of-range indices and non-finite positions.
fn validate_soup(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<(), AccelError> {
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(AccelError::InvalidGeometry(format!("vertex {i} is not finite: {:?}", positions[i])));
    }
    if positions.len() > u32::MAX as usize || indices.len() > u32::MAX as usize {
        return Err(AccelError::InvalidGeometry("more than 2^32 vertices or triangles".into()));
    }
    let n = positions.len() as u32;
    if let Some(t) = indices.iter().position(|tri| tri.iter().any(|&i| i >= n)) {
        return Err(AccelError::InvalidGeometry(format!("triangle {t} indexes a vertex past the {n} given")));
    }
    Ok(())
}
