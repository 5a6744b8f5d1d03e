//! Scene files (TOML, Mitsuba 3 vocabulary) → [`Scene`]: one triangle soup with a material per triangle
//! (the flattened shapes in world space, then each instanced shapegroup's shapes once, in object space,
//! placed by instances), the analytic shapes (sphere, disk, cylinder), the lights, the camera and the
//! render settings.
//!
//! Every table rejects unknown keys (`deny_unknown_fields`) and keys that do not apply to its `type`. Errors
//! ([`SceneError`]) name the file, the key path (`shape[3].bsdf.reflectance`) with its line, and the
//! problem. Relative file names are relative to the scene file's directory.
//!
//! ```toml
//! [integrator]                 # optional; defaults shown (module `settings`)
//! max_depth = -1               # -1 = unlimited (Russian roulette from rr_depth)
//! rr_depth = 5
//! samples_per_pixel = 16
//! seed = 0
//! hide_emitters = false        # true: camera rays see no emitter (Mitsuba's flag; `integrator::path`)
//! [integrator.caustics]        # optional
//! estimator = "mis"            # pt (default) | pm | mis
//! photons = 200000             # optional
//! knn = 50
//! max_radius = 0.1             # optional
//!
//! [sensor]                     # required (see `crate::camera`)
//! type = "perspective"         # perspective (default) | thinlens | orthographic (keys: `crate::camera`)
//! fov = 39.3077                # degrees, in (0, 180); or focal_length = "50mm" (the default)
//! fov_axis = "smaller"         # x (default) | y | diagonal | smaller | larger
//! # near_clip, far_clip        (Mitsuba's clip planes: depths along the viewing axis, 0.01 and 10⁴ by default)
//! to_world = { look_at = { origin = [0, 0, 3.9], target = [0, 0, 0], up = [0, 1, 0] } }
//! film = { width = 256, height = 256, crop = [0, 0, 256, 128] }   # default 768×576; crop optional
//!
//! [bsdf.white]                 # named materials, referenced by name; types and keys: `crate::bsdf`, one file each
//! type = "diffuse"
//! reflectance = [0.8, 0.8, 0.8]   # or one number (gray)
//!
//! [bsdf.floor]
//! type = "blendbsdf"
//! weight = 0.5
//! bsdf_0 = "white"
//! bsdf_1 = { type = "roughconductor", distribution = "ggx", alpha = 0.08 }   # default: beckmann
//!
//! [[shape]]
//! type = "rectangle"           # obj | ply | serialized | rectangle | cube | sphere
//! to_world = [ { rotate = { axis = [1, 0, 0], angle = -90 } }, { translate = [0, -1, 0] } ]
//! bsdf = "white"               # a name, or an inline table; absent: diffuse 0.5, black if it emits (Mitsuba)
//!
//! [[shape]]
//! type = "rectangle"
//! to_world = [ { scale = [0.25, 0.25, 1] }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 0.99, 0] } ]
//! bsdf = { type = "diffuse", reflectance = 0 }
//! emitter = { type = "area", radiance = [15, 15, 15] }   # one-sided, along the geometric normal
//!
//! [[shape]]
//! type = "sphere"
//! center = [0.4, -0.35, 0.25]  # default [0, 0, 0]
//! radius = 0.3                 # default 1
//! # rings = 128, segments = 256   (caustica extension: a tessellated sphere; defaults shown)
//! bsdf = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
//!
//! [[shape]]
//! type = "obj"                 # or "ply" (.ply / .ply.gz)
//! filename = "assets/models/teapot.obj"
//! face_normals = false         # true: flat shading (also allowed on spheres)
//! flip_normals = false         # any shape: reverse orientation (and emission side)
//! bsdf = { type = "twosided", bsdf = { type = "conductor" } }   # perfect mirror, both sides (one-sided alone)
//!
//! [[shape]]
//! type = "serialized"          # Mitsuba's serialized mesh, versions 3 and 4 (`crate::mesh::serialized`)
//! filename = "meshes/scene.serialized"
//! shape_index = 2              # which shape of the file, default 0 (the first)
//! face_normals = false         # as for obj / ply
//!
//! [shapegroup.pillar]         # Mitsuba's shapegroup: shapes stored once, rendered only where instances
//! shape = [ { type = "cube", bsdf = "white" } ]   # place them (module `instances`)
//!
//! [[shape]]
//! type = "instance"
//! shapegroup = "pillar"
//! to_world = [ { scale = [0.1, 1, 0.1] }, { translate = [0.7, 0, -0.7] } ]   # any invertible affine map
//!
//! [[emitter]]
//! type = "envmap"
//! filename = "assets/envmaps/studio.exr"
//! scale = 1.0
//! to_world = { rotate = { axis = [0, 1, 0], angle = 90 } }
//!
//! [[emitter]]
//! type = "constant"
//! radiance = 0.05              # default 1
//!
//! [[emitter]]                  # delta lights (`crate::emitter`): point, spot, directional
//! type = "point"
//! position = [0, 1.5, 0]       # or to_world, not both
//! intensity = 2                # W/sr, default 1
//!
//! [[emitter]]
//! type = "spot"                # cutoff_angle (20), beam_width (¾ cutoff), degrees; shines along +z of to_world
//! intensity = 10
//! to_world = { look_at = { origin = [0, 2, 0], target = [0, 0, 0], up = [0, 0, 1] } }
//!
//! [[emitter]]
//! type = "directional"
//! direction = [1, -2, 0.5]     # the way the light travels; or to_world (its +z), not both
//! irradiance = 1.5             # W/m², default 1
//! ```
//!
//! **Transforms** (`transform`): `to_world` is one table or a list; in a list **the first element is
//! applied first** (Mitsuba's XML order), so the floor above is rotated, then translated.
//!
//! **Shapes** (`crate::shape`: one file per type; `build` places them): rectangles (the square [-1,1]² facing +z) and cubes are flat-shaded; spheres,
//! disks and cylinders are analytic (module `analytic`, `accel::analytic`: Mitsuba's quadrics and uvs), except
//! with an emitter, in a shapegroup, or a sphere given `rings`, `segments` or `face_normals` (then tessellated:
//! 128 rings × 256 segments by default, chord error ≤ 3.0e-4·radius, smooth normals); meshes
//! (obj, ply, serialized) use their vertex normals (angle-weighted normals are computed when the file has none) unless
//! `face_normals = true`. Normals transform with the inverse transpose, and the winding of mirrored shapes
//! is swapped so the geometric normal follows the shading normal. Each emitting shape becomes one area
//! light; emitters with zero radiance, zero area or zero scale are left out.
//! A shape lying more than 2¹⁴ times its own size from the origin is refused (`precision`: f32 coordinates
//! cannot hold it there; the error states the limit).

