//! The mesh attributes the materials read (`mesh_attribute` textures, `crate::texture::MeshAttribute`): one
//! `texture::AttributeTable` per attribute name, holding the values of only the shapes whose material reads
//! it, so that a scene without such textures keeps nothing and reads nothing beyond its triangles.
//!
//! ```toml
//! [[shape]]
//! type = "ply"
//! filename = "meshes/bunny.ply"            # with vertex colours: vertex_color
//! bsdf = { type = "diffuse", reflectance = { type = "mesh_attribute", name = "vertex_color" } }
//! ```
//!
//! A shape whose material reads an attribute it does not have is an error naming the shape and the
//! attribute (Mitsuba's `Shape::eval_attribute` stops there too), as is an attribute of other than 1 or 3
//! values (a colour with alpha: Mitsuba's `eval_attribute` refuses it). Once the shapes are loaded, each
//! material that reads attributes decides its `material::Facts` again from their values.

use super::error::{ErrorContext, SceneError};
use crate::material::Material;
use crate::mesh::attribute::Attributes;
use crate::texture::{AttributeTable, Texture};

/// The tables being filled while the shapes load.
pub(crate) struct SceneAttributes {
    tables: Vec<AttributeTable>,
    /// Per material, the tables it reads.
    by_material: Vec<Vec<u32>>,
}

impl SceneAttributes {
    /// A table per attribute name the `textures` read (each texture's `table` set to it), and which tables
    /// each material reads.
    pub(crate) fn new(materials: &[Material], textures: &mut [Texture]) -> Self {
        let mut tables: Vec<AttributeTable> = Vec::new();
        for t in textures.iter_mut() {
            if let Texture::MeshAttribute(a) = t {
                a.table = match tables.iter().position(|t| t.name == a.name) {
                    Some(i) => i as u32,
                    None => {
                        tables.push(AttributeTable::new(&a.name));
                        (tables.len() - 1) as u32
                    }
                };
            }
        }
        let by_material = materials
            .iter()
            .map(|m| {
                let mut read: Vec<u32> = m
                    .bindings()
                    .iter()
                    .filter_map(|b| match &textures[b.texture as usize] {
                        Texture::MeshAttribute(a) => Some(a.table),
                        _ => None,
                    })
                    .collect();
                read.sort_unstable();
                read.dedup();
                read
            })
            .collect();
        Self { tables, by_material }
    }

    /// Whether material `material` reads attribute `name` (what a shape of it keeps of its file's).
    pub(crate) fn reads(&self, material: u32, name: &str) -> bool {
        self.by_material[material as usize].iter().any(|&t| self.tables[t as usize].name == name)
    }

    /// Adds the attributes a shape of material `material` has (`attributes`, as its file gave them) at its
    /// place in the scene: triangles from `first_prim`, vertices from `first_vertex`. `key` and `what` (its
    /// type and file) name the shape in errors.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_shape(
        &mut self,
        ctx: &ErrorContext,
        key: &str,
        what: &str,
        material: u32,
        first_prim: u32,
        first_vertex: u32,
        triangles: u32,
        attributes: &Attributes,
    ) -> Result<(), SceneError> {
        for &t in &self.by_material[material as usize] {
            let table = &mut self.tables[t as usize];
            let Some(a) = attributes.get(&table.name) else {
                let has = if attributes.names.is_empty() {
                    "it has none (caustica reads mesh attributes from PLY files)".to_string()
                } else {
                    format!("it has {}", attributes.names.join(", "))
                };
                return Err(ctx.key_error(key, format!("{what} has no attribute `{}`, which its material reads (a `mesh_attribute` texture); {has}", table.name)));
            };
            if a.dim != 1 && a.dim != 3 {
                return Err(ctx.key_error(key, format!("{what}: attribute `{}` has {} values per element; a `mesh_attribute` texture reads attributes of 1 or 3 (Mitsuba's eval_attribute)", a.name, a.dim)));
            }
            table.push_shape(first_prim, triangles, first_vertex, a.dim, &a.values);
        }
        Ok(())
    }

    /// The tables (in the order of the textures' `table` indices), after deciding again the facts of each
    /// material that reads them from their values (`material::Material::refine_facts`).
    pub(crate) fn finish(self, materials: &mut [Material], textures: &[Texture]) -> Vec<AttributeTable> {
        if self.tables.is_empty() {
            return self.tables;
        }
        for (m, read) in materials.iter_mut().zip(&self.by_material) {
            if read.is_empty() {
                continue;
            }
            m.refine_facts(|t| match &textures[t as usize] {
                Texture::MeshAttribute(a) => self.tables[a.table as usize].summary(a.scale).unwrap_or_else(|| a.summary_before_load()),
                other => other.summary(),
            });
        }
        self.tables
    }
}
