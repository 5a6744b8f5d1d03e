//! From the parsed file to a [`Scene`], in three phases so that a missing file is only reported once
//! everything else in the file has been checked:
//!
//! 1. **plan** — every value is range-checked, transforms composed, materials resolved; no file is touched;
//! 2. **files** — every referenced file (meshes, environment maps) must exist;
//! 3. **load** — meshes are loaded or generated, placed in world space and flattened into one triangle
//!    soup (per-triangle material and flat flag); spheres, disks and cylinders become analytic shapes
//!    where `crate::shape`'s rule says so (`analytic_shape`); each emitting shape becomes one [`AreaLight`]
//!    (over its triangles, or over its analytic surface, `light::shapes`, numbered after all triangles). The
//!    shapes of the shapegroups that instances place follow, in their group's object space, each group's
//!    triangles a prototype (module `instances`).
//!
//! Placement (pbrt-v4 §3.10, Mitsuba's `Mesh`): points by `to_world`, normals by its inverse transpose. A
//! transform with negative determinant (a mirror) reverses the geometric normal `(p1−p0)×(p2−p0)` relative to
//! the transformed shading normals, so the winding of such shapes is swapped to keep the two on the same
//! side (the geometric normal is what one-sided emitters emit along). `flip_normals` negates the normals and
//! swaps the winding too.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::desc::{FilmDesc, PluginDesc, SceneFile, SensorDesc, ShapeDesc, ToWorld, TransformOp};
use super::error::{ErrorContext, SceneError};
use super::attributes::SceneAttributes;
use super::instances;
use super::material::Materials;
use super::textures::Textures;
use super::plugins::{self, Role};
use super::settings::{check, CausticsSettings, IntegratorSettings};
use super::spans::{join_index, join_key, SpanIndex};
use super::transform::{invertible_linear_part, to_world_matrix, to_world_value};
use super::xml::Places;
use super::{AnalyticShading, Scene};
use crate::camera::{self, Camera, CameraError, Projection};
use crate::film::{filter, PixelFilter};
use crate::accel::analytic::Analytic;
use crate::accel::Instance;
use crate::light::{AnalyticShape, AreaLight, EnvMap, Light, LightError, LightSet};
use crate::math::{Aabb, Mat3, Mat4, Vec2, Vec3};
use crate::emitter::{self, Emitter};
use crate::mesh::attribute::Attributes;
use crate::mesh::TriangleMesh;
use crate::shape::{self, LoadError, Shape, ShapeModel};
use crate::texture::{Texture, BARYCENTRIC_UVS};

/// A checked shape, ready to load.
struct ShapePlan {
    key: String,
    shape: Shape,
    to_world: Mat4,
    linear: Mat3,
    det: f32,
    flip: bool,
    material: u32,
    /// An area emitter's radiance.
    radiance: Option<PlannedRadiance>,
}

/// An area emitter's radiance: one value, or a texture read at each point's uv (`light::AreaLight`).
enum PlannedRadiance {
    Constant(Vec3),
    Texture(Texture),
}

/// A checked environment emitter.
enum EmitterPlan {
    Env {
        key: String,
        path: PathBuf,
        scale: f32,
        to_world: Mat4,
    },
    Constant {
        radiance: Vec3,
    },
    /// A light built whole (point, spot, directional, sunsky: no file to load); `None` when it emits nothing.
    Built(Option<Light>),
    /// A projector and the texture it projects (its `irradiance`).
    Projector(emitter::Projector, Texture),
}

/// Parses and builds a TOML scene; `name` is the file name used in errors, `base_dir` resolves relative paths.
pub(crate) fn build_scene(text: &str, base_dir: &Path, name: &Path) -> Result<Scene, SceneError> {
    let mut ctx = ErrorContext {
        file: name.to_path_buf(),
        spans: SpanIndex::default(),
        places: None,
    };
    let description = match toml::from_str::<toml::Table>(text) {
        Ok(description) => description,
        Err(e) => {
            ctx.spans = SpanIndex::lines_only(text);
            return Err(ctx.syntax(&e));
        }
    };
    // The text is parsed once: the description is deserialised as it is (100,000 shapes: 5.5 s through a
    // second and third reading of the text, see `spans`). Only when that fails is the text deserialised,
    // whose errors carry the span of the key at fault; the key paths and lines of later errors come from
    // the span index, made at the first error.
    ctx.spans = SpanIndex::deferred(text);
    match description.try_into::<SceneFile>() {
        Ok(file) => build_file(file, &ctx, base_dir, name),
        Err(_) => build_described(text, &ctx, base_dir, name),
    }
}