mod analytic;
pub mod aov;
mod attributes;
mod build;
mod convert;
mod desc;
mod error;
mod instances;
mod interaction;
mod material;
mod note;
mod plugins;
pub mod precision;
pub mod settings;
mod shading;
mod spans;
mod textures;
mod transform;
mod validate;
mod xml;

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

pub use convert::convert_scene;
pub use error::SceneError;
pub use analytic::{AnalyticShading, Surface};
pub use interaction::{SurfaceInteraction, SHADOW_EPSILON};
pub use note::{NoteKind, SceneNote};
pub use xml::unsupported::Unsupported;
pub use shading::TriangleShading;
pub use settings::{CausticsSettings, Estimator, IntegratorSettings};
pub use transform::look_at;

use crate::accel::analytic::Analytic;
use crate::accel::{Geometry, Instance};
use crate::material::Material;
use crate::texture::{AttributeTable, Texture};
pub use crate::camera::Camera;
use crate::light::LightSet;
use crate::math::Aabb;
use crate::mesh::TriangleMesh;

/// A loaded scene.
pub struct Scene {
    /// The scene file (as given to [`Scene::load`] / the `name_for_errors` of [`Scene::from_toml_str`]).
    pub path: PathBuf,
    /// The flattened soup: prim = triangle index; `normals` and `uvs` always `Some` (per vertex).
    pub mesh: TriangleMesh,
    /// Index into `bsdfs`, per triangle.
    pub tri_material: Vec<u32>,
    /// Per triangle: true when the shading normal is the geometric normal (face_normals, rectangle, cube).
    pub tri_flat: Vec<bool>,
    /// Per triangle: `mesh`, `tri_material` and `tri_flat` at the triangle, in one record (module
    /// `shading`, with the triangle's geometric normal), read by [`Scene::interaction`]; made at load, from
    /// the fields above.
    shading: Vec<TriangleShading>,
    /// Per shape of the scene file, in its order, the index of its first triangle (ascending): a
    /// triangle's shape for the `shape_index` and `prim_index` AOVs ([`Scene::shape_of`]); the shapes of
    /// the placed shapegroups follow the other shapes.
    pub shape_first_triangle: Vec<u32>,
    /// Triangles `[0, flat_triangles)` of `mesh` are the flat soup, in world space; the rest are the
    /// prototypes', in object space (module `instances`).
    pub flat_triangles: u32,
    /// Per shapegroup (in the order of their ids), its triangles in `mesh` (empty when no instance
    /// places it).
    pub prototypes: Vec<Range<u32>>,
    /// The instances: a prototype and its placement.
    pub instances: Vec<Instance>,
    /// The analytic shapes (sphere, disk, cylinder: module `analytic`), in world space; a hit on shape `k`
    /// has `prim = triangle_count + k` ([`Scene::surface`]).
    pub analytic: Vec<Analytic>,
    /// Per analytic shape: its material, its index in the file, its frame rule.
    pub analytic_shading: Vec<AnalyticShading>,
    /// The materials in use (named ones once each, inline ones once per shape, the default once), indexed
    /// by `tri_material`; [`Scene::bsdf_at`] evaluates one at a hit.
    pub materials: Vec<Material>,
    /// The textures the materials use (`Material::bindings` index them).
    pub textures: Vec<Texture>,
    /// Bytes of the images the scene keeps: the textures' texels (each image once, `texture::ImageCache`)
    /// and the environment maps' radiance and sampling tables (`EnvMap::memory_bytes`).
    pub image_bytes: u64,
    /// The mesh attributes the `mesh_attribute` textures read, one table per attribute name, holding only
    /// the shapes whose material reads it (module `attributes`; empty in a scene without them).
    pub attributes: Vec<AttributeTable>,
    /// Per triangle: whether its shape has texture coordinates (in `mesh.uvs`, per vertex, zeros for the
    /// shapes without); where it has none, a hit's are its barycentrics, as in Mitsuba ([`Scene::tex_uv`]).
    pub tri_has_uv: Vec<bool>,
    pub lights: LightSet,
    pub camera: Camera,
    pub integrator: IntegratorSettings,
    /// Bounds of the flat soup's vertices, the instances' and the analytic shapes' world boxes.
    pub bounds: Aabb,
    /// What the scene files say that was read but not used as written (module `note`).
    pub notes: Vec<SceneNote>,
}

