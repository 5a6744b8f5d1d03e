//! `caustica info SCENE.toml...`: what a render of the scene would do, without rendering: film and
//! settings, triangles, materials, lights and their total power (a textured area light's: `π·A·Y` of its
//! texture's mean, `light::area`), whether a photon pass will run (and why not), and the memory the largest
//! structures will need.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::Outcome;
use crate::bsdf::Bsdf;
use crate::light::Light;
use crate::math::Vec3;
use crate::photon::PhotonBudget;
use crate::render::memory::{mesh_bytes, MemoryEstimate};
use crate::render::{photon_pass_needed, RenderSettings};
use crate::scene::{Estimator, Scene};

/// Arguments of `caustica info`.
#[derive(clap::Args, Debug, Clone)]
pub struct InfoArgs {
    /// Scene files: TOML, or Mitsuba 3 XML (.xml).
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    #[command(flatten)]
    pub params: super::args::SceneParams,
}

/// Prints the description of every scene.
pub fn run(args: &InfoArgs) -> anyhow::Result<Outcome> {
    for path in &args.scenes {
        let scene = Scene::load_with_params(path, &args.params.map())?;
        print!("{}", describe(&scene));
    }
    Ok(Outcome::Done)
}

/// The BSDF's Mitsuba plugin name; a `twosided` wrapper is named by what it wraps.
fn bsdf_kind(b: &Bsdf) -> &'static str {
    match b {
        Bsdf::TwoSided(two_sided) => bsdf_kind(&two_sided.0),
        other => other.type_name(),
    }
}

fn light_kind(l: &Light) -> &'static str {
    match l {
        Light::Area(a) if a.is_textured() => "textured area",
        Light::Area(_) => "area",
        Light::Env(_) => "envmap",
        Light::Constant { .. } => "constant",
        Light::Point(p) if p.spot().is_some() => "spot",
        Light::Point(p) if p.projector_profile().is_some() => "projector",
        Light::Point(_) => "point",
        Light::Directional(_) => "directional",
    }
}

/// `{kind: count}` in first-seen order, as `2 diffuse, 1 conductor`.
fn tally<'a>(kinds: impl Iterator<Item = &'a str>) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for k in kinds {
        match counts.iter_mut().find(|(name, _)| *name == k) {
            Some((_, n)) => *n += 1,
            None => counts.push((k, 1)),
        }
    }
    counts.iter().map(|(k, n)| format!("{n} {k}")).collect::<Vec<_>>().join(", ")
}

