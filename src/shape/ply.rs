//! Mitsuba's `ply` shape: a PLY file, ASCII or binary, optionally gzip-compressed (`.ply.gz`; `mesh::ply`).
//!
//! ```toml
//! [[shape]]
//! type = "ply"
//! filename = "meshes/dragon.ply"  # or .ply.gz; relative to the scene file
//! face_normals = false            # true: shade with the triangles' own normals (default false)
//! flip_tex_coords = true          # v ↦ 1 − v on the file's uvs (Mitsuba's default)
//! ```
//!
//! Its other vertex and face properties are the mesh's attributes (`vertex_color`, `face_weight`, …), read
//! by a `mesh_attribute` texture of its material (`mesh::attribute`).

use std::path::Path;

use super::{check_extension, check_mesh, flip_tex_coords, required_filename, LoadError, Plugin, Shape, ShapeModel};
use crate::mesh::attribute::Attributes;
use crate::mesh::TriangleMesh;
use crate::props::{PropError, Props};

#[derive(Clone, Debug, PartialEq)]
pub struct Ply {
    pub filename: String,
    pub face_normals: bool,
    pub flip_tex_coords: bool,
}

pub(super) const PLUGIN: Plugin = Plugin {
    name: "ply",
    keys: &["filename", "face_normals", "flip_tex_coords"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<Shape, PropError> {
    let filename = required_filename(&p, PLUGIN.name)?;
    check_extension(&filename, PLUGIN.name, &[".ply", ".ply.gz"])?;
    Ok(Shape::Ply(Ply {
        filename,
        face_normals: p.bool_or("face_normals", false)?,
        flip_tex_coords: p.bool_or("flip_tex_coords", true)?,
    }))
}

impl ShapeModel for Ply {
    fn filename(&self) -> Option<&str> {
        Some(&self.filename)
    }
    fn flat(&self) -> bool {
        self.face_normals
    }
    fn triangles(&self, base_dir: &Path) -> Result<TriangleMesh, LoadError> {
        self.triangles_with_attributes(base_dir, &|_| false).map(|(mesh, _)| mesh)
    }
    fn triangles_with_attributes(&self, base_dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), LoadError> {
        let path = base_dir.join(&self.filename);
        let (mut mesh, attributes) = crate::mesh::ply::load_ply_with_attributes(&path, keep)
            .and_then(|(mesh, a)| mesh.validate(&path).map(|()| (mesh, a)))
            .map_err(|e| LoadError::File(e.to_string()))?;
        check_mesh(&mesh).map_err(LoadError::File)?;
        for a in &attributes.kept {
            if let Some(i) = a.values.iter().position(|v| !v.is_finite()) {
                let element = if a.name.starts_with("face_") { "triangle" } else { "vertex" };
                return Err(LoadError::File(format!("{}: attribute `{}` is not finite at {element} {}", path.display(), a.name, i / usize::from(a.dim))));
            }
        }
        flip_tex_coords(&mut mesh, self.flip_tex_coords);
        Ok((mesh, attributes))
    }
}
