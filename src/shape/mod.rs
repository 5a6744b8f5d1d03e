//! Shape plugins: one file per Mitsuba shape type, each with its keys, defaults and checks (read from
//! [`Props`] by its constructor) and the triangles it makes in object space. Mitsuba 3's layout: one
//! file per plugin under `src/shapes/`, each reading its own properties.
//!
//! What every shape takes beside its own keys — `to_world`, `bsdf`, `emitter`, `flip_normals` — is read
//! once, by the scene builder (`scene::build`), which places the triangles in world space and attaches the
//! material and the area light.
//!
//! | type | keys | triangles |
//! |---|---|---|
//! | `obj`, `ply` | `filename`, `face_normals`, `flip_tex_coords` | the file's |
//! | `serialized` | `filename`, `shape_index`, `face_normals` | shape `shape_index` of the file |
//! | `rectangle` | — | [-1, 1]² at z = 0, facing +z |
//! | `cube` | — | [-1, 1]³ |
//! | `sphere` | `center`, `radius`, `rings`, `segments`, `face_normals` | analytic; tessellated with `rings`, `segments` or `face_normals` |
//! | `disk` | — | analytic: the unit disk at z = 0, facing +z (tessellated: a fan of 256 triangles) |
//! | `cylinder` | `p0`, `p1`, `radius` | analytic: an open tube (tessellated: 256 quads around) |
//!
//! **Analytic shapes** (`sphere`, `disk`, `cylinder`: [`ShapeModel::analytic`]) are intersected as the
//! quadrics they are (`accel::analytic`: no faceting in reflections), with Mitsuba 3.9.1's
//! parameterisation; one carrying an `emitter` is an area light over that surface (`light::shapes`: a
//! sphere sampled by solid angle, a disk and a cylinder by area). They are tessellated instead (their
//! `triangles`) where caustica does not yet take the analytic form: inside a `shapegroup` (instances place
//! triangles), and a sphere given `rings`, `segments` or `face_normals` (caustica's tessellation keys ask
//! for triangles). The scene builder (`scene::build`) decides.
//!
//! A new shape type is a file here (its type, its [`ShapeModel`], its `PLUGIN`) and its line in
//! `shape_types!` below.

mod cube;
mod cylinder;
mod disk;
mod obj;
mod ply;
mod rectangle;
mod serialized;
mod sphere;

use std::path::Path;

pub use crate::accel::analytic::Kind as AnalyticKind;
use crate::math::Mat4;
use crate::mesh::attribute::Attributes;
use crate::mesh::TriangleMesh;
use crate::props::{PropError, Props};

pub use disk::DISK_SEGMENTS;
pub use sphere::{SPHERE_RINGS, SPHERE_SEGMENTS};

/// A shape type as the scene files name it (`crate::props::Plugin`).
pub(crate) type Plugin = crate::props::Plugin<Shape>;

/// Why a shape's triangles could not be made.
#[derive(Debug)]
pub enum LoadError {
    /// The file the shape's `filename` names cannot be used (the message names the file).
    File(String),
    /// A key's value does not fit the file (a `serialized` file's `shape_index` past its shapes).
    Key(&'static str, String),
}

/// What the scene builder asks of a shape type.
pub(crate) trait ShapeModel {
    /// The file the shape reads, as written (relative to the scene file's directory), if any.
    fn filename(&self) -> Option<&str> {
        None
    }
    /// Whether the shape is shaded with its triangles' own normals (no interpolated normals).
    fn flat(&self) -> bool;
    /// The triangles in object space; files are found relative to `base_dir`.
    fn triangles(&self, base_dir: &Path) -> Result<TriangleMesh, LoadError>;
    /// The analytic primitive the shape is (`accel::analytic`): its kind and its object-space placement,
    /// applied before `to_world`; `None` for a shape made of triangles (the default).
    fn analytic(&self) -> Option<(AnalyticKind, Mat4)> {
        None
    }
    /// The triangles and the mesh attributes `keep` accepts (`mesh::attribute`; only PLY files have any).
    fn triangles_with_attributes(&self, base_dir: &Path, _keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), LoadError> {
        Ok((self.triangles(base_dir)?, Attributes::default()))
    }
}

/// The closed enum of shape types, its dispatch and the list of their [`Plugin`]s, from one list.
macro_rules! shape_types {
    ($($variant:ident($module:ident::$ty:ident),)*) => {
        /// A shape as its file describes it, before it is placed in the scene.
        #[derive(Clone, Debug, PartialEq)]
        pub enum Shape {
            $($variant($module::$ty),)*
        }

        /// Every shape type, in the order of the enum.
        pub(crate) const PLUGINS: &[&Plugin] = &[$(&$module::PLUGIN,)*];

        impl Shape {
            /// The Mitsuba plugin name of the shape's type.
            #[must_use]
            pub fn type_name(&self) -> &'static str {
                match self { $(Shape::$variant(_) => $module::PLUGIN.name,)* }
            }
        }

        impl ShapeModel for Shape {
            fn filename(&self) -> Option<&str> {
                match self { $(Shape::$variant(s) => s.filename(),)* }
            }
            fn flat(&self) -> bool {
                match self { $(Shape::$variant(s) => s.flat(),)* }
            }
            fn triangles(&self, base_dir: &Path) -> Result<TriangleMesh, LoadError> {
                match self { $(Shape::$variant(s) => s.triangles(base_dir),)* }
            }
            fn triangles_with_attributes(&self, base_dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), LoadError> {
                match self { $(Shape::$variant(s) => s.triangles_with_attributes(base_dir, keep),)* }
            }
            fn analytic(&self) -> Option<(AnalyticKind, Mat4)> {
                match self { $(Shape::$variant(s) => s.analytic(),)* }
            }
        }
    };
}

