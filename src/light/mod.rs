//! Light sources and their sampling: emissive triangles or analytic shapes (module `shapes`: sphere, disk,
//! cylinder) ([`AreaLight`], Mitsuba's `area` emitter), the
//! equirectangular environment map ([`EnvMap`], Mitsuba's `envmap`), the constant environment
//! ([`Light::Constant`], Mitsuba's `constant`) and the delta lights ([`PointLight`]: `point`, `spot` and
//! `projector`, module `projector`; [`DirectionalLight`]: `directional`; module `delta`); [`LightSet`]
//! holds them all and chooses one ∝ power for next-event estimation (NEE) and for photon emission.
//!
//! Measures are in the names: `pdf_w` per steradian, `pdf_a` per unit area. Every `pdf_li_*` is computed by
//! the same function the matching `sample_li` uses, so the two always agree (MIS needs this).
//!
//! Power (method.md §2) is a luminance: `Φ = π·A·Y(L)` for a one-sided diffuse area light, and
//! `Φ = π·R²·∫Y(Le) dω` for the environment map and the constant light, R = the scene's bounding-sphere radius;
//! the delta lights' powers are in `delta`.

pub mod area;
pub mod delta;
pub mod env;
pub mod env_sun;
pub mod projector;
pub mod set;
pub mod shapes;

#[cfg(test)]
mod test_util;
#[cfg(test)]
mod tests_area;
#[cfg(test)]
mod tests_textured;
#[cfg(test)]
mod tests_delta;
#[cfg(test)]
mod tests_projector;
#[cfg(test)]
mod tests_spot_texture;
#[cfg(test)]
mod tests_env;

pub use area::AreaLight;
pub use delta::{DirectionalLight, PointLight, SpotProfile, SpotTexture};
pub use env::EnvMap;
pub use env_sun::EnvSun;
pub use projector::{Frustum, ProjectorProfile};
pub use set::LightSet;
pub use shapes::{AnalyticShape, CylinderShape, DiskShape, SphereShape};

use crate::math::{Frame, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::PathBuf;
use crate::sampling::warp::{square_to_uniform_disk_concentric, square_to_uniform_sphere, uniform_sphere_pdf_w};

/// Luminance Y (Rec. 709 weights), the one definition of the project.
pub use crate::film::luminance;

/// A direction toward a light chosen by `sample_li`, with what NEE needs to use it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the reference point toward the light.
    pub wi_world: Vec3,
    /// Distance to `p_light`; `f32::INFINITY` for the environment and constant lights (then trace the shadow
    /// ray along `wi_world` without a bound).
    pub dist: f32,
    /// Radiance arriving at the reference point from the light along `-wi_world` (unoccluded).
    pub li: Vec3,
    /// Solid-angle density of this sample: given this light for [`Light::sample_li`], including the light's
    /// selection probability for [`LightSet::sample_li`]. For a delta light (`delta`) it is a probability,
    /// not a density: 1 given the light (its one point or direction), the selection probability in the set.
    pub pdf_w: f32,
    /// Sampled point on the light; for infinite lights `p_ref + wi_world` (a point along the direction,
    /// meaningful only together with `dist = ∞`).
    pub p_light: Vec3,
    /// Unit geometric normal at `p_light` (the emitting side); `-wi_world` for infinite and delta lights.
    pub n_light: Vec3,
    /// A delta light (point, spot, directional): no BSDF-sampled direction can reach it, so NEE is the only
    /// technique for this light and its MIS weight is 1 (method.md §4.1).
    pub delta: bool,
}