/// Builds a scene from the description read from Mitsuba XML (`xml`): the same deserialiser and builder
/// as a TOML file, with errors reported at the places the keys came from. `again` reads the description
/// once more, for the error of one that does not deserialise.
pub(crate) fn build_xml_scene(
    description: toml::Table,
    places: Places,
    again: impl FnOnce() -> Result<(toml::Table, Places), SceneError>,
    base_dir: &Path,
    name: &Path,
) -> Result<Scene, SceneError> {
    // The description is deserialised as it is, and consumed (linear, no text: 200,000 shapes took 3.4 s through
    // TOML text). Only when that fails does it go through its TOML text, whose deserialiser's errors carry the
    // span of the key at fault (its path, and so its place in the XML): the same deserialiser on the same
    // values, so it fails there too, with the key path.
    let Ok(file) = description.try_into::<SceneFile>() else {
        let (description, places) = again()?;
        let text = toml::to_string(&description).map_err(|e| SceneError::Key {
            file: name.to_path_buf(),
            key: String::new(),
            line: None,
            message: format!("the scene description cannot be written as TOML: {e}"),
        })?;
        let ctx = ErrorContext { file: name.to_path_buf(), spans: SpanIndex::new(&text), places: Some(places) };
        return build_described(&text, &ctx, base_dir, name);
    };
    let ctx = ErrorContext { file: name.to_path_buf(), spans: SpanIndex::default(), places: Some(places) };
    build_file(file, &ctx, base_dir, name)
}

/// Deserialises the description `text` (well-formed TOML) and builds the scene.
fn build_described(text: &str, ctx: &ErrorContext, base_dir: &Path, name: &Path) -> Result<Scene, SceneError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    build_file(file, ctx, base_dir, name)
}