shape_types! {
    Obj(obj::Obj),
    Ply(ply::Ply),
    Serialized(serialized::Serialized),
    Rectangle(rectangle::Rectangle),
    Cube(cube::Cube),
    Sphere(sphere::Sphere),
    Disk(disk::Disk),
    Cylinder(cylinder::Cylinder),
}

/// The keys every shape takes beside its own, read by the scene builder.
pub(crate) const COMMON_KEYS: &[&str] = &["to_world", "bsdf", "emitter", "flip_normals"];

/// `filename`, which a file-based shape needs: as written.
fn required_filename(p: &Props<'_, ()>, kind: &str) -> Result<String, PropError> {
    match p.string("filename")? {
        Some(f) => Ok(f.to_string()),
        None => Err(PropError::new("", format!("shape type `{kind}` needs `filename`"))),
    }
}

/// Reads a mesh file at `base_dir/filename` with the reader its name picks, and checks what every later
/// stage relies on (the loaders should guarantee it; a bad file must not panic later).
fn load_file(base_dir: &Path, filename: &str) -> Result<TriangleMesh, LoadError> {
    let path = base_dir.join(filename);
    let mesh = crate::mesh::load_mesh(&path).map_err(|e| LoadError::File(e.to_string()))?;
    check_mesh(&mesh).map_err(LoadError::File)?;
    Ok(mesh)
}

/// Structural checks of a loaded mesh.
fn check_mesh(mesh: &TriangleMesh) -> Result<(), String> {
    if mesh.indices.is_empty() {
        return Err("the mesh has no triangles".into());
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("vertex {i} is not finite"));
    }
    let n = mesh.positions.len();
    if let Some(t) = mesh.indices.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
        return Err(format!("triangle {t} indexes a vertex past the {n} given"));
    }
    if mesh.normals.as_ref().is_some_and(|v| v.len() != n) {
        return Err("the mesh has a different number of normals and positions".into());
    }
    if mesh.uvs.as_ref().is_some_and(|v| v.len() != n) {
        return Err("the mesh has a different number of uvs and positions".into());
    }
    Ok(())
}

/// Mitsuba's OBJ and PLY readers' `flip_tex_coords` (obj.cpp, ply.cpp; default true): `v ↦ 1 − v`.
fn flip_tex_coords(mesh: &mut TriangleMesh, flip: bool) {
    if let (Some(uvs), true) = (&mut mesh.uvs, flip) {
        uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
    }
}

/// Checks that `filename` ends with one of `extensions` (any case).
fn check_extension(filename: &str, kind: &str, extensions: &[&str]) -> Result<(), PropError> {
    let lower = filename.to_ascii_lowercase();
    if extensions.iter().any(|e| lower.ends_with(e)) {
        return Ok(());
    }
    let shown = crate::props::shown(filename);
    Err(PropError::new("filename", format!("a `{kind}` shape needs a {} file, got {shown}", extensions.join(" or "))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn build(text: &str) -> Result<Shape, PropError> {
        let mut table: toml::Table = text.parse().unwrap();
        let kind = table.remove("type").unwrap();
        let plugin = crate::props::find(PLUGINS, kind.as_str().unwrap()).unwrap();
        (plugin.build)(Props::new(&table, plugin.keys, Vec::new()))
    }

    #[test]
    fn each_type_reads_its_keys_with_mitsubas_defaults() {
        let Shape::Sphere(s) = build("type = \"sphere\"").unwrap() else { panic!() };
        assert_eq!((s.center, s.radius, s.rings, s.segments), (crate::math::Vec3::ZERO, 1.0, SPHERE_RINGS, SPHERE_SEGMENTS));
        assert!(!s.flat());
        assert!(build("type = \"rectangle\"").unwrap().flat());
        let ply = build("type = \"ply\"\nfilename = \"a.PLY.gz\"").unwrap();
        assert_eq!(ply.filename(), Some("a.PLY.gz"));
        assert_eq!(ply.type_name(), "ply");
    }

    #[test]
    fn bad_values_are_named_by_key() {
        let e = build("type = \"sphere\"\nrings = 1").unwrap_err();
        assert_eq!((e.key.as_str(), e.message.as_str()), ("rings", "a sphere needs at least 2 rings, got 1"));
        assert_eq!(build("type = \"sphere\"\nradius = 0").unwrap_err().key, "radius");
        assert_eq!(build("type = \"sphere\"\nrings = 65536\nsegments = 65536").unwrap_err().key, "");
        let e = build("type = \"obj\"\nfilename = \"a.ply\"").unwrap_err();
        assert_eq!((e.key.as_str(), e.message.as_str()), ("filename", "a `obj` shape needs a .obj file, got \"a.ply\""));
        assert_eq!(build("type = \"serialized\"").unwrap_err().message, "shape type `serialized` needs `filename`");
    }
}
