//! The benchmark's three ray sets, generated deterministically from a mesh or a scene's geometry with
//! instances (every ray is a pure function
//! of (seed, set, index), so the sets do not depend on the thread count and are identical for every backend):
//! - *primary*: a pinhole camera outside the bounding sphere looking at its centre; a square image whose
//!   rays are stored tile by tile (16×16 pixels, scanline order inside a tile and between tiles), so each
//!   parallel work item of [`CHUNK`] rays is one coherent tile;
//! - *incoherent*: origins uniform over the surface area (with instances: a flat triangle or an instance
//!   chosen by area, the instance's area its prototype's times `|det|^(2/3)` of its transform, then a
//!   prototype triangle by area, placed), offset by the one offset rule
//!   ([`offset_ray_origin`] with [`barycentric_point_error`]), cosine-distributed directions about the
//!   geometric normal of a randomly chosen side, `t ≥ spawn_t_min` as the renderer's spawned rays;
//! - *shadow*: occlusion between two random surface points, both ends offset, `t ∈ [spawn_t_min, 1 − 10⁻⁴]`
//!   with the unnormalised direction between the offset end points (pbrt-v4's `SpawnRayTo`).
//!
//! Without the renderer's `spawn_t_min`, a ray leaving a large triangle (the 20-unit floor of
//! `teapot-glossy.toml`) can be reported hitting that same triangle at `t ≈ 0` by one backend's rounding
//! and not by the other's: such self-hits were the closest-hit disagreements between Embree and the BVH.

use rayon::prelude::*;

use crate::accel::{Geometry, FLAT};
use crate::math::{barycentric_point_error, gamma, offset_ray_origin, spawn_t_min, Aabb, Frame, Ray, Vec3};
use crate::mesh::TriangleMesh;
use crate::sampler::Sampler;