/// Builds the scene of the deserialised description `file`.
fn build_file(file: SceneFile, ctx: &ErrorContext, base_dir: &Path, name: &Path) -> Result<Scene, SceneError> {
    // Phase 1: plan.
    let integrator = integrator_settings(&ctx, &file)?;
    let given_camera = file.sensor.as_ref().map(|s| camera(ctx, s)).transpose()?;
    let textures = Textures::new(ctx, &file.texture, base_dir)?;
    let mut materials = Materials::new(ctx, &file.bsdf, textures)?;
    // Shapes in the file's order, instances apart (module `instances`), then each shapegroup's shapes.
    let groups: BTreeMap<String, usize> = file.shapegroup.keys().enumerate().map(|(i, k)| (k.clone(), i)).collect();
    let mut shape_plans = Vec::with_capacity(file.shape.len());
    let mut instance_plans = Vec::new();
    let mut instance_keys = Vec::new();
    for (i, shape) in file.shape.iter().enumerate() {
        let key = join_index("shape", i);
        match shape.plugin.kind.as_str() {
            instances::INSTANCE => {
                instance_plans.push(instances::plan_instance(ctx, &key, shape, &groups)?);
                instance_keys.push(key);
            }
            instances::SHAPEGROUP => return Err(instances::refuse_group_as_shape(ctx, &key)),
            _ => shape_plans.push(plan_shape(ctx, &key, shape, &mut materials)?),
        }
    }
    let mut group_plans = Vec::with_capacity(groups.len());
    for (name, group) in &file.shapegroup {
        let mut plans = Vec::with_capacity(group.shape.len());
        for (k, shape) in group.shape.iter().enumerate() {
            let key = join_index(&join_key(&join_key("shapegroup", name), "shape"), k);
            instances::check_group_shape(ctx, &key, shape)?;
            plans.push(plan_shape(ctx, &key, shape, &mut materials)?);
        }
        group_plans.push(plans);
    }
    let mut emitter_plans = Vec::with_capacity(file.emitter.len());
    for (i, emitter) in file.emitter.iter().enumerate() {
        emitter_plans.push(plan_emitter(ctx, &join_index("emitter", i), emitter, base_dir, &mut materials)?);
    }
    let (mut materials, mut textures, mut image_bytes) = materials.finish(ctx)?;
    let mut attributes = SceneAttributes::new(&materials, &mut textures);

    // Phase 2: every referenced file exists.
    let files = shape_plans
        .iter()
        .chain(group_plans.iter().flatten())
        .filter_map(|s| Some((join_key(&s.key, "filename"), base_dir.join(s.shape.filename()?))))
        .chain(emitter_plans.iter().filter_map(|e| match e {
            EmitterPlan::Env { key, path, .. } => Some((join_key(key, "filename"), path.clone())),
            EmitterPlan::Constant { .. } | EmitterPlan::Built(_) | EmitterPlan::Projector(..) => None,
        }));
    for (key, path) in files {
        if !path.exists() {
            return Err(ctx.missing_file(&key, &path));
        }
        if !path.is_file() {
            return Err(ctx.asset_error(&key, &path, "not a regular file"));
        }
    }

    // Phase 3: load and flatten.
    let mut mesh = TriangleMesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Default::default()
    };
    let mut tri_material = Vec::new();
    let mut tri_flat = Vec::new();
    let mut tri_has_uv = Vec::new();
    let mut shape_first_triangle = Vec::with_capacity(shape_plans.len());
    let mut lights = Vec::new();
    let (mut analytic, mut analytic_shading) = (Vec::new(), Vec::new());
    // Analytic shapes with an area emitter: (index in `analytic`, radiance); their lights are made once the
    // triangle count, which numbers their primitives, is known.
    let mut emissive_analytic = Vec::new();
    // The flat shapes, then the groups that some instance places, each group's shapes together.
    let n_flat = shape_plans.len();
    let placed_groups: Vec<usize> = (0..group_plans.len()).filter(|g| instance_plans.iter().any(|(i, _)| *i as usize == *g)).collect();
    let mut flat_vertices = None;
    for (i, plan) in shape_plans.iter().chain(placed_groups.iter().flat_map(|&g| &group_plans[g])).enumerate() {
        if i == n_flat {
            flat_vertices = Some(mesh.positions.len());
        }
        if let Some(shape) = analytic_shape(ctx, plan, i < n_flat)? {
            // No triangles: its entry in `shape_first_triangle` is the next triangle's, as an empty shape's.
            shape_first_triangle.push(mesh.triangle_count() as u32);
            let what = format!("the {} shape", plan.shape.type_name());
            attributes.add_shape(ctx, &plan.key, &what, plan.material, mesh.triangle_count() as u32, mesh.positions.len() as u32, 0, &Attributes::default())?;
            if let Some(radiance) = &plan.radiance {
                emissive_analytic.push((analytic.len(), radiance));
            }
            analytic.push(shape);
            analytic_shading.push(AnalyticShading { material: plan.material, shape: i as u32, anisotropic: materials[plan.material as usize].facts().anisotropic });
            continue;
        }
        let (mut placed, shape_attributes) = load_and_place(ctx, plan, base_dir, &|name| attributes.reads(plan.material, name))?;
        let base = mesh.triangle_count();
        shape_first_triangle.push(base as u32);
        let n = placed.triangle_count();
        if (base + n) as u64 > u64::from(u32::MAX) {
            return Err(ctx.key_error(&plan.key, "the scene has more than 2^32 triangles"));
        }
        let has_uv = placed.uvs.is_some();
        tri_has_uv.extend(std::iter::repeat_n(has_uv, n));
        placed.uvs.get_or_insert_with(|| vec![Vec2::ZERO; placed.positions.len()]);
        let what = match plan.shape.filename() {
            Some(f) => format!("the {} shape {}", plan.shape.type_name(), crate::props::shown(f)),
            None => format!("the {} shape", plan.shape.type_name()),
        };
        attributes.add_shape(ctx, &plan.key, &what, plan.material, base as u32, mesh.positions.len() as u32, n as u32, &shape_attributes)?;
        mesh.append(&placed);
        tri_material.extend(std::iter::repeat_n(plan.material, n));
        tri_flat.extend(std::iter::repeat_n(plan.shape.flat(), n));
        if let Some(radiance) = &plan.radiance {
            let triangles: Vec<(u32, [Vec3; 3])> = (0..n).map(|i| ((base + i) as u32, placed.triangle(i))).collect();
            let light = match radiance {
                PlannedRadiance::Constant(c) => AreaLight::new(*c, triangles),
                PlannedRadiance::Texture(t) => {
                    // The corners' uvs as `Scene::tex_uv` reads them at a hit (the barycentrics without uvs).
                    let uvs = placed.uvs.as_deref().expect("uvs were filled in above");
                    let corners = (0..n).map(|i| if has_uv { placed.indices[i].map(|k| uvs[k as usize]) } else { BARYCENTRIC_UVS }).collect();
                    AreaLight::textured(t.clone(), triangles, corners)
                }
            };
            // Lights that cannot emit anything are left out (zero radiance everywhere, or zero area).
            if light.max_radiance().max_element() > 0.0 && light.area() > 0.0 {
                lights.push(Light::Area(light));
            }
        }
    }
    for plan in emitter_plans {
        match plan {
            EmitterPlan::Env {
                key,
                path,
                scale,
                to_world,
            } => {
                if scale > 0.0 {
                    let env = EnvMap::load(&path, scale, to_world).map_err(|e| match e {
                        LightError::ScaleOverflow { .. } => ctx.key_error(&join_key(&key, "scale"), e.to_string()),
                        _ => ctx.asset_error(&join_key(&key, "filename"), &path, e.to_string()),
                    })?;
                    image_bytes += env.memory_bytes();
                    lights.push(Light::Env(env));
                }
            }
            EmitterPlan::Constant { radiance } => {
                if radiance.max_element() > 0.0 {
                    lights.push(Light::Constant { radiance });
                }
            }
            EmitterPlan::Built(light) => {
                // A sunsky's sky is an environment map baked at load time: its pixels count as an image's.
                if let Some(Light::Env(env)) = &light {
                    image_bytes += env.memory_bytes();
                }
                lights.extend(light);
            }
            EmitterPlan::Projector(projector, texture) => lights.extend(projector.light(texture)),
        }
    }
    // Each placed group's triangles (the soup past the flat shapes' `flat`), and the instances.
    let flat = shape_first_triangle.get(n_flat).map_or(mesh.triangle_count(), |&f| f as usize);
    let flat_vertices = flat_vertices.unwrap_or(mesh.positions.len());
    let mut prototypes = vec![0..0; group_plans.len()];
    let mut first = n_flat;
    for &g in &placed_groups {
        let end = first + group_plans[g].len();
        let triangle = |s: usize| shape_first_triangle.get(s).map_or(mesh.triangle_count() as u32, |&t| t);
        prototypes[g] = triangle(first)..triangle(end);
        first = end;
    }
    let instances: Vec<Instance> = instance_plans.iter().map(|&(g, m)| Instance::new(g, m).expect("checked by plan_instance")).collect();
    let instance_boxes = crate::accel::Geometry { positions: &mesh.positions, indices: &mesh.indices, flat: flat as u32, prototypes: &prototypes, instances: &instances, analytic: &[] }.instance_bounds();
    for (b, key) in instance_boxes.iter().zip(&instance_keys) {
        super::precision::check_box(*b).map_err(|m| ctx.key_error(key, m.replacen("the shape", "the instance", 1)))?;
    }
    let bounds = instance_boxes.iter().fold(Aabb::from_points(&mesh.positions[..flat_vertices]), |b, &i| b.union(i));
    let bounds = analytic.iter().fold(bounds, |b, a| b.union(a.bounds()));
    let camera = match (given_camera, &file.sensor) {
        (Some(camera), Some(_)) => {
            super::precision::check_camera(camera.position(), bounds).map_err(|m| ctx.key_error("sensor.to_world", m))?;
            camera
        }
        _ => camera(ctx, &default_sensor(bounds))?,
    };
    for (k, radiance) in emissive_analytic {
        // Primitive `triangle_count + k` (`Scene::surface`).
        let prim = (mesh.triangle_count() + k) as u32;
        let Some(shape) = AnalyticShape::from_primitive(&analytic[k]) else {
            continue;
        };
        let light = match radiance {
            PlannedRadiance::Constant(c) => AreaLight::analytic(*c, prim, shape),
            PlannedRadiance::Texture(t) => AreaLight::analytic_textured(t.clone(), prim, shape),
        };
        if light.max_radiance().max_element() > 0.0 && light.area() > 0.0 {
            lights.push(Light::Area(light));
        }
    }
    let lights = LightSet::new(lights, mesh.triangle_count() + analytic.len(), bounds);
    let attributes = attributes.finish(&mut materials, &textures);
    Ok(Scene {
        path: name.to_path_buf(),
        shading: super::shading::shading_records(&mesh, &tri_material, &tri_flat, |m| materials[m as usize].facts().anisotropic),
        mesh,
        tri_material,
        tri_flat,
        materials,
        textures,
        image_bytes,
        attributes,
        tri_has_uv,
        shape_first_triangle,
        flat_triangles: flat as u32,
        prototypes,
        instances,
        analytic,
        analytic_shading,
        lights,
        camera,
        integrator,
        bounds,
        notes: Vec::new(),
    })
}

