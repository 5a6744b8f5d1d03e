//! Mitsuba's `sphere` shape: analytic (`accel::analytic`; Mitsuba places the unit sphere by `to_world ·
//! translate(center) · scale(radius)` and intersects the sphere of centre `to_world·0` and radius
//! `|to_world·x̂|`, so a non-uniform scale gives the sphere of the x axis's scale, as in Mitsuba 3.9.1,
//! which warns), unless it is given `rings`, `segments` or `face_normals` — caustica's tessellation keys:
//! then it is triangles (`mesh::shapes::sphere`: poles on ±z, Mitsuba's uvs, the exact sphere normals at
//! the vertices). Spheres in a shapegroup are tessellated too (`crate::shape`); an emitting analytic sphere
//! is an area light sampled by solid angle (`light::shapes`).
//!
//! ```toml
//! [[shape]]
//! type = "sphere"
//! center = [0, 1, 0]   # default the origin
//! radius = 0.5         # default 1
//! # rings = 128        # tessellated: latitude bands (≥ 2; default below)
//! # segments = 256     # tessellated: longitude bands (≥ 3)
//! # face_normals = true # tessellated, facets shaded flat
//! ```

use std::path::Path;

use super::{AnalyticKind, LoadError, Plugin, Shape, ShapeModel};
use crate::math::{Mat4, Vec3};
use crate::mesh::{shapes, TriangleMesh};
use crate::props::{PropError, Props};

/// Default tessellation: 128 rings × 256 segments = 65,024 triangles. The chord error is at most
/// radius·(1 − cos(π/128)) = 3.0e-4·radius (a conservative bound on the distance between the triangles and
/// the true sphere); shading uses the exact per-vertex normals interpolated, so reflections stay smooth.
pub const SPHERE_RINGS: u32 = 128;
pub const SPHERE_SEGMENTS: u32 = 256;
/// Upper limit on the triangles of one tessellated sphere (2·rings·segments).
const MAX_TRIANGLES: u64 = 1 << 26;

#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub rings: u32,
    pub segments: u32,
    pub face_normals: bool,
    /// `rings`, `segments` or `face_normals` was given: the sphere is triangles (module docs).
    pub tessellated: bool,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "sphere",
    keys: &["center", "radius", "rings", "segments", "face_normals"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<Shape, PropError> {
    let rings = p.u32_or("rings", SPHERE_RINGS)?;
    if rings < 2 {
        return Err(PropError::new("rings", format!("a sphere needs at least 2 rings, got {rings}")));
    }
    let segments = p.u32_or("segments", SPHERE_SEGMENTS)?;
    if segments < 3 {
        return Err(PropError::new("segments", format!("a sphere needs at least 3 segments, got {segments}")));
    }
    if 2 * u64::from(rings) * u64::from(segments) > MAX_TRIANGLES {
        return Err(PropError::new("", format!("rings × segments = {rings} × {segments} gives more than 2^26 triangles")));
    }
    Ok(Shape::Sphere(Sphere {
        center: p.vec3("center")?.unwrap_or(Vec3::ZERO),
        radius: p.positive_or("radius", 1.0, "the radius")?,
        rings,
        segments,
        face_normals: p.bool_or("face_normals", false)?,
        tessellated: ["rings", "segments", "face_normals"].iter().any(|k| p.has(k)),
    }))
}

impl ShapeModel for Sphere {
    fn flat(&self) -> bool {
        self.face_normals
    }
    fn triangles(&self, _: &Path) -> Result<TriangleMesh, LoadError> {
        Ok(shapes::sphere(self.center, self.radius, self.rings, self.segments))
    }
    fn analytic(&self) -> Option<(AnalyticKind, Mat4)> {
        (!self.tessellated).then(|| (AnalyticKind::Sphere, Mat4::from_translation(self.center) * Mat4::from_scale(Vec3::splat(self.radius))))
    }
}
