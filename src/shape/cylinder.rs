//! Mitsuba's `cylinder` shape: an open tube (no caps) of `radius` from `p0` to `p1` (defaults: radius 1,
//! from the origin to +z), then `to_world`; outward normals, Mitsuba's uvs (`cylinder.cpp`: `u = φ/2π`,
//! `v` along the axis from 0 at `p0` to 1 at `p1`). Mitsuba places its unit cylinder by
//! `translate(p0)·to_frame(frame of (p1 − p0))·scale(radius, radius, |p1 − p0|)`, the frame being the one
//! `math::Frame::from_normal` builds (Duff et al. 2017, as Mitsuba's `coordinate_system`), so `u` starts
//! where Mitsuba's does. Analytic (`accel::analytic`: intersected in the unit cylinder's space, so any
//! affine `to_world` works, non-uniform scales included; with an emitter, an area light over it:
//! `light::shapes`); in a shapegroup, tessellated
//! with [`CYLINDER_SEGMENTS`] quads around (`mesh::shapes::cylinder`), shaded with the exact normals at the
//! vertices.
//!
//! ```toml
//! [[shape]]
//! type = "cylinder"
//! p0 = [0, 0, 0]
//! p1 = [0, 2, 0]
//! radius = 0.25
//! ```

use std::path::Path;

use super::{AnalyticKind, LoadError, Plugin, Shape, ShapeModel};
use crate::math::{Frame, Mat3, Mat4, Vec3};
use crate::mesh::{shapes, TriangleMesh};
use crate::props::{PropError, Props};

/// Quads around the axis: the chord error is at most radius·(1 − cos(π/256)) = 7.5e-5·radius.
pub const CYLINDER_SEGMENTS: u32 = 256;

#[derive(Clone, Debug, PartialEq)]
pub struct Cylinder {
    pub p0: Vec3,
    pub p1: Vec3,
    pub radius: f32,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "cylinder",
    keys: &["p0", "p1", "radius"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<Shape, PropError> {
    let p0 = p.vec3("p0")?.unwrap_or(Vec3::ZERO);
    let p1 = p.vec3("p1")?.unwrap_or(Vec3::Z);
    let length = (p1 - p0).length();
    if !(length > 0.0 && length.is_finite()) {
        return Err(PropError::new("p1", format!("the cylinder's axis p1 − p0 has length {length}; it must be > 0 and finite")));
    }
    let radius = p.positive_or("radius", 1.0, "the radius")?;
    Ok(Shape::Cylinder(Cylinder { p0, p1, radius }))
}

impl Cylinder {
    /// The unit cylinder's placement before `to_world`.
    fn placement(&self) -> Mat4 {
        let d = self.p1 - self.p0;
        let length = d.length();
        let frame = Frame::from_normal(d / length);
        let rotation = Mat4::from_mat3(Mat3::from_cols(frame.s, frame.t, frame.n));
        Mat4::from_translation(self.p0) * rotation * Mat4::from_scale(Vec3::new(self.radius, self.radius, length))
    }
}

impl ShapeModel for Cylinder {
    fn flat(&self) -> bool {
        false
    }
    fn analytic(&self) -> Option<(AnalyticKind, Mat4)> {
        Some((AnalyticKind::Cylinder, self.placement()))
    }
    fn triangles(&self, _: &Path) -> Result<TriangleMesh, LoadError> {
        let mut mesh = shapes::cylinder(CYLINDER_SEGMENTS);
        let m = self.placement();
        // A rotation after a scale that is uniform across the normals' plane: normals only rotate.
        let rotation = Mat3::from_mat4(m).inverse().transpose();
        for p in &mut mesh.positions {
            *p = m.transform_point3(*p);
        }
        for n in mesh.normals.iter_mut().flatten() {
            *n = (rotation * *n).normalize();
        }
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p0_p1_and_radius_place_the_unit_cylinder() {
        let c = Cylinder { p0: Vec3::new(1.0, 2.0, 3.0), p1: Vec3::new(1.0, 5.0, 3.0), radius: 0.5 };
        let mesh = c.triangles(Path::new(".")).unwrap();
        for (p, n) in mesh.positions.iter().zip(mesh.normals.as_ref().unwrap()) {
            let radial = Vec3::new(p.x - 1.0, 0.0, p.z - 3.0);
            assert!((radial.length() - 0.5).abs() < 1e-5, "{p}");
            assert!((2.0 - 1e-5..=5.0 + 1e-5).contains(&p.y), "{p}");
            assert!(n.abs_diff_eq(radial / 0.5, 1e-4), "{n} at {p}");
        }
    }
}