fn integrator_settings(ctx: &ErrorContext, file: &SceneFile) -> Result<IntegratorSettings, SceneError> {
    let d = &file.integrator;
    let key_check = |key: &str, r: Result<(), check::Invalid>| r.map_err(|e| ctx.key_error(key, e.0));
    key_check("integrator.max_depth", check::max_depth(d.max_depth))?;
    key_check("integrator.rr_depth", check::rr_depth(d.rr_depth))?;
    key_check("integrator.samples_per_pixel", check::spp(d.samples_per_pixel))?;
    let caustics = match &d.caustics {
        None => CausticsSettings::default(),
        Some(c) => {
            if let Some(n) = c.photons {
                key_check("integrator.caustics.photons", check::photons(n))?;
            }
            if let Some(m) = c.caustic_photons {
                key_check("integrator.caustics.caustic_photons", check::photons(m))?;
            }
            if c.photons.is_some() && c.caustic_photons.is_some() {
                return Err(ctx.key_error("integrator.caustics.caustic_photons", "give either photons or caustic_photons, not both"));
            }
            key_check("integrator.caustics.knn", check::knn(c.knn))?;
            let max_radius = match c.max_radius {
                Some(r) => {
                    ctx.finite("integrator.caustics.max_radius", r)?;
                    key_check("integrator.caustics.max_radius", check::max_radius(r))?;
                    Some(r)
                }
                None => None,
            };
            CausticsSettings {
                estimator: c.estimator,
                photons: c.photons,
                caustic_photons: c.caustic_photons,
                knn: c.knn,
                max_radius,
            }
        }
    };
    let aovs = match &d.aovs {
        Some(spec) => check::aovs(spec).map_err(|e| ctx.key_error("integrator.aovs", e.0))?,
        None => super::aov::Aovs::default(),
    };
    Ok(IntegratorSettings {
        aovs,
        max_depth: d.max_depth,
        rr_depth: d.rr_depth,
        samples_per_pixel: d.samples_per_pixel,
        seed: d.seed,
        hide_emitters: d.hide_emitters,
        caustics,
    })
}

