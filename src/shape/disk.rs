//! Mitsuba's `disk` shape: the unit disk at z = 0 facing +z (`to_world` places and sizes it: any affine
//! map), flat, with Mitsuba's uvs (`disk.cpp`: `u = r`, `v = φ/2π`). Analytic (`accel::analytic`; with an
//! emitter, an area light over it: `light::shapes`); in a shapegroup, a fan of [`DISK_SEGMENTS`] triangles (`mesh::shapes::disk`).
//!
//! ```toml
//! [[shape]]
//! type = "disk"
//! to_world = [{ scale = 0.3 }, { translate = [0, 2, 0] }]
//! emitter = { type = "area", radiance = 10 }
//! ```

use std::path::Path;

use super::{AnalyticKind, LoadError, Plugin, Shape, ShapeModel};
use crate::math::Mat4;
use crate::mesh::{shapes, TriangleMesh};
use crate::props::{PropError, Props};

/// Triangles of the fan: the polygon's area is `n/2·sin(2π/n)`, π·(1 − 1.0e-4) for 256, and its rim lies
/// within 1 − cos(π/256) = 7.5e-5 of the circle.
pub const DISK_SEGMENTS: u32 = 256;

#[derive(Clone, Debug, PartialEq)]
pub struct Disk;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "disk",
    keys: &[],
    nested: &[],
    build,
};

fn build(_: Props<'_, ()>) -> Result<Shape, PropError> {
    Ok(Shape::Disk(Disk))
}

impl ShapeModel for Disk {
    fn flat(&self) -> bool {
        true
    }
    fn triangles(&self, _: &Path) -> Result<TriangleMesh, LoadError> {
        Ok(shapes::disk(DISK_SEGMENTS))
    }
    fn analytic(&self) -> Option<(AnalyticKind, Mat4)> {
        Some((AnalyticKind::Disk, Mat4::IDENTITY))
    }
}