/// Seed of every benchmark ray set (fixed: runs are comparable across machines and commits).
const SEED: u64 = 0xbe7c_4000;
/// Image tile edge in pixels.
pub const TILE: usize = 16;
/// Rays per parallel work item: one primary tile (the other sets use the same granularity).
pub const CHUNK: usize = TILE * TILE;
/// The camera's vertical (and horizontal) field of view.
const FOV_DEGREES: f32 = 40.0;
/// Shadow rays stop this far (in units of their direction) before their end point (pbrt-v4's `ShadowEpsilon`).
const SHADOW_EPSILON: f32 = 1e-4;

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
        Self::generate_for(&Geometry::soup(&mesh.positions, &mesh.indices), n)
    }

    /// [`RaySets::generate`] over a scene's geometry, instances included.
    pub fn generate_for(g: &Geometry, n: usize) -> anyhow::Result<Self> {
        let surface = SurfaceSampler::new(g)?;
        let bounds = g.instance_bounds().into_iter().fold(Aabb::from_points(&g.flat_indices().iter().flatten().map(|&i| g.positions[i as usize]).collect::<Vec<_>>()), Aabb::union);
        let primary = primary_rays(bounds, n);
        let incoherent = (0..n as u64)
            .into_par_iter()
            .map(|i| {
                let mut s = Sampler::for_key(SEED, 1, i);
                let p = surface.sample(&mut s);
                let ng = if s.next_1d() < 0.5 { p.ng } else { -p.ng };
                let dir = Frame::from_normal(ng).to_world(cosine_hemisphere(s.next_1d(), s.next_1d()));
                Ray::segment(offset_ray_origin(p.p, p.p_error, ng, dir), dir, spawn_t_min(p.p_error, dir), f32::INFINITY)
            })
            .collect();
        let shadow = (0..n as u64)
            .into_par_iter()
            .map(|i| {
                let mut s = Sampler::for_key(SEED, 2, i);
                let (a, b) = (surface.sample(&mut s), surface.sample(&mut s));
                let from = offset_ray_origin(a.p, a.p_error, a.ng, b.p - a.p);
                let to = offset_ray_origin(b.p, b.p_error, b.ng, a.p - b.p);
                Ray::segment(from, to - from, spawn_t_min(a.p_error, to - from), 1.0 - SHADOW_EPSILON)
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
fn primary_rays(bounds: Aabb, n: usize) -> Vec<Ray> {
    let side = primary_side(n);
    let (center, radius) = bounds.bounding_sphere();
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

/// Samples points uniformly by area over a mesh (triangle by its area, then uniform barycentrics); with
/// instances, as the module docs say.
struct SurfaceSampler<'a> {
    g: Geometry<'a>,
    /// Running sums of the flat triangles' areas, then of the instances' (f64, so a million small
    /// triangles sum exactly enough).
    cdf: Vec<f64>,
    /// Per prototype, the running sums of its triangles' areas.
    prototypes: Vec<Vec<f64>>,
}

fn triangle_area(g: &Geometry, t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| g.positions[i as usize]);
    0.5 * f64::from((b - a).cross(c - a).length())
}

fn running_sums(areas: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut total = 0.0;
    areas.map(|a| {
        total += a;
        total
    }).collect()
}

impl<'a> SurfaceSampler<'a> {
    fn new(g: &Geometry<'a>) -> anyhow::Result<Self> {
        let prototypes: Vec<Vec<f64>> = (0..g.prototypes.len()).map(|p| running_sums(g.prototype_indices(p).iter().map(|t| triangle_area(g, t)))).collect();
        let instance_area = |i: &crate::accel::Instance| {
            let det = f64::from(i.to_world.matrix3.determinant()).abs();
            prototypes[i.prototype as usize].last().copied().unwrap_or(0.0) * det.powf(2.0 / 3.0)
        };
        let cdf = running_sums(g.flat_indices().iter().map(|t| triangle_area(g, t)).chain(g.instances.iter().map(instance_area)));
        let total = cdf.last().copied().unwrap_or(0.0);
        if !(total > 0.0 && total.is_finite()) {
            anyhow::bail!("the mesh has no surface area to sample ray origins on (total area {total})");
        }
        Ok(Self { g: *g, cdf, prototypes })
    }

    fn sample(&self, s: &mut Sampler) -> SurfacePoint {
        let pick = |cdf: &[f64], u: f32| {
            let target = f64::from(u) * cdf.last().expect("checked non-empty in new");
            // First entry whose running sum exceeds the target; zero-area entries are never chosen.
            cdf.partition_point(|&c| c <= target).min(cdf.len() - 1)
        };
        let k = pick(&self.cdf, s.next_1d());
        let flat = self.g.flat as usize;
        let (tri, inst) = if k < flat {
            (self.g.indices[k], FLAT)
        } else {
            let inst = &self.g.instances[k - flat];
            let p = inst.prototype as usize;
            (self.g.prototype_indices(p)[pick(&self.prototypes[p], s.next_1d())], (k - flat) as u32)
        };
        let corners = tri.map(|i| self.g.positions[i as usize]);
        // Uniform barycentrics: b0 = 1 − √u1, b1 = u2·√u1 (pbrt-v4 §6.5.4, SampleUniformTriangle).
        let (u1, u2) = (s.next_1d(), s.next_1d());
        let su = u1.sqrt();
        let b = [1.0 - su, u2 * su, su - u2 * su];
        let p = b[0] * corners[0] + b[1] * corners[1] + b[2] * corners[2];
        let ng = (corners[1] - corners[0]).cross(corners[2] - corners[0]).try_normalize().unwrap_or(Vec3::Z);
        let p_error = barycentric_point_error(b, corners);
        if inst == FLAT {
            return SurfacePoint { p, p_error, ng };
        }
        // Placed as `Scene::interaction` places an instanced hit.
        let i = &self.g.instances[inst as usize];
        let m = i.to_world.matrix3;
        let abs = glam::Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        let t = Vec3::from(i.to_world.translation);
        SurfacePoint {
            p: i.to_world.transform_point3(p),
            p_error: Vec3::from(abs * glam::Vec3A::from(p_error)) + gamma(3) * (Vec3::from(abs * glam::Vec3A::from(p.abs())) + t.abs()),
            ng: Vec3::from(i.to_object.matrix3.transpose() * glam::Vec3A::from(ng)).try_normalize().unwrap_or(Vec3::Z),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::accel::Accel;
    use crate::mesh::shapes;

    #[test]
    fn primary_image_is_whole_tiles() {
        assert_eq!(primary_side(1), TILE);
        assert_eq!(primary_side(1_000_000), 1008);
    }

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
}
