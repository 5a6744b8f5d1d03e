//! The one function that turns a backend's preliminary hit `(t, prim, u, v)` into shading data, and the
//! rules for spawning rays from a surface. Both intersection backends go through it, so they shade
//! identically (Mitsuba 3's `compute_surface_interaction`; pbrt-v4 `Triangle::InteractionFromIntersection`).
//!
//! A hit on an instance is shaded from its prototype's triangle in object space, then placed in world
//! space as Mitsuba's `Instance::compute_surface_interaction` does (src/shapes/instance.cpp): the point by
//! `to_world`, the geometric and shading normals by its inverse transpose (renormalised), `∂p/∂u`, `∂p/∂v`
//! as vectors; texture coordinates and mesh attributes are the prototype's. The point's error bound is
//! carried through the transform as pbrt-v4 carries a `Point3fi` (`Transform::operator()`): `|M|·δ` plus
//! `γ₃·(|M|·|p| + |t|)`.

use std::borrow::Cow;

use super::{Scene, Surface};
use crate::bsdf::{Bsdf, HitFrame, ParamMut};
use crate::accel::{Hit, FLAT};
use crate::texture::{MeshPoint, TexEval};
use crate::math::{barycentric_point_error, gamma, offset_ray_origin, spawn_t_min, Frame, Ray, Vec2, Vec3};

/// Shadow rays stop this fraction short of their target (pbrt-v4's `ShadowEpsilon`), so the surface the
/// target lies on does not occlude it.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// Shading data at a ray–surface hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceInteraction {
    /// Hit point rebuilt from the barycentrics: `p = (1−u−v)·p0 + u·p1 + v·p2` (on an analytic shape, the
    /// hit re-projected onto its surface: module `analytic`).
    pub p: Vec3,
    /// Conservative absolute error bound of `p` per axis (`math::barycentric_point_error`), for
    /// `offset_ray_origin`.
    pub p_error: Vec3,
    /// Unit geometric normal, `normalize((p1−p0)×(p2−p0))`.
    pub ng: Vec3,
    /// Unit shading normal: interpolated vertex normals (or `ng` for flat triangles and degenerate
    /// interpolations), flipped into `ng`'s hemisphere.
    pub ns: Vec3,
    /// Shading frame around `ns`.
    pub frame: Frame,
    /// The hit's barycentrics `(u, v)` (Embree's convention: weights of p1 and p2); on an analytic shape,
    /// its texture coordinates (Mitsuba's uv).
    pub uv: Vec2,
    /// Triangle index in the scene's soup (the prototype's triangle on an instance), or past the triangles
    /// an analytic shape ([`Scene::surface`] tells which).
    pub prim: u32,
    /// The instance hit (`accel::FLAT` on the flat soup).
    pub inst: u32,
    /// Index into `Scene::bsdfs`.
    pub material: u32,
}

impl SurfaceInteraction {
    /// A ray leaving the surface in direction `dir`, its origin offset to the side `dir` points into.
    #[inline(always)]
    #[must_use]
    pub fn spawn_ray(&self, dir: Vec3) -> Ray {
        Ray::segment(offset_ray_origin(self.p, self.p_error, self.ng, dir), dir, spawn_t_min(self.p_error, dir), f32::INFINITY)
    }

    /// A shadow ray towards `p_target`: `dir = p_target − origin` (not normalised), `t ∈ [0, 1 − ε]` with
    /// ε = [`SHADOW_EPSILON`], so only occluders strictly between the two points are found.
    #[inline(always)]
    #[must_use]
    pub fn spawn_ray_to(&self, p_target: Vec3) -> Ray {
        let origin = offset_ray_origin(self.p, self.p_error, self.ng, p_target - self.p);
        let dir = p_target - origin;
        Ray::segment(origin, dir, spawn_t_min(self.p_error, dir), 1.0 - SHADOW_EPSILON)
    }
}