/// A photon's starting ray chosen by `sample_le` (method.md §2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionSample {
    /// Ray origin. For area lights the sampled point already moved off the surface by
    /// [`crate::math::offset_ray_origin`]; for infinite and directional lights a point on a disk outside
    /// the scene; for point lights the light's position.
    pub origin: Vec3,
    /// Unit normal of the emitting surface (area) or of the disk (infinite lights: `n = dir`, so cos θ′ = 1);
    /// `dir` for point lights.
    pub n: Vec3,
    /// Unit direction the photon travels.
    pub dir: Vec3,
    /// Emitted radiance along `dir`; for a point light its radiant intensity (W/sr), for a directional
    /// light its irradiance: in each case `le·|cos θ′|/(pdf_a·pdf_w_dir)` is the power of the start.
    pub le: Vec3,
    /// Density of `origin` per unit area: `1/A` (area light) or `1/(π R²)` (disk of infinite and
    /// directional lights); 1 for a point light (the one point, a probability).
    pub pdf_a: f32,
    /// Density of `dir` per steradian: `cos θ′/π` (area light, cosine-weighted) or the light's
    /// importance-sampling pdf (infinite lights); 1 for a directional light (the one direction).
    pub pdf_w_dir: f32,
    /// The near end of the photon's first ray: for an area light [`crate::math::spawn_t_min`] of the
    /// sampled point, the rule of every ray spawned from a surface (Embree 3 reports the light's own
    /// triangle at t = −0 for a ray leaving a 10⁻⁹-sized light at the origin, which lost every photon);
    /// 0 for the other lights, whose origins lie on no surface.
    pub t_min: f32,
}

/// Errors from building a light (loading an environment map). Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum LightError {
    #[error("{}: cannot read: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{}: cannot decode the environment map: {message}", path.display())]
    Decode { path: PathBuf, message: String },
    #[error("{}: unsupported environment map format (expected .exr or .hdr)", path.display())]
    UnsupportedFormat { path: PathBuf },
    #[error("{}: pixel (x {x}, y {y}) has a negative or non-finite value ({r}, {g}, {b})", path.display())]
    BadTexel {
        path: PathBuf,
        x: usize,
        y: usize,
        r: f32,
        g: f32,
        b: f32,
    },
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// A texel times the emitter's `scale` overflows f32: the scale is at fault, not the file.
    #[error("pixel (x {x}, y {y}) of {} times scale {scale} overflows f32 (largest texel value {max:e}; the scale must stay below {limit:e})", path.display())]
    ScaleOverflow {
        path: PathBuf,
        x: usize,
        y: usize,
        scale: f32,
        max: f32,
        limit: f32,
    },
}

/// One light source.
#[derive(Clone, Debug)]
pub enum Light {
    Area(AreaLight),
    Env(EnvMap),
    /// Uniform radiance from every direction at infinity (Mitsuba's `constant` emitter).
    Constant {
        radiance: Vec3,
    },
    /// Mitsuba's `point`, `spot` and `projector` emitters (a delta position).
    Point(PointLight),
    /// Mitsuba's `directional` emitter (a delta direction).
    Directional(DirectionalLight),
}

