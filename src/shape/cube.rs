//! Mitsuba's `cube` shape: the cube [-1, 1]³ with outward faces (`to_world` places and sizes it), flat,
//! with Mitsuba's uvs (`mesh::shapes::cube`).
//!
//! ```toml
//! [[shape]]
//! type = "cube"
//! to_world = { scale = 0.5 }
//! ```

use std::path::Path;

use super::{LoadError, Plugin, Shape, ShapeModel};
use crate::mesh::{shapes, TriangleMesh};
use crate::props::{PropError, Props};

#[derive(Clone, Debug, PartialEq)]
pub struct Cube;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "cube",
    keys: &[],
    nested: &[],
    build,
};

fn build(_: Props<'_, ()>) -> Result<Shape, PropError> {
    Ok(Shape::Cube(Cube))
}

impl ShapeModel for Cube {
    fn flat(&self) -> bool {
        true
    }
    fn triangles(&self, _: &Path) -> Result<TriangleMesh, LoadError> {
        Ok(shapes::cube())
    }
}
