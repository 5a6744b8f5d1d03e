//! Mitsuba 3.9.1's `mesh_attribute` texture (src/textures/mesh_attribute.cpp): the value of a per-vertex or
//! per-face attribute of the mesh that was hit (a PLY file's vertex colours: `vertex_color`), times `scale`.
//!
//! ```toml
//! reflectance = { type = "mesh_attribute", name = "vertex_color" }       # the PLY's r,g,b (or red,green,blue)
//! weight = { type = "mesh_attribute", name = "face_weight", scale = 0.5 } # scale: default 1
//! ```
//!
//! Rules, as Mitsuba's `Mesh::eval_attribute` (src/render/mesh.cpp, `interpolate_attribute` in
//! include/mitsuba/render/mesh.h): a `vertex_…` attribute is interpolated over the hit triangle with the
//! hit's barycentrics, `(1 − u − v)·a₀ + u·a₁ + v·a₂`; a `face_…` attribute is constant per face (a PLY
//! polygon's fan triangles share its value). A one-value attribute gives its value in all three channels;
//! a three-value one its colour. `name` must contain `vertex_` or `face_` (Mitsuba's check, a substring
//! test). Which attributes a mesh has, and how they are named, is the PLY reader's (`mesh::attribute`).
//!
//! The values live in the scene, one [`AttributeTable`] per attribute name the materials read, holding
//! only the shapes whose material reads it (a scene without `mesh_attribute` keeps nothing); a hit finds
//! them through [`MeshPoint`]. A shape whose material reads an attribute it lacks is an error of the scene
//! layer, as in Mitsuba.
//!
//! One deviation: a one-number parameter (a roughness, a blend weight) on a three-value attribute reads
//! its [`luminance`](super::luminance) here; Mitsuba's scalar variants stop there with an error
//! (`eval_attribute_1`: "requested but had size 3").

use super::TextureSpec;
use crate::math::{Vec2, Vec3};
use crate::props::{Plugin, PropError, Props, Textured};

/// A `mesh_attribute` texture: which attribute, its scale, and the scene's table of its values.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// The attribute's name (`vertex_color`, `face_weight`).
    pub name: String,
    pub scale: f32,
    /// Index of the [`AttributeTable`] of `name` among the scene's (set by the scene layer).
    pub table: u32,
}

/// Where a `mesh_attribute` texture is read: the scene's tables, its triangles' vertex indices, the hit
/// triangle and its barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct MeshPoint<'a> {
    pub tables: &'a [AttributeTable],
    pub indices: &'a [[u32; 3]],
    pub prim: u32,
    /// Embree's `(u, v)`: the weights of the triangle's second and third vertices.
    pub bary: Vec2,
}

impl MeshAttribute {
    /// The colour at `at` (Mitsuba's `eval`), zero where there is no mesh (an emitter's texture, which the
    /// scene refuses) or the triangle's shape was not given the attribute (the scene refuses that too).
    #[inline]
    #[must_use]
    pub fn eval_rgb(&self, at: Option<&MeshPoint<'_>>) -> Vec3 {
        self.value(at).map_or(Vec3::ZERO, |(v, _)| v * self.scale)
    }

    /// One number at `at` (Mitsuba's `eval_1`): a one-value attribute's value, a colour's luminance (module
    /// documentation).
    #[inline]
    #[must_use]
    pub fn eval_1(&self, at: Option<&MeshPoint<'_>>) -> f32 {
        self.value(at).map_or(0.0, |(v, dim)| if dim == 1 { v.x } else { super::luminance(v) } * self.scale)
    }

    #[inline]
    fn value(&self, at: Option<&MeshPoint<'_>>) -> Option<(Vec3, u8)> {
        let at = at?;
        at.tables.get(self.table as usize)?.eval(at.indices, at.prim, at.bary)
    }

    /// What the plugins' constructors see before the meshes are read (Mitsuba has no `mean` for this
    /// texture: its `plastic` refuses it): the values taken in `[0, scale]`, mean half of it. The scene
    /// layer replaces it by [`AttributeTable::summary`] once the shapes are loaded.
    #[must_use]
    pub fn summary_before_load(&self) -> Textured {
        let (lo, hi) = (self.scale.min(0.0), self.scale.max(0.0));
        Textured { mean: Vec3::splat(0.5 * self.scale), mean_1: 0.5 * self.scale, max: Vec3::splat(hi), min: Vec3::splat(lo) }
    }
}