/// Bytes as `12.3 MB` (powers of 1000).
fn mb(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

/// The text `info` prints for one scene.
#[must_use]
pub fn describe(scene: &Scene) -> String {
    let settings = RenderSettings::from_scene(scene);
    let crop = scene.camera.crop();
    let mut s = String::new();
    let _ = writeln!(s, "{}", scene.path.display());
    let _ = writeln!(
        s,
        "  film        {}×{} (crop {crop}: {} pixels), {} spp, seed {}",
        scene.camera.width(),
        scene.camera.height(),
        crop.area(),
        settings.spp,
        settings.seed
    );
    let _ = writeln!(s, "  sensor      {}", sensor(&scene.camera));
    let (centre, radius) = scene.bounds.bounding_sphere();
    let _ = writeln!(s, "  geometry    {} triangles, {} vertices, bounding sphere centre {} radius {radius:.4}", scene.triangle_count(), scene.mesh.positions.len(), fmt_vec(centre));
    if !scene.instances.is_empty() {
        let _ = writeln!(s, "  instances   {}", instances(scene));
    }
    if !scene.analytic.is_empty() {
        let _ = writeln!(s, "  analytic    {} ({})", scene.analytic.len(), tally(scene.analytic.iter().map(|a| a.kind.name())));
    }
    let delta = scene.materials.iter().filter(|m| m.facts().has_delta).count();
    let _ = writeln!(s, "  materials   {} ({}); {delta} with a delta lobe (mirror/glass)", scene.materials.len(), tally(scene.materials.iter().map(|m| bsdf_kind(m.template()))));
    let lights = scene.lights.lights();
    let _ = writeln!(s, "  lights      {} ({}), total power {:.4}", lights.len(), if lights.is_empty() { "none".into() } else { tally(lights.iter().map(light_kind)) }, scene.lights.total_power());
    let _ = writeln!(s, "  estimator   {} (k = {}, max radius {:.4})", settings.estimator.name(), settings.knn, settings.max_radius);
    let _ = writeln!(s, "  photon pass {}", photon_pass(scene, settings.estimator, settings.photons));
    if settings.estimator == Estimator::Pt {
        let _ = writeln!(s, "  with pm/mis {}", photon_pass(scene, Estimator::Mis, settings.photons));
    }
    let _ = writeln!(s, "  memory      {}", memory(scene, &settings));
    for note in &scene.notes {
        let _ = writeln!(s, "  note        {note}");
    }
    s
}

/// The sensor's type, position and parameters (`crate::camera::Projection`).
fn sensor(camera: &crate::camera::Camera) -> String {
    use crate::camera::Projection;
    let p = camera.projection();
    let mut s = format!("{} at {}", p.name(), fmt_vec(camera.position()));
    if let Some((fov, axis)) = p.fov() {
        let _ = write!(s, ", fov {fov:.4}° ({axis:?})");
    }
    match p {
        Projection::ThinLens { aperture_radius, focus_distance, .. } => {
            let _ = write!(s, ", aperture radius {aperture_radius}, focus distance {focus_distance}");
        }
        Projection::Orthographic { .. } => {
            // The view's size in world units: between the origins of the film's edge rays.
            let (w, h) = (camera.width() as f32, camera.height() as f32);
            let across = camera.generate_ray(0.0, 0.5 * h).origin.distance(camera.generate_ray(w, 0.5 * h).origin);
            let down = camera.generate_ray(0.5 * w, 0.0).origin.distance(camera.generate_ray(0.5 * w, h).origin);
            let _ = write!(s, ", view {across:.4} × {down:.4}");
        }
        Projection::Perspective { .. } => {}
    }
    let (near, far) = p.clip();
    let _ = write!(s, ", clip [{near}, {far}]");
    s
}

fn fmt_vec(v: Vec3) -> String {
    format!("({:.3}, {:.3}, {:.3})", v.x, v.y, v.z)
}

/// Whether a render with `estimator` traces photons, and how many, or why not.
fn photon_pass(scene: &Scene, estimator: Estimator, budget: PhotonBudget) -> String {
    match photon_pass_needed(scene, estimator) {
        Ok(()) => format!("yes: {} per pass", describe_budget(budget)),
        Err(reason) => format!("no: {reason}"),
    }
}

fn describe_budget(b: PhotonBudget) -> String {
    match b {
        PhotonBudget::Emitted(n) => format!("{n} photons emitted"),
        PhotonBudget::Stored(m) => format!("emit until {m} caustic photons are stored"),
    }
}

/// Instances, prototypes, and the mesh memory instancing saves against placing every instance's triangles
/// (`render::memory::mesh_bytes`, per vertex and per triangle, as the estimate counts them).
fn instances(scene: &Scene) -> String {
    let m = &scene.mesh;
    let (normals, uvs) = (m.normals.is_some(), m.uvs.is_some());
    // A prototype's vertices are those its triangles index (its shapes' vertices, contiguous).
    let size = |r: &std::ops::Range<u32>| -> (u64, u64) {
        let tris = &m.indices[r.start as usize..r.end as usize];
        let (lo, hi) = tris.iter().flatten().fold((u32::MAX, 0), |(lo, hi), &i| (lo.min(i), hi.max(i)));
        (if tris.is_empty() { 0 } else { u64::from(hi - lo + 1) }, tris.len() as u64)
    };
    let sizes: Vec<(u64, u64)> = scene.prototypes.iter().map(size).collect();
    let placed = scene.prototypes.iter().filter(|r| !r.is_empty()).count();
    let stored: u64 = sizes.iter().map(|&(v, t)| mesh_bytes(v, t, normals, uvs)).sum::<u64>() + (scene.instances.len() * size_of::<crate::accel::Instance>()) as u64;
    let (flat_v, flat_t) = scene.instances.iter().fold((0u64, 0u64), |(v, t), i| {
        let (pv, pt) = sizes[i.prototype as usize];
        (v + pv, t + pt)
    });
    let flattened = mesh_bytes(flat_v, flat_t, normals, uvs);
    format!(
        "{} of {placed} shapegroups ({} triangles stored once); flattened: {flat_t} triangles, {} instead of {} ({} saved)",
        scene.instances.len(),
        sizes.iter().map(|s| s.1).sum::<u64>(),
        mb(flattened),
        mb(stored),
        mb(flattened.saturating_sub(stored)),
    )
}

/// The render's memory estimate ([`MemoryEstimate`], whose docs say what it counts).
fn memory(scene: &Scene, settings: &RenderSettings) -> String {
    let m = MemoryEstimate::of(scene, settings);
    format!(
        "about {} (mesh {}, film {}, photon map {}, images {}; the intersection backend's structure comes on top)",
        mb(m.total()),
        mb(m.mesh),
        mb(m.film),
        mb(m.photon_map),
        mb(m.images)
    )
}