/// Mitsuba 0.6's camera for a scene without a sensor (`Scene::configure`, src/librender/scene.cpp;
/// Mitsuba 3 has none and renders nothing): a 45° field of view along x, looking along +z from below
/// the scene's bounding box, far enough for the box's larger extent in x and y to fill the view; the
/// default film. Its far clip plane is Mitsuba's default unless the box reaches beyond it: then just past the
/// box's far corner (depth ≤ distance + diagonal), so that the whole scene is seen.
fn default_sensor(bounds: Aabb) -> SensorDesc {
    let mut props = toml::Table::from_iter([("fov".to_string(), toml::Value::Float(45.0))]);
    let mut to_world = None;
    if !bounds.is_empty() {
        let (centre, extents) = (bounds.center(), bounds.extent());
        let distance = extents.x.max(extents.y) / (2.0 * 22.5f32.to_radians().tan());
        let reach = 1.01 * (distance + extents.length());
        if reach > camera::DEFAULT_FAR_CLIP {
            props.insert("far_clip".to_string(), toml::Value::Float(f64::from(reach)));
        }
        to_world = Some(ToWorld::One(TransformOp {
            translate: Some([centre.x, centre.y, bounds.min.z - distance]),
            ..TransformOp::default()
        }));
    }
    SensorDesc { plugin: PluginDesc { kind: camera::DEFAULT_TYPE.to_string(), props }, to_world, film: FilmDesc::default() }
}

fn camera(ctx: &ErrorContext, s: &SensorDesc) -> Result<Camera, SceneError> {
    let to_world = to_world_matrix(ctx, "sensor.to_world", s.to_world.as_ref())?;
    if s.to_world.is_some() {
        invertible_linear_part(ctx, "sensor.to_world", to_world)?;
    }
    let projection = projection(ctx, s)?;
    let mut camera = Camera::with_projection(to_world, projection, s.film.width, s.film.height).map_err(|e| match e {
        CameraError::Fov(_) => ctx.key_error("sensor.fov", e.to_string()),
        CameraError::ZeroSizeFilm { width: 0, .. } => ctx.key_error("sensor.film.width", e.to_string()),
        CameraError::ZeroSizeFilm { .. } => ctx.key_error("sensor.film.height", e.to_string()),
        CameraError::FilmTooLarge { .. } => ctx.key_error("sensor.film", e.to_string()),
        CameraError::ApertureRadius(_) => ctx.key_error("sensor.aperture_radius", e.to_string()),
        CameraError::FocusDistance(_) => ctx.key_error("sensor.focus_distance", e.to_string()),
        CameraError::NearClip(_) => ctx.key_error("sensor.near_clip", e.to_string()),
        CameraError::FarClip { .. } => ctx.key_error("sensor.far_clip", e.to_string()),
        CameraError::Crop { .. } | CameraError::Transform | CameraError::Scale => ctx.key_error("sensor.to_world", e.to_string()),
    })?;
    if let Some([x0, y0, x1, y1]) = s.film.crop {
        camera
            .set_crop(crate::math::Rect::new(x0, y0, x1, y1))
            .map_err(|e| ctx.key_error("sensor.film.crop", e.to_string()))?;
    }
    camera.set_filter(match &s.film.rfilter {
        Some(d) => rfilter(ctx, d)?,
        None => PixelFilter::default(),
    });
    Ok(camera)
}