/// One shape's part of an [`AttributeTable`]: its triangles `[first_prim, end_prim)` of the scene, its
/// vertices from `first_vertex`, and where its values start.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    first_prim: u32,
    end_prim: u32,
    first_vertex: u32,
    offset: u32,
    /// Values per element in the file (1 or 3).
    dim: u8,
}

/// The values of one attribute over the shapes that read it: per vertex (`vertex_…`) or per triangle
/// (`face_…`), colours as they are, one value repeated in three channels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AttributeTable {
    pub name: String,
    spans: Vec<Span>,
    values: Vec<Vec3>,
}

impl AttributeTable {
    #[must_use]
    pub fn new(name: &str) -> Self {
        Self { name: name.to_string(), ..Self::default() }
    }

    /// Whether the attribute is per face (its name starts with `face_`; else per vertex).
    #[must_use]
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }

    /// Adds a shape's values: its triangles start at `first_prim` of the scene, its vertices at
    /// `first_vertex`; `values` has `dim` (1 or 3) numbers per vertex, or per triangle for a face attribute.
    /// Shapes are added in the order of their triangles.
    pub fn push_shape(&mut self, first_prim: u32, triangles: u32, first_vertex: u32, dim: u8, values: &[f32]) {
        debug_assert!(dim == 1 || dim == 3);
        debug_assert!(self.spans.last().is_none_or(|s| s.end_prim <= first_prim));
        let offset = self.values.len() as u32;
        self.spans.push(Span { first_prim, end_prim: first_prim + triangles, first_vertex, offset, dim });
        if dim == 1 {
            self.values.extend(values.iter().map(|&v| Vec3::splat(v)));
        } else {
            self.values.extend(values.chunks_exact(3).map(Vec3::from_slice));
        }
    }

    /// The value at barycentrics `bary` of triangle `prim` (whose vertices `indices` gives) and the
    /// attribute's number of values, or `None` when the triangle's shape is not in the table.
    #[inline]
    #[must_use]
    pub fn eval(&self, indices: &[[u32; 3]], prim: u32, bary: Vec2) -> Option<(Vec3, u8)> {
        let k = self.spans.partition_point(|s| s.end_prim <= prim);
        let s = self.spans.get(k).filter(|s| s.first_prim <= prim)?;
        if self.per_face() {
            return Some((self.values[(s.offset + prim - s.first_prim) as usize], s.dim));
        }
        let [a, b, c] = indices[prim as usize].map(|i| self.values[(s.offset + i - s.first_vertex) as usize]);
        Some(((1.0 - bary.x - bary.y) * a + bary.x * b + bary.y * c, s.dim))
    }

    /// Whether no shape was added.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.spans.is_empty()
    }

    /// The per-channel mean, mean number, maximum and minimum of the values times `scale` (interpolated
    /// values lie between their corners'), or `None` when no shape was added.
    #[must_use]
    pub fn summary(&self, scale: f32) -> Option<Textured> {
        if self.values.is_empty() {
            return None;
        }
        let n = self.values.len() as f32;
        let (mut sum, mut max, mut min) = (Vec3::ZERO, Vec3::splat(f32::NEG_INFINITY), Vec3::splat(f32::INFINITY));
        let mut sum_1 = 0.0;
        for (k, s) in self.spans.iter().enumerate() {
            let end = self.spans.get(k + 1).map_or(self.values.len(), |t| t.offset as usize);
            for v in &self.values[s.offset as usize..end] {
                let v = *v * scale;
                sum += v;
                max = max.max(v);
                min = min.min(v);
                sum_1 += if s.dim == 1 { v.x } else { super::luminance(v) };
            }
        }
        Some(Textured { mean: sum / n, mean_1: sum_1 / n, max, min })
    }

    /// The bytes its values take.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        (self.values.len() * std::mem::size_of::<Vec3>() + self.spans.len() * std::mem::size_of::<Span>()) as u64
    }
}