/// How a scene file is read.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Values of the scene's parameters (`$name` in Mitsuba XML; Mitsuba's `-D name=value`).
    pub params: BTreeMap<String, String>,
    /// The command line chooses the estimator (`--estimator`): an integrator the scene names that caustica
    /// does not have is replaced by its path tracer, with a note, instead of refused.
    pub replace_integrator: bool,
}

/// The text of the scene file named on the command line (TOML or XML), read as an included file is read
/// (`xml::read_regular`): a regular file of at most `xml::MAX_INCLUDE_BYTES` (256 MiB), so that a device,
/// a FIFO or a huge file is refused instead of read without bound.
pub(crate) fn read_scene_file(path: &Path) -> Result<String, SceneError> {
    let read = |source| SceneError::Read { file: path.to_path_buf(), source };
    xml::read_regular(path, xml::MAX_INCLUDE_BYTES).map_err(|e| match e {
        xml::Unreadable::Io(source) => read(source),
        xml::Unreadable::Directory | xml::Unreadable::NotRegular => read(std::io::Error::other(format!("it is {e}; a scene must be a regular file"))),
        xml::Unreadable::TooLarge { .. } => read(std::io::Error::other(format!("it is larger than {} MiB, the bound on a scene file", xml::MAX_INCLUDE_BYTES >> 20))),
    })
}