/// The sensor's projection (`crate::camera::Projection`), built by its type's constructor (`camera::PLUGINS`).
fn projection(ctx: &ErrorContext, s: &SensorDesc) -> Result<Projection, SceneError> {
    plugins::build(ctx, "sensor", Role::Sensor, camera::PLUGINS, &s.plugin, |_, _| Ok(()))
}

/// `[sensor.film.rfilter]` → the filter, built by its type's constructor (`film::filter::PLUGINS`).
fn rfilter(ctx: &ErrorContext, d: &PluginDesc) -> Result<PixelFilter, SceneError> {
    plugins::build(ctx, "sensor.film.rfilter", Role::RFilter, filter::PLUGINS, d, |_, _| Ok(()))
}

/// A shape's table at `key` → its plan: the shape type's own keys read by its plugin (`crate::shape`), the
/// keys every shape takes (`shape::COMMON_KEYS`) read here.
fn plan_shape(ctx: &ErrorContext, key: &str, d: &ShapeDesc, materials: &mut Materials) -> Result<ShapePlan, SceneError> {
    let shape = plugins::build(ctx, key, Role::Shape, shape::PLUGINS, &d.plugin, |_, _| Ok(()))?;
    let to_world_key = join_key(key, "to_world");
    let to_world = to_world_matrix(ctx, &to_world_key, d.to_world.as_ref())?;
    let (linear, det) = invertible_linear_part(ctx, &to_world_key, to_world)?;
    let bsdf_key = join_key(key, "bsdf");
    let material = materials.index_for(ctx, &bsdf_key, d.bsdf.as_ref(), d.emitter.is_some())?;
    let radiance = d.emitter.as_ref().map(|e| area_emitter(ctx, &join_key(key, "emitter"), e, materials)).transpose()?;
    Ok(ShapePlan {
        key: key.to_string(),
        shape,
        to_world,
        linear,
        det,
        flip: d.flip_normals.unwrap_or(false),
        material,
        radiance,
    })
}

/// A shape's `emitter` at `key`: an `area` emitter (`crate::emitter`), its radiance a colour or a texture.
fn area_emitter(ctx: &ErrorContext, key: &str, table: &toml::Table, materials: &mut Materials) -> Result<PlannedRadiance, SceneError> {
    let d = PluginDesc::from_table(table.clone()).map_err(|m| ctx.key_error(key, m))?;
    if d.kind != emitter::AREA && emitter::plugin(&d.kind).is_some() {
        let message = format!("a shape's emitter is an `area` emitter; a `{}` emitter stands alone ([[emitter]] in TOML, <emitter> outside any <shape> in XML)", d.kind);
        return Err(ctx.key_error(&join_key(key, "type"), message));
    }
    let mut texture = None;
    let built = plugins::build_textured(ctx, key, Role::Emitter, emitter::PLUGINS, &d, |_, _| Ok(Mat4::IDENTITY), |at, _, v| {
        let t = materials.texture(ctx, at, v)?;
        if let Texture::MeshAttribute(a) = &t {
            return Err(ctx.key_error(at, format!("caustica does not take a `mesh_attribute` texture (`{}`) as an emitter's radiance", a.name)));
        }
        let summary = t.summary();
        texture = Some(t);
        Ok(summary)
    })?;
    match (built, texture) {
        (Emitter::Area { .. }, Some(t)) => Ok(PlannedRadiance::Texture(t)),
        (Emitter::Area { radiance }, None) => Ok(PlannedRadiance::Constant(radiance)),
        _ => unreachable!("only the area type passes the check above"),
    }
}

