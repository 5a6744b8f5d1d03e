//! Mitsuba's `serialized` shape: one shape of a file in Mitsuba's zlib-compressed mesh format
//! (`mesh::serialized`). Any file name: the format id inside tells, as Mitsuba reads it.
//!
//! ```toml
//! [[shape]]
//! type = "serialized"
//! filename = "meshes/scene.serialized"
//! shape_index = 0        # which shape of the file (default 0, its first)
//! face_normals = false   # true: shade with the triangles' own normals (default false)
//! ```

use std::path::Path;

use super::{check_mesh, required_filename, LoadError, Plugin, Shape, ShapeModel};
use crate::error::MeshError;
use crate::mesh::TriangleMesh;
use crate::props::{PropError, Props};

#[derive(Clone, Debug, PartialEq)]
pub struct Serialized {
    pub filename: String,
    pub shape_index: u32,
    pub face_normals: bool,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "serialized",
    keys: &["filename", "shape_index", "face_normals"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<Shape, PropError> {
    Ok(Shape::Serialized(Serialized {
        filename: required_filename(&p, PLUGIN.name)?,
        shape_index: p.u32_or("shape_index", 0)?,
        face_normals: p.bool_or("face_normals", false)?,
    }))
}

impl ShapeModel for Serialized {
    fn filename(&self) -> Option<&str> {
        Some(&self.filename)
    }
    fn flat(&self) -> bool {
        self.face_normals
    }
    fn triangles(&self, base_dir: &Path) -> Result<TriangleMesh, LoadError> {
        let path = base_dir.join(&self.filename);
        let mesh = crate::mesh::serialized::load_serialized(&path, self.shape_index)
            .map_err(|e| match e {
                MeshError::ShapeIndexOutOfRange { .. } => LoadError::Key("shape_index", e.to_string()),
                _ => LoadError::File(e.to_string()),
            })?
            .mesh;
        check_mesh(&mesh).map_err(LoadError::File)?;
        Ok(mesh)
    }
}