impl Scene {
    /// Reads and builds the scene file at `path`: Mitsuba 3 XML when its name ends in `.xml` (any case),
    /// TOML otherwise; file names inside are relative to its directory.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Self::load_with_params(path, &BTreeMap::new())
    }

    /// [`Scene::load`] with values for the scene's parameters (`$name` in Mitsuba XML; Mitsuba's `-D
    /// name=value`). TOML scenes have no parameters: giving any is an error.
    pub fn load_with_params(path: &Path, params: &BTreeMap<String, String>) -> Result<Scene, SceneError> {
        Self::load_with(path, &LoadOptions { params: params.clone(), ..LoadOptions::default() })
    }

    /// [`Scene::load`] as `options` say.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
        let params = &options.params;
        let text = read_scene_file(path)?;
        let base_dir = path.parent().unwrap_or_else(|| Path::new("."));
        if is_xml(path) {
            let convert = xml::ConvertOptions { replace_integrator: options.replace_integrator };
            return Self::from_xml_with(&text, base_dir, path, params, convert);
        }
        if let Some(name) = params.keys().next() {
            return Err(SceneError::Key {
                file: path.to_path_buf(),
                key: format!("-D {name}"),
                line: None,
                message: "scene parameters apply to Mitsuba XML scenes (.xml) only".into(),
            });
        }
        Self::from_toml_str(&text, base_dir, path)
    }

    /// Builds a scene from TOML text; `base_dir` resolves relative file names, `name_for_errors` names the
    /// text in errors (and becomes `Scene::path`).
    pub fn from_toml_str(text: &str, base_dir: &Path, name_for_errors: &Path) -> Result<Scene, SceneError> {
        build::build_scene(text, base_dir, name_for_errors)
    }

    /// Builds a scene from Mitsuba 3 XML text (module `xml`), with values for its parameters; `base_dir`
    /// resolves relative file names and includes, `name_for_errors` names the text in errors.
    pub fn from_xml_str(
        text: &str,
        base_dir: &Path,
        name_for_errors: &Path,
        params: &BTreeMap<String, String>,
    ) -> Result<Scene, SceneError> {
        Self::from_xml_with(text, base_dir, name_for_errors, params, xml::ConvertOptions::default())
    }

    fn from_xml_with(
        text: &str,
        base_dir: &Path,
        name_for_errors: &Path,
        params: &BTreeMap<String, String>,
        options: xml::ConvertOptions,
    ) -> Result<Scene, SceneError> {
        let read = || xml::read_str(text, name_for_errors, base_dir, params, options);
        let (description, places, notes) = read()?;
        let again = || read().map(|(description, places, _)| (description, places));
        let mut scene = build::build_xml_scene(description, places, again, base_dir, name_for_errors)?;
        scene.notes = notes;
        Ok(scene)
    }

    /// Whether any material in use has a delta lobe (else no caustic paths exist and a photon pass is useless).
    #[must_use]
    pub fn has_delta_bsdf(&self) -> bool {
        self.materials.iter().any(|m| m.facts().has_delta)
    }

    /// Bounds of the triangles and analytic shapes whose material has a delta lobe (empty when there are none): a photon
    /// whose first ray misses this box cannot become a caustic photon (method.md §2).
    #[must_use]
    pub fn delta_bounds(&self) -> Aabb {
        let delta_box = |range: Range<u32>| {
            let mut b = Aabb::EMPTY;
            for t in range {
                if self.materials[self.tri_material[t as usize] as usize].facts().has_delta {
                    for &v in &self.mesh.indices[t as usize] {
                        b = b.grow(self.mesh.positions[v as usize]);
                    }
                }
            }
            b
        };
        let prototypes: Vec<Aabb> = self.prototypes.iter().map(|r| delta_box(r.clone())).collect();
        let triangles = self.instances.iter().fold(delta_box(0..self.flat_triangles), |b, i| b.union(i.world_bounds(prototypes[i.prototype as usize])));
        let delta = |s: &&AnalyticShading| self.materials[s.material as usize].facts().has_delta;
        self.analytic.iter().zip(&self.analytic_shading).filter(|(_, s)| delta(s)).fold(triangles, |b, (a, _)| b.union(a.bounds()))
    }

    /// The geometry the intersection backends are built from (`accel::build_accel`).
    #[must_use]
    pub fn geometry(&self) -> Geometry<'_> {
        Geometry { positions: &self.mesh.positions, indices: &self.mesh.indices, flat: self.flat_triangles, prototypes: &self.prototypes, instances: &self.instances, analytic: &self.analytic }
    }

    /// Triangle `prim`'s shading record.
    #[must_use]
    pub fn shading(&self, prim: u32) -> &TriangleShading {
        &self.shading[prim as usize]
    }

    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.mesh.triangle_count()
    }

    /// Triangle `prim`'s shape (its index in the scene file's order, from 0) and its index within that
    /// shape (Mitsuba's `prim_index`); an analytic shape's index and 0.
    #[must_use]
    pub fn shape_of(&self, prim: u32) -> (u32, u32) {
        if let Surface::Analytic(k) = self.surface(prim) {
            return (self.analytic_shading[k as usize].shape, 0);
        }
        let shape = self.shape_first_triangle.partition_point(|&first| first <= prim).saturating_sub(1);
        (shape as u32, prim - self.shape_first_triangle.get(shape).copied().unwrap_or(0))
    }
}

/// Whether `path` names a Mitsuba XML scene (extension `.xml`, any case).
#[must_use]
pub fn is_xml(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}