/// A top-level emitter's table at `key` → its plan (`crate::emitter`; its `to_world` read here). A
/// projector's `irradiance` and a spot's `texture` may be textures, resolved as an area emitter's `radiance` is.
fn plan_emitter(ctx: &ErrorContext, key: &str, d: &PluginDesc, base_dir: &Path, materials: &mut Materials) -> Result<EmitterPlan, SceneError> {
    if d.kind == emitter::AREA {
        let message = "an `area` emitter is attached to a shape: `emitter = { type = \"area\", … }` in its [[shape]] (in XML, inside its <shape>)";
        return Err(ctx.key_error(&join_key(key, "type"), message));
    }
    let mut texture = None;
    let built = if d.kind == emitter::PROJECTOR || d.kind == emitter::SPOT {
        plugins::build_textured(ctx, key, Role::Emitter, emitter::PLUGINS, d, |at, v| to_world_value(ctx, at, v), |at, _, v| {
            let t = materials.texture(ctx, at, v)?;
            let summary = t.summary();
            texture = Some(t);
            Ok(summary)
        })?
    } else {
        plugins::build(ctx, key, Role::Emitter, emitter::PLUGINS, d, |at, v| to_world_value(ctx, at, v))?
    };
    Ok(match built {
        Emitter::Env { filename, scale, to_world } => EmitterPlan::Env {
            key: key.to_string(),
            path: base_dir.join(filename),
            scale,
            to_world,
        },
        Emitter::Constant { radiance } => EmitterPlan::Constant { radiance },
        Emitter::Built(light) => EmitterPlan::Built(light),
        Emitter::Projector(p) => {
            let texture = texture.unwrap_or(Texture::Constant(p.irradiance));
            EmitterPlan::Projector(p, texture)
        }
        Emitter::Spot(s) => EmitterPlan::Built(s.light(texture)),
        Emitter::Area { .. } => unreachable!("refused above"),
    })
}

/// The analytic primitive a shape is placed as (`crate::shape`'s rule: not in a shapegroup — `flat` is
/// false there — and not a sphere given its tessellation keys), in world space; with an emitter, its light
/// samples the same surface (`light::shapes`).
fn analytic_shape(ctx: &ErrorContext, plan: &ShapePlan, flat: bool) -> Result<Option<Analytic>, SceneError> {
    let Some((kind, placement)) = plan.shape.analytic().filter(|_| flat) else {
        return Ok(None);
    };
    let shape = Analytic::new(kind, plan.to_world * placement, plan.flip);
    let shape = shape.ok_or_else(|| ctx.key_error(&join_key(&plan.key, "to_world"), format!("the {} has no finite placement", kind.name())))?;
    Ok(Some(shape))
}

/// The shape's triangles in world space, with per-vertex normals.
fn load_and_place(ctx: &ErrorContext, plan: &ShapePlan, base_dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), SceneError> {
    let (mut mesh, attributes) = plan.shape.triangles_with_attributes(base_dir, keep).map_err(|e| match e {
        LoadError::File(m) => {
            let path = base_dir.join(plan.shape.filename().unwrap_or_default());
            ctx.asset_error(&join_key(&plan.key, "filename"), &path, m)
        }
        LoadError::Key(k, m) => ctx.key_error(&join_key(&plan.key, k), m),
    })?;
    let m = plan.to_world;
    for p in &mut mesh.positions {
        *p = m.transform_point3(*p);
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(ctx.key_error(
            &join_key(&plan.key, "to_world"),
            format!("vertex {i} is not finite after the transform"),
        ));
    }
    super::precision::check_offset(&mesh).map_err(|m| ctx.key_error(&plan.key, m))?;
    // Winding: keep (p1−p0)×(p2−p0) on the side of the transformed normals (see the module docs).
    if (plan.det < 0.0) != plan.flip {
        for t in &mut mesh.indices {
            t.swap(1, 2);
        }
    }
    let sign = if plan.flip { -1.0 } else { 1.0 };
    let normals = match mesh.normals.take() {
        Some(mut normals) => {
            let normal_matrix = plan.linear.inverse().transpose();
            for n in &mut normals {
                *n = sign * (normal_matrix * *n).normalize_or_zero();
            }
            normals
        }
        None => vertex_normals(&mesh),
    };
    mesh.normals = Some(normals);
    Ok((mesh, attributes))
}

