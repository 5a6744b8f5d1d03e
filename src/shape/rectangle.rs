//! Mitsuba's `rectangle` shape: the square [-1, 1]² at z = 0 facing +z (`to_world` places and sizes it),
//! flat, with Mitsuba's uvs (`mesh::shapes::rectangle`).
//!
//! ```toml
//! [[shape]]
//! type = "rectangle"
//! to_world = { scale = [2, 1, 1] }
//! ```

use std::path::Path;

use super::{LoadError, Plugin, Shape, ShapeModel};
use crate::mesh::{shapes, TriangleMesh};
use crate::props::{PropError, Props};

#[derive(Clone, Debug, PartialEq)]
pub struct Rectangle;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "rectangle",
    keys: &[],
    nested: &[],
    build,
};

fn build(_: Props<'_, ()>) -> Result<Shape, PropError> {
    Ok(Shape::Rectangle(Rectangle))
}

impl ShapeModel for Rectangle {
    fn flat(&self) -> bool {
        true
    }
    fn triangles(&self, _: &Path) -> Result<TriangleMesh, LoadError> {
        Ok(shapes::rectangle())
    }
}
