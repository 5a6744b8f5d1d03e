//! Mitsuba's `obj` shape: a Wavefront OBJ file (polygons as fans; `mesh::obj`).
//!
//! ```toml
//! [[shape]]
//! type = "obj"
//! filename = "meshes/bunny.obj"   # relative to the scene file
//! face_normals = false            # true: shade with the triangles' own normals (default false)
//! flip_tex_coords = true          # v ↦ 1 − v on the file's uvs (Mitsuba's default)
//! ```

use std::path::Path;

use super::{check_extension, flip_tex_coords, load_file, required_filename, LoadError, Plugin, Shape, ShapeModel};
use crate::mesh::TriangleMesh;
use crate::props::{PropError, Props};

#[derive(Clone, Debug, PartialEq)]
pub struct Obj {
    pub filename: String,
    pub face_normals: bool,
    pub flip_tex_coords: bool,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "obj",
    keys: &["filename", "face_normals", "flip_tex_coords"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<Shape, PropError> {
    let filename = required_filename(&p, PLUGIN.name)?;
    check_extension(&filename, PLUGIN.name, &[".obj"])?;
    Ok(Shape::Obj(Obj {
        filename,
        face_normals: p.bool_or("face_normals", false)?,
        flip_tex_coords: p.bool_or("flip_tex_coords", true)?,
    }))
}

impl ShapeModel for Obj {
    fn filename(&self) -> Option<&str> {
        Some(&self.filename)
    }
    fn flat(&self) -> bool {
        self.face_normals
    }
    fn triangles(&self, base_dir: &Path) -> Result<TriangleMesh, LoadError> {
        let mut mesh = load_file(base_dir, &self.filename)?;
        flip_tex_coords(&mut mesh, self.flip_tex_coords);
        Ok(mesh)
    }
}
