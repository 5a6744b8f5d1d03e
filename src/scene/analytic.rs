//! Analytic shapes in the scene (`accel::analytic`: sphere, disk, cylinder): their geometry
//! ([`Scene::analytic`]) goes to the backends beside the triangles; a hit on one carries
//! `prim = triangle_count + k` ([`Scene::surface`] is the one place that reads it back). Its shading data is
//! the primitive's surface (Mitsuba's `compute_surface_interaction` for the shape: point re-projected,
//! normal, uv; `∂p/∂u`, `∂p/∂v` for textures, normal and bump maps and the anisotropic frame), its material
//! the shape's. Analytic shapes have no mesh attributes (a material reading one is refused at load) and
//! `prim_index` 0 (Mitsuba's for a shape of one primitive).

use super::{Scene, SurfaceInteraction};
use crate::accel::{Hit, FLAT};
use crate::bsdf::HitFrame;
use crate::math::{Frame, Ray};

/// What the scene keeps of an analytic shape beside its geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyticShading {
    /// Index into `Scene::materials`.
    pub material: u32,
    /// The shape's index in the scene file's order (the `shape_index` AOV).
    pub shape: u32,
    /// The material may be anisotropic: the shading frame follows `∂p/∂u` (`Scene::interaction`).
    pub anisotropic: bool,
}

/// What a hit's `prim` names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// A triangle of the soup.
    Triangle(u32),
    /// Analytic shape `k` (`Scene::analytic[k]`).
    Analytic(u32),
}

impl Scene {
    /// What `prim` (a hit's, an interaction's) names: triangles first, then the analytic shapes.
    #[inline(always)]
    #[must_use]
    pub fn surface(&self, prim: u32) -> Surface {
        let triangles = self.mesh.indices.len() as u32;
        if prim < triangles { Surface::Triangle(prim) } else { Surface::Analytic(prim - triangles) }
    }

    /// [`Scene::interaction`] on analytic shape `k`.
    #[inline(never)]
    pub(super) fn analytic_interaction(&self, ray: &Ray, hit: &Hit, k: u32) -> SurfaceInteraction {
        let shading = self.analytic_shading[k as usize];
        let s = self.analytic[k as usize].surface(ray, hit.t);
        let si = SurfaceInteraction {
            p: s.p,
            p_error: s.p_error,
            ng: s.n,
            ns: s.n,
            frame: Frame::from_normal(s.n),
            uv: s.uv,
            prim: hit.prim,
            inst: FLAT,
            material: shading.material,
        };
        if shading.anisotropic { self.with_tangent_frame(si) } else { si }
    }

    /// [`Scene::hit_frame`] on analytic shape `k`: Mitsuba's `∂p/∂u`, `∂p/∂v` of the shape.
    pub(super) fn analytic_hit_frame(&self, si: &SurfaceInteraction, k: u32) -> HitFrame {
        let (dp_du, dp_dv) = self.analytic[k as usize].derivatives(si.p);
        HitFrame { frame: si.frame, ng: si.ng, dp_du, dp_dv }
    }
}
