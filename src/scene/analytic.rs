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

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::accel::{build_accel, BackendKind};
    use crate::math::{Vec2, Vec3};

    const SCENE: &str = r#"
[sensor]
film = { width = 8, height = 8 }
[[shape]]
type = "rectangle"
[[shape]]
type = "sphere"
center = [0, 0, 3]
radius = 0.5
bsdf = { type = "roughconductor", alpha_u = 0.1, alpha_v = 0.3 }
[[shape]]
type = "sphere"
rings = 8
segments = 16
center = [5, 0, 0]
[[shape]]
type = "disk"
flip_normals = true
to_world = { translate = [0, 0, -2] }
[[shape]]
type = "disk"
to_world = { translate = [0, 0, -4] }
emitter = { type = "area", radiance = 1 }
[[shape]]
type = "cylinder"
to_world = { translate = [0, 3, 0] }
"#;

    /// Which shapes are analytic (module `crate::shape`'s rule), what their hits name and how they shade.
    #[test]
    fn analytic_shapes_are_built_hit_and_shaded() {
        let scene = Scene::from_toml_str(SCENE, Path::new("."), Path::new("a.toml")).unwrap();
        let kinds: Vec<_> = scene.analytic.iter().map(|a| a.kind.name()).collect();
        assert_eq!(kinds, ["sphere", "disk", "disk", "cylinder"]);
        assert_eq!(scene.analytic_shading.iter().map(|s| s.shape).collect::<Vec<_>>(), [1, 3, 4, 5]);
        // The rectangle and the tessellated sphere are triangles.
        let tessellated = crate::mesh::shapes::sphere(Vec3::ZERO, 1.0, 8, 16).triangle_count();
        assert_eq!(scene.triangle_count(), 2 + tessellated);
        assert!(scene.bounds.contains(Vec3::new(0.0, 0.0, 3.5)) && scene.bounds.contains(Vec3::new(1.0, 4.0, 0.0)));
        let n = scene.triangle_count() as u32;
        assert_eq!((scene.surface(n - 1), scene.surface(n + 3)), (Surface::Triangle(n - 1), Surface::Analytic(3)));
        // The emitting disk is an area light over its analytic surface, primitive n + 2.
        assert_eq!((scene.lights.light_of_prim(n + 2), scene.lights.light_of_prim(n + 1)), (Some(0), None));
        let accel = build_accel(BackendKind::Bvh, &scene.geometry()).unwrap();
        // The sphere from above: its top, Mitsuba's uv (θ = 0), the anisotropic frame along ∂p/∂u.
        let ray = Ray::new(Vec3::new(0.3, 0.0, 10.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = accel.intersect(&ray).unwrap();
        assert_eq!((hit.prim, scene.shape_of(hit.prim)), (n, (1, 0)));
        let si = scene.interaction(&ray, &hit);
        assert!(((si.p - Vec3::new(0.0, 0.0, 3.0)).length() - 0.5).abs() < 1e-6 && si.ng == si.ns && si.ng.z > 0.5, "{si:?}");
        assert_eq!(scene.tex_uv(&si), si.uv);
        let frame = scene.hit_frame(&si);
        assert!(frame.dp_du.y > 0.0 && si.frame.s.dot(frame.dp_du.normalize()) > 0.999, "{frame:?}");
        assert!(si.spawn_ray(Vec3::Z).origin.z > si.p.z && accel.intersect(&si.spawn_ray(Vec3::Z)).is_none());
        // Through the sphere: the refracted ray finds the far side, not the near one.
        let inside = accel.intersect(&si.spawn_ray(-Vec3::Z)).unwrap();
        assert_eq!(inside.prim, n);
        assert!((scene.interaction(&si.spawn_ray(-Vec3::Z), &inside).p.z - 2.6).abs() < 1e-5);
        // The flipped disk faces −z; its uv is (r, φ/2π).
        let ray = Ray::new(Vec3::new(0.0, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = accel.intersect(&Ray { t_min: 3.0, ..ray }).unwrap();
        let si = scene.interaction(&ray, &hit);
        assert!(si.ng == -Vec3::Z && (si.uv - Vec2::new(0.25, 0.25)).abs().max_element() < 1e-6, "{si:?}");
    }

    #[test]
    fn a_mesh_attribute_on_an_analytic_shape_is_refused() {
        let text = "[[shape]]\ntype = \"sphere\"\nbsdf = { type = \"diffuse\", reflectance = { type = \"mesh_attribute\", name = \"vertex_color\" } }\n";
        let e = Scene::from_toml_str(text, Path::new("."), Path::new("a.toml")).err().unwrap().to_string();
        assert!(e.contains("the sphere shape has no attribute `vertex_color`"), "{e}");
    }
}