impl Scene {
    /// Shading data for `hit` on `ray` (the hit must come from an accelerator built over `self.mesh`).
    #[inline(always)]
    #[must_use]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        if let Surface::Analytic(k) = self.surface(hit.prim) {
            return self.analytic_interaction(ray, hit, k);
        }
        // One record per triangle (positions, normals, material): one cache miss, not an index then vertices.
        let tri = self.shading(hit.prim);
        let [p0, p1, p2] = tri.p;
        let (u, v) = (hit.u, hit.v);
        let b0 = 1.0 - u - v;
        let p = b0 * p0 + u * p1 + v * p2;
        let p_error = barycentric_point_error([b0, u, v], [p0, p1, p2]);
        let interpolated = if tri.flat { None } else { (b0 * tri.n[0] + u * tri.n[1] + v * tri.n[2]).try_normalize() };
        if hit.inst != FLAT {
            let si = self.instanced(ray, hit, p, p_error, tri.ng, interpolated, tri.material);
            return if tri.anisotropic { self.with_tangent_frame(si) } else { si };
        }
        // A zero-area triangle has no normal; face the ray so that spawned rays still leave the surface.
        let ng = tri.ng.unwrap_or_else(|| -ray.dir.normalize_or(Vec3::Z));
        let mut ns = interpolated.unwrap_or(ng);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let si = SurfaceInteraction {
            p,
            p_error,
            ng,
            ns,
            frame: Frame::from_normal(ns),
            uv: Vec2::new(u, v),
            prim: hit.prim,
            inst: FLAT,
            material: tri.material,
        };
        if tri.anisotropic { self.with_tangent_frame(si) } else { si }
    }

    /// `si` with Mitsuba's shading frame (`SurfaceInteraction::initialize_sh_frame`,
    /// include/mitsuba/render/interaction.h): the tangent is `∂p/∂u` ([`Scene::hit_frame`]) made orthogonal to
    /// the shading normal by Gram–Schmidt, the bitangent `n × s`; where `∂p/∂u` is zero or along `n`, the
    /// frame around `n` alone. Only an anisotropic material's hits need it (`TriangleShading::anisotropic`):
    /// turning the frame about `n` changes nothing else's response, and skipping it keeps every other
    /// material's frame, and its images, as they were.
    #[inline(never)]
    pub(super) fn with_tangent_frame(&self, mut si: SurfaceInteraction) -> SurfaceInteraction {
        let n = si.ns;
        let dp_du = self.hit_frame(&si).dp_du;
        if let Some(s) = (dp_du - n * n.dot(dp_du)).try_normalize() {
            si.frame = Frame { s, t: n.cross(s), n };
        }
        si
    }

    /// [`Scene::interaction`] on an instance: the object-space point (and its error), geometric normal and
    /// interpolated normal placed in world space (module docs).
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn instanced(&self, ray: &Ray, hit: &Hit, p: Vec3, p_error: Vec3, ng: Option<Vec3>, interpolated: Option<Vec3>, material: u32) -> SurfaceInteraction {
        let inst = &self.instances[hit.inst as usize];
        let m = inst.to_world.matrix3;
        let abs = glam::Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        let t = Vec3::from(inst.to_world.translation);
        let p_world = inst.to_world.transform_point3(p);
        let p_error = Vec3::from(abs * glam::Vec3A::from(p_error)) + gamma(3) * (Vec3::from(abs * glam::Vec3A::from(p.abs())) + t.abs());
        // Normals by the inverse transpose: the transpose of `to_object`'s linear part.
        let normal_matrix = inst.to_object.matrix3.transpose();
        let place = |n: Vec3| Vec3::from(normal_matrix * glam::Vec3A::from(n)).try_normalize();
        let ng = ng.and_then(place).unwrap_or_else(|| -ray.dir.normalize_or(Vec3::Z));
        let mut ns = interpolated.and_then(place).unwrap_or(ng);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        SurfaceInteraction {
            p: p_world,
            p_error,
            ng,
            ns,
            frame: Frame::from_normal(ns),
            uv: Vec2::new(hit.u, hit.v),
            prim: hit.prim,
            inst: hit.inst,
            material,
        }
    }

    /// The BSDF of the material at `si`, its textures evaluated there (`crate::material`): the material's
    /// own BSDF, not a copy, when it has no texture.
    #[inline]
    #[must_use]
    pub fn bsdf_at(&self, si: &SurfaceInteraction) -> Cow<'_, Bsdf> {
        let material = &self.materials[si.material as usize];
        if !material.is_textured() {
            return Cow::Borrowed(material.template());
        }
        let uv = self.tex_uv(si);
        // The point on the mesh, for the mesh attributes (only in a scene that has them).
        let on_mesh = !self.attributes.is_empty() && self.surface(si.prim) == Surface::Triangle(si.prim);
        let mesh = on_mesh.then(|| MeshPoint { tables: &self.attributes, indices: &self.mesh.indices, prim: si.prim, bary: si.uv });
        let at = TexEval { uv, mesh };
        // The hit's geometry, made only for a parameter that reads it (a normal or height map), once.
        let mut hit = None;
        material.bsdf_at(|texture, param| {
            let t = &self.textures[texture as usize];
            match param {
                ParamMut::Frame(frame, rule) => {
                    let hit = hit.get_or_insert_with(|| self.hit_frame(si));
                    *frame = rule.perturbation(|| t.eval_rgb(at), || t.eval_1_grad(uv), hit);
                }
                param => param.set(|| t.eval_rgb(at), || t.eval_1(at)),
            }
        })
    }

    /// The geometry at `si` a perturbed shading frame reads: its frame, geometric normal and the surface's
    /// derivatives `∂p/∂u`, `∂p/∂v` — Mitsuba's mesh rule (`Mesh::compute_surface_interaction`,
    /// src/render/mesh.cpp): with texture coordinates, the solution of `p1 − p0 = ∂p/∂u·Δu₁ + ∂p/∂v·Δv₁`,
    /// `p2 − p0 = ∂p/∂u·Δu₂ + ∂p/∂v·Δv₂`, or, where the coordinates are degenerate (a zero determinant),
    /// `coordinate_system(ng)`; without them, the barycentric parameterisation, `p1 − p0` and `p2 − p0`.
    #[must_use]
    pub fn hit_frame(&self, si: &SurfaceInteraction) -> HitFrame {
        if let Surface::Analytic(k) = self.surface(si.prim) {
            return self.analytic_hit_frame(si, k);
        }
        let prim = si.prim as usize;
        let [p0, p1, p2] = self.shading(si.prim).p;
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        let (dp_du, dp_dv) = match self.mesh.uvs.as_deref().filter(|_| self.tri_has_uv[prim]) {
            None => (dp0, dp1),
            Some(uvs) => {
                let [uv0, uv1, uv2] = self.mesh.indices[prim].map(|k| uvs[k as usize]);
                let (duv0, duv1) = (uv1 - uv0, uv2 - uv0);
                let det = duv0.x * duv1.y - duv0.y * duv1.x;
                if det != 0.0 {
                    let inv = 1.0 / det;
                    ((duv1.y * dp0 - duv0.y * dp1) * inv, (duv0.x * dp1 - duv1.x * dp0) * inv)
                } else {
                    let f = Frame::from_normal(si.ng);
                    (f.s, f.t)
                }
            }
        };
        let (dp_du, dp_dv) = match self.instances.get(si.inst as usize) {
            Some(inst) => (inst.to_world.transform_vector3(dp_du), inst.to_world.transform_vector3(dp_dv)),
            None => (dp_du, dp_dv),
        };
        HitFrame { frame: si.frame, ng: si.ng, dp_du, dp_dv }
    }

    /// The texture coordinates at `si`: its triangle's vertex coordinates interpolated by its barycentrics,
    /// or the barycentrics themselves where its shape has none (Mitsuba's `Mesh::compute_surface_interaction`).
    #[inline]
    #[must_use]
    pub fn tex_uv(&self, si: &SurfaceInteraction) -> Vec2 {
        let prim = si.prim as usize;
        // An analytic shape's `si.uv` are its texture coordinates (module `analytic`).
        if self.surface(si.prim) != Surface::Triangle(si.prim) || !self.tri_has_uv[prim] {
            return si.uv;
        }
        let uvs = self.mesh.uvs.as_deref().expect("the scene's mesh has uvs");
        crate::texture::interpolate_uv(self.mesh.indices[prim].map(|k| uvs[k as usize]), si.uv.x, si.uv.y)
    }

    /// Reads the shading records of a batch of hits before any of them is shaded, so that their cache
    /// misses overlap one another instead of each stalling its own `interaction` (a scalar shading loop
    /// is too long for the processor to run ahead into the next hit's miss). The loads touch both cache
    /// lines of each record: its first position and, 92 bytes on, its material.
    pub fn warm_shading(&self, hits: &[Option<Hit>]) {
        let triangles = self.triangle_count() as u32;
        let touched = hits.iter().flatten().filter(|h| h.prim < triangles).fold(0u32, |acc, hit| {
            let tri = self.shading(hit.prim);
            acc ^ tri.p[0].x.to_bits() ^ tri.material
        });
        std::hint::black_box(touched);
    }
}