impl Light {
    /// Samples a direction toward this light from `p_ref`; `pdf_w` is given this light (no selection).
    /// `None` when the sample carries nothing (back side of an area light, zero-pdf direction, ...).
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Area(a) => a.sample_li(p_ref, u),
            Light::Env(e) => e.sample_li(p_ref, u),
            Light::Constant { radiance } => {
                let wi = square_to_uniform_sphere(u);
                infinite_light_sample(p_ref, wi, *radiance, uniform_sphere_pdf_w(wi))
            }
            Light::Point(p) => p.sample_li(p_ref),
            Light::Directional(d) => d.sample_li(p_ref),
        }
    }

    /// `true` for the environment lights at infinity (environment map, constant), seen by escaping rays.
    /// The directional light is at infinity too, but no ray finds its one direction: it is a delta light.
    #[must_use]
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Env(_) | Light::Constant { .. })
    }

    /// `true` for the delta lights (point, spot, directional): NEE and photons reach them, rays never do.
    #[must_use]
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point(_) | Light::Directional(_))
    }

    /// Radiance this light sends along an escaping ray with direction `dir_world` (0 for area lights).
    #[must_use]
    pub fn le_escaped(&self, dir_world: Vec3) -> Vec3 {
        match self {
            Light::Area(_) | Light::Point(_) | Light::Directional(_) => Vec3::ZERO,
            Light::Env(e) => e.eval(dir_world),
            Light::Constant { radiance } => *radiance,
        }
    }

    /// Solid-angle pdf (given this light) with which `sample_li` produces the escaping direction `dir_world`
    /// (0 for area lights).
    #[must_use]
    pub fn pdf_li_escaped(&self, dir_world: Vec3) -> f32 {
        match self {
            Light::Area(_) | Light::Point(_) | Light::Directional(_) => 0.0,
            Light::Env(e) => e.pdf_li(dir_world),
            Light::Constant { .. } => uniform_sphere_pdf_w(dir_world),
        }
    }

    /// Power Φ as a luminance (method.md §2); `scene_radius` is R of the scene's bounding sphere.
    #[must_use]
    pub fn power(&self, scene_radius: f32) -> f32 {
        match self {
            Light::Area(a) => a.power(),
            Light::Env(e) => e.power(scene_radius),
            Light::Constant { radiance } => PI * scene_radius * scene_radius * 4.0 * PI * luminance(*radiance),
            Light::Point(p) => p.power(),
            Light::Directional(d) => d.power(scene_radius),
        }
    }

    /// Samples a photon's starting ray (method.md §2). The arguments are those of the light's own
    /// `sample_le`, in order: area `(u_pos, u_dir, u_tri)`, environment `(u_dir, u_disk)`, constant
    /// `(u_dir, u_disk)` (uniform direction), point/spot `(u_dir)`, directional `(u_disk)`; infinite and
    /// directional lights use the scene's bounding sphere.
    #[must_use]
    pub fn sample_le(&self, u_a: Vec2, u_b: Vec2, u_c: f32, scene_center: Vec3, scene_radius: f32) -> Option<EmissionSample> {
        match self {
            Light::Area(a) => a.sample_le(u_a, u_b, u_c),
            Light::Env(e) => e.sample_le(u_a, u_b, scene_center, scene_radius),
            Light::Constant { radiance } => {
                let omega = square_to_uniform_sphere(u_a);
                disk_emission(omega, *radiance, uniform_sphere_pdf_w(omega), u_b, scene_center, scene_radius, scene_radius)
            }
            Light::Point(p) => p.sample_le(u_a),
            Light::Directional(d) => d.sample_le_toward(u_a, scene_center, scene_radius, scene_radius),
        }
    }
}

/// The `LightSample` of an infinite light in direction `wi` (None if it carries nothing).
fn infinite_light_sample(p_ref: Vec3, wi: Vec3, li: Vec3, pdf_w: f32) -> Option<LightSample> {
    if !(pdf_w > 0.0 && pdf_w.is_finite()) || li == Vec3::ZERO {
        return None;
    }
    Some(LightSample {
        wi_world: wi,
        dist: f32::INFINITY,
        li,
        pdf_w,
        p_light: p_ref + wi,
        n_light: -wi,
        delta: false,
    })
}

/// Emission from an infinite light arriving from direction `omega` (unit, toward the light): the photon
/// starts on a disk of radius `radius` perpendicular to `omega`, centred at `center + distance·omega`
/// (outside the scene when `distance` is large enough; `distance = radius = R` with the scene's bounding
/// sphere as in pbrt-v4 `ImageInfiniteLight::SampleLe`), and travels along `-omega`.
fn disk_emission(omega: Vec3, le: Vec3, pdf_w_dir: f32, u_disk: Vec2, center: Vec3, radius: f32, distance: f32) -> Option<EmissionSample> {
    if !(radius > 0.0 && radius.is_finite() && pdf_w_dir > 0.0 && pdf_w_dir.is_finite()) || le == Vec3::ZERO {
        return None;
    }
    let frame = Frame::from_normal(omega);
    let d = square_to_uniform_disk_concentric(u_disk);
    let origin = center + distance * omega + radius * (d.x * frame.s + d.y * frame.t);
    Some(EmissionSample {
        t_min: 0.0,
        origin,
        n: -omega,
        dir: -omega,
        le,
        pdf_a: 1.0 / (PI * radius * radius),
        pdf_w_dir,
    })
}