pub(super) const PLUGIN: Plugin<TextureSpec> = Plugin { name: "mesh_attribute", keys: &["name", "scale"], nested: &[], build };

fn build(p: Props<'_, ()>) -> Result<TextureSpec, PropError> {
    let Some(name) = p.string("name")? else {
        return Err(PropError::new("name", "missing: a mesh_attribute texture reads the attribute named by `name` (vertex_… or face_…)"));
    };
    // Mitsuba's check is a substring test (`find`), not a prefix.
    if !name.contains("vertex_") && !name.contains("face_") {
        return Err(PropError::new("name", format!("{} is not a mesh attribute's name: it must start with \"vertex_\" or \"face_\"", crate::props::shown(name))));
    }
    let scale = p.float_or("scale", 1.0)?;
    Ok(TextureSpec::MeshAttribute { name: name.to_string(), scale })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_values_interpolate_by_the_barycentrics_and_face_values_are_constant() {
        // Two shapes: triangles 0..2 (vertices 0..4) without the attribute, triangles 2..4 (vertices 4..8) with it.
        let indices = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let mut t = AttributeTable::new("vertex_color");
        let colours = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5];
        t.push_shape(2, 2, 4, 3, &colours);
        let a = MeshAttribute { name: "vertex_color".into(), scale: 2.0, table: 0 };
        let at = |prim, u, v| MeshPoint { tables: std::slice::from_ref(&t), indices: &indices, prim, bary: Vec2::new(u, v) };
        assert_eq!(a.eval_rgb(Some(&at(2, 0.0, 0.0))), Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(a.eval_rgb(Some(&at(2, 0.25, 0.5))), Vec3::new(0.5, 0.5, 1.0));
        assert_eq!(a.eval_rgb(Some(&at(3, 0.0, 1.0))), Vec3::splat(1.0));
        // A triangle of a shape the table does not hold, and no mesh at all: zero.
        assert_eq!(a.eval_rgb(Some(&at(1, 0.2, 0.2))), Vec3::ZERO);
        assert_eq!(a.eval_rgb(None), Vec3::ZERO);
        // A one-number parameter on a colour reads its luminance.
        assert!((a.eval_1(Some(&at(3, 0.0, 1.0))) - 2.0 * super::super::luminance(Vec3::splat(0.5))).abs() < 1e-6);

        let mut f = AttributeTable::new("face_weight");
        f.push_shape(0, 1, 0, 1, &[0.25]);
        f.push_shape(2, 2, 4, 1, &[0.5, 0.75]);
        let w = MeshAttribute { name: "face_weight".into(), scale: 1.0, table: 0 };
        let at = |prim, u, v| MeshPoint { tables: std::slice::from_ref(&f), indices: &indices, prim, bary: Vec2::new(u, v) };
        assert_eq!(w.eval_1(Some(&at(0, 0.3, 0.3))), 0.25);
        assert_eq!(w.eval_1(Some(&at(1, 0.3, 0.3))), 0.0);
        assert_eq!(w.eval_1(Some(&at(3, 0.9, 0.05))), 0.75);
        assert_eq!(w.eval_rgb(Some(&at(2, 0.1, 0.1))), Vec3::splat(0.5));
        let s = f.summary(2.0).unwrap();
        assert_eq!((s.max, s.min, s.mean_1), (Vec3::splat(1.5), Vec3::splat(0.5), 1.0));
    }

    #[test]
    fn the_name_must_name_a_vertex_or_face_attribute() {
        let build = |text: &str| {
            let table: toml::Table = text.parse().unwrap();
            (PLUGIN.build)(Props::new(&table, PLUGIN.keys, Vec::new()))
        };
        assert_eq!(build("name = \"vertex_color\"").unwrap(), TextureSpec::MeshAttribute { name: "vertex_color".into(), scale: 1.0 });
        assert_eq!(build("name = \"my_face_w\"\nscale = 3").unwrap(), TextureSpec::MeshAttribute { name: "my_face_w".into(), scale: 3.0 });
        assert_eq!(build("name = \"color\"").unwrap_err().key, "name");
        assert_eq!(build("scale = 2").unwrap_err().key, "name");
    }
}