/// Angle-weighted vertex normals (Thürmer & Wüthrich 1998), as Mitsuba computes them for meshes without
/// normals; zero for vertices of degenerate triangles only (the interaction then falls back to the
/// geometric normal).
fn vertex_normals(mesh: &TriangleMesh) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.indices {
        let p = t.map(|i| mesh.positions[i as usize]);
        let Some((n, _)) = crate::math::triangle_normal_area(p) else {
            continue;
        };
        for k in 0..3 {
            let e1 = crate::math::normalize_any(p[(k + 1) % 3] - p[k]).unwrap_or(Vec3::ZERO);
            let e2 = crate::math::normalize_any(p[(k + 2) % 3] - p[k]).unwrap_or(Vec3::ZERO);
            let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
            normals[t[k] as usize] += angle * n;
        }
    }
    for n in &mut normals {
        *n = n.normalize_or_zero();
    }
    normals
}

#[cfg(test)]
mod sensor_tests {
    use std::path::Path;

    use crate::camera::{Projection, DEFAULT_FAR_CLIP, DEFAULT_NEAR_CLIP};
    use crate::scene::Scene;

    fn load(sensor: &str) -> Result<Scene, String> {
        let text = format!("[sensor]\n{sensor}\nfilm = {{ width = 8, height = 6 }}\n\n[[shape]]\ntype = \"cube\"\n");
        Scene::from_toml_str(&text, Path::new("."), Path::new("s.toml")).map_err(|e| e.to_string())
    }

    #[test]
    fn sensor_keys_defaults_and_errors() {
        // Mitsuba's defaults: clip planes 0.01 and 10⁴, the focal plane at the far clip plane, 50 mm.
        let s = load("type = \"thinlens\"\naperture_radius = 0.1").unwrap();
        match s.camera.projection() {
            Projection::ThinLens { aperture_radius, focus_distance, near_clip, far_clip, .. } => {
                assert_eq!((aperture_radius, focus_distance, near_clip, far_clip), (0.1, DEFAULT_FAR_CLIP, DEFAULT_NEAR_CLIP, DEFAULT_FAR_CLIP));
            }
            p => panic!("{p:?}"),
        }
        let s = load("type = \"orthographic\"\nnear_clip = 0.5\nfar_clip = 20").unwrap();
        assert_eq!(s.camera.projection(), Projection::Orthographic { near_clip: 0.5, far_clip: 20.0 });
        for (sensor, key, says) in [
            ("type = \"thinlens\"", "sensor", "needs aperture_radius"),
            ("type = \"thinlens\"\naperture_radius = -1", "sensor.aperture_radius", "≥ 0"),
            ("type = \"thinlens\"\naperture_radius = 0.1\nfocus_distance = 0", "sensor.focus_distance", "> 0"),
            ("type = \"thinlens\"\naperture_radius = 0.1\nto_world = { scale = 2 }", "sensor.to_world", "must not scale"),
            ("type = \"orthographic\"\nfov = 40", "sensor.fov", "`fov` does not apply to sensor type `orthographic`"),
            ("type = \"orthographic\"\nnear_clip = 2\nfar_clip = 1", "sensor.far_clip", "greater than near_clip"),
            ("aperture_radius = 0.1", "sensor.aperture_radius", "`aperture_radius` does not apply to sensor type `perspective`"),
            ("fov = 40\nfocal_length = \"35mm\"", "sensor.focal_length", "either fov or focal_length"),
            ("fov = 180", "sensor.fov", "(0, 180)"),
            ("fov_axis = \"z\"", "sensor.fov_axis", "not an axis"),
            ("focal_length = \"wide\"", "sensor.focal_length", "not a focal length"),
            ("type = \"fisheye\"", "sensor.type", "unknown sensor type"),
        ] {
            let e = load(sensor).err().unwrap_or_else(|| panic!("{sensor}: loads"));
            assert!(e.contains(key) && e.contains(says), "{sensor}: {e}");
        }
    }
}

#[cfg(test)]
mod sunsky_memory {
    use super::*;

    /// A sunsky's baked sky counts in the scene's image bytes (the memory check before a render).
    #[test]
    fn the_baked_sky_counts_as_an_image() {
        let scene = |emitter: &str| {
            let text = format!("[sensor]\nfov = 40\n[[shape]]\ntype = \"rectangle\"\n[[emitter]]\n{emitter}\n");
            Scene::from_toml_str(&text, Path::new("."), Path::new("s.toml")).unwrap()
        };
        let sky = scene("type = \"sunsky\"");
        let constant = scene("type = \"constant\"");
        assert!(sky.image_bytes >= 1024 * 512 * 12, "{} bytes", sky.image_bytes);
        assert_eq!(constant.image_bytes, 0);
    }
}
