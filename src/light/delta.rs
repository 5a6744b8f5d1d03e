//! Delta lights (Mitsuba 3's `point`, `spot`, `projector` and `directional` emitters): light from one
//! point, or from one direction. No ray can hit them, so next-event estimation is their only eye-side
//! technique (MIS weight 1, method.md §4.1) and their caustics come only from photons.
//!
//! - **point** (`point.cpp`): radiant intensity `I` (W/sr) in every direction; the radiance arriving at
//!   distance r is `I/r²` along the line to the light.
//! - **spot** (`spot.cpp`): a point light whose intensity is `I·falloff(θ)`, θ the angle to the spot's
//!   axis (+z of its `to_world`): 1 up to `beam_width`, falling linearly in θ to 0 at `cutoff_angle`
//!   (Mitsuba's `falloff_curve`: `(cutoff − θ)/(cutoff − beam_width)`), 0 beyond; with a `texture`, times
//!   `T(uv)` ([`SpotTexture`]: Mitsuba's `direction_to_uv`, the projector's film rule on a square film).
//! - **projector** (`projector.cpp`): a point light whose intensity is `π·scale·k·T(uv)/cos³θ` inside a
//!   perspective frustum, T a texture on its film (module `projector`).
//! - **directional** (`directional.cpp`): irradiance `E` (W/m² on a surface facing the light) arriving
//!   along one direction from infinitely far away.
//!
//! Power (method.md §2, luminance): point `4π·Y(I)`; spot `2π·Y(I)·∫₀^c falloff(θ) sin θ dθ =
//! 2π·Y(I)·(1 − (sin c − sin b)/(c − b))` (c the cutoff, b the beam width, both in radians; `1 − cos c`
//! when b = c), a textured spot `Y(I·∫falloff·T dω)` by quadrature over the cone; projector `Y(π·scale·k·A·mean(T))`; directional `π·R²·Y(E)`, R the scene's bounding
//! radius (the disk of a distant light that covers the scene, as for environment maps).

use std::f32::consts::PI;

use super::projector::{Frustum, ProjectorProfile};
use super::{disk_emission, EmissionSample, LightSample};
use crate::math::{Frame, Mat3, Vec2, Vec3};
use crate::texture::Texture;
use crate::sampling::warp::{square_to_uniform_cone, square_to_uniform_sphere, uniform_cone_pdf_w, uniform_sphere_pdf_w};

/// The beam of a spot light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotProfile {
    /// Unit axis in world space (the spot's local +z).
    axis: Vec3,
    /// Cutoff and beam-width angles in radians, `0 ≤ beam ≤ cutoff ≤ π`, `cutoff > 0`.
    cutoff: f32,
    beam: f32,
    cos_cutoff: f32,
    cos_beam: f32,
}

impl SpotProfile {
    /// A beam along `axis` (any length > 0) with angles in degrees; `None` unless
    /// `0 < cutoff_deg ≤ 180` and `0 ≤ beam_deg ≤ cutoff_deg` and the axis has a direction.
    #[must_use]
    pub fn new(axis: Vec3, cutoff_deg: f32, beam_deg: f32) -> Option<Self> {
        let axis = axis.try_normalize()?;
        if !(cutoff_deg > 0.0 && cutoff_deg <= 180.0 && beam_deg >= 0.0 && beam_deg <= cutoff_deg) {
            return None;
        }
        let (cutoff, beam) = (cutoff_deg.to_radians(), beam_deg.to_radians());
        Some(Self { axis, cutoff, beam, cos_cutoff: cutoff.cos(), cos_beam: beam.cos() })
    }

    /// Unit axis (world space).
    #[must_use]
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// `cos` of the cutoff angle: no light leaves at a larger angle to the axis.
    #[must_use]
    pub fn cos_cutoff(&self) -> f32 {
        self.cos_cutoff
    }

    /// The falloff factor in [0, 1] for the unit direction `w` leaving the light (Mitsuba's
    /// `falloff_curve`): 1 within the beam, `(cutoff − θ)/(cutoff − beam)` in the transition, 0 from the
    /// cutoff on.
    #[must_use]
    pub fn falloff(&self, w: Vec3) -> f32 {
        let cos_theta = self.axis.dot(w);
        if cos_theta.is_nan() || cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - cos_theta.clamp(-1.0, 1.0).acos()) / (self.cutoff - self.beam)).clamp(0.0, 1.0)
        }
    }

    /// `∫ falloff dω` over the sphere: `2π·(1 − (sin c − sin b)/(c − b))` (the integral of
    /// `(c − θ)·sin θ` over [b, c] by parts), `2π·(1 − cos c)` when b = c.
    #[must_use]
    pub fn solid_angle_integral(&self) -> f32 {
        let (c, b) = (f64::from(self.cutoff), f64::from(self.beam));
        let width = c - b;
        let inner = if width < 1e-6 {
            // (sin c − sin b)/(c − b) → cos of the midpoint (error O(width²)).
            1.0 - (0.5 * (b + c)).cos()
        } else {
            1.0 - (c.sin() - b.sin()) / width
        };
        (2.0 * std::f64::consts::PI * inner) as f32
    }
}

/// The texture of a spot (Mitsuba's `spot` with a `texture`): its intensity along `w` is multiplied by `T(uv)`,
/// `uv = (½ + l.x/(2·l.z·tan c), ½ + l.y/(2·l.z·tan c))` for `w` in the spot's frame `l` (Mitsuba's
/// `direction_to_uv`, c the cutoff angle). That is the projector's film rule ([`Frustum::film_uv`]) on the
/// square film of half-extent `tan c` with the frame's x and y turned by 180° (the projector's u and v run
/// against x and y, the spot's along them); the beam's cone lies inside that square, so every lit direction
/// reads the texture. A cutoff of 90° or more has no such film (`None`).
#[derive(Clone, Debug)]
pub struct SpotTexture {
    film: Frustum,
    texture: Texture,
    /// `∫ falloff·T dω` per channel, by quadrature at construction (the light's power).
    integral: Vec3,
}

/// Cells per side of the quadrature of a textured spot's power (a stratified grid over the cone).
const SPOT_POWER_CELLS: u32 = 128;

impl SpotTexture {
    /// `texture` on the beam of `spot`, whose frame is `frame` (orthonormal, third column the spot's axis).
    #[must_use]
    pub fn new(spot: &SpotProfile, frame: Mat3, texture: Texture) -> Option<Self> {
        if !(spot.cutoff < 0.5 * PI) {
            return None;
        }
        let turned = Mat3::from_cols(-frame.x_axis, -frame.y_axis, frame.z_axis);
        let tan_c = spot.cutoff.tan();
        let film = Frustum::new(turned, Vec2::splat(tan_c))?;
        let mut t = Self { film, texture, integral: Vec3::ZERO };
        // Midpoints of a grid over the uniform cone warp: each cell is 1/n² of the cone's solid angle.
        let n = SPOT_POWER_CELLS;
        let axis = Frame::from_normal(spot.axis);
        let mut sum = glam::DVec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let w = axis.to_world(square_to_uniform_cone(u, spot.cos_cutoff)).normalize();
                sum += (t.eval(w) * spot.falloff(w)).as_dvec3();
            }
        }
        let solid_angle = 2.0 * std::f64::consts::PI * (1.0 - f64::from(spot.cos_cutoff));
        t.integral = (sum * solid_angle / f64::from(n * n)).as_vec3();
        Some(t)
    }

    /// `T(uv)` along the unit direction `w` (0 behind the spot).
    #[must_use]
    pub fn eval(&self, w: Vec3) -> Vec3 {
        self.film.film_uv(w).map_or(Vec3::ZERO, |(uv, _)| self.texture.eval_rgb(uv))
    }

    #[must_use]
    pub fn texture(&self) -> &Texture {
        &self.texture
    }
}

/// How a point light's intensity varies with direction.
#[derive(Clone, Debug)]
enum Profile {
    /// The same in every direction (`point`).
    Uniform,
    Spot(SpotProfile, Option<Box<SpotTexture>>),
    Projector(Box<ProjectorProfile>),
}

/// A point light: a point, a spot or a projector.
#[derive(Clone, Debug)]
pub struct PointLight {
    position: Vec3,
    /// Radiant intensity (W/sr) at the centre of a spot's beam, everywhere for a point light; a
    /// projector's factor `π·scale·k`, times its profile's `T(uv)/cos³θ`.
    intensity: Vec3,
    profile: Profile,
}

/// How photon directions leave a point light (method.md §2): uniform in a cone, over the sphere, or
/// through a projector's film (a film point uniform on it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointDirection {
    Cone { axis: Vec3, cos_max: f32 },
    Sphere,
    /// A film point uniform on a projector's film ([`Frustum::sample_direction`]).
    Frustum(Frustum),
}

impl PointDirection {
    /// A direction and its solid-angle density.
    #[must_use]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        match *self {
            PointDirection::Cone { axis, cos_max } => {
                let w = Frame::from_normal(axis).to_world(square_to_uniform_cone(u, cos_max)).normalize();
                (w, uniform_cone_pdf_w(Vec3::Z, cos_max))
            }
            PointDirection::Sphere => {
                let w = square_to_uniform_sphere(u);
                (w, uniform_sphere_pdf_w(w))
            }
            PointDirection::Frustum(f) => f.sample_direction(u),
        }
    }

    /// The solid angle the rule samples: the smaller, the fewer photons are lost.
    #[must_use]
    pub fn solid_angle(&self) -> f32 {
        match *self {
            PointDirection::Cone { cos_max, .. } => 2.0 * PI * (1.0 - cos_max),
            PointDirection::Sphere => 4.0 * PI,
            PointDirection::Frustum(f) => f.solid_angle(),
        }
    }
}

impl PointLight {
    #[must_use]
    pub fn new(position: Vec3, intensity: Vec3, spot: Option<SpotProfile>) -> Self {
        Self { position, intensity, profile: spot.map_or(Profile::Uniform, |s| Profile::Spot(s, None)) }
    }

    /// A spot whose intensity is also multiplied by a texture over its beam.
    #[must_use]
    pub fn textured_spot(position: Vec3, intensity: Vec3, spot: SpotProfile, texture: SpotTexture) -> Self {
        Self { position, intensity, profile: Profile::Spot(spot, Some(Box::new(texture))) }
    }

    /// A projector at `position` whose `to_world` scales by k, with `scale·k` (Mitsuba's `scale` times
    /// that k) per channel: its intensity is `π·scale·k·T(uv)/cos³θ` (module `projector`).
    #[must_use]
    pub fn projector(position: Vec3, scale_k: Vec3, profile: ProjectorProfile) -> Self {
        Self { position, intensity: PI * scale_k, profile: Profile::Projector(Box::new(profile)) }
    }

    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    #[must_use]
    pub fn intensity(&self) -> Vec3 {
        self.intensity
    }

    #[must_use]
    pub fn spot(&self) -> Option<&SpotProfile> {
        match &self.profile {
            Profile::Spot(s, _) => Some(s),
            _ => None,
        }
    }

    /// A spot's texture, if it has one.
    #[must_use]
    pub fn spot_texture(&self) -> Option<&SpotTexture> {
        match &self.profile {
            Profile::Spot(_, t) => t.as_deref(),
            _ => None,
        }
    }

    #[must_use]
    pub fn projector_profile(&self) -> Option<&ProjectorProfile> {
        match &self.profile {
            Profile::Projector(p) => Some(p),
            _ => None,
        }
    }

    /// Radiant intensity leaving along the unit direction `w` (W/sr): `I`, `I·falloff` for a spot (times
    /// `T(uv)` with a texture), `I·T(uv)/cos³θ` for a projector.
    #[must_use]
    pub fn intensity_toward(&self, w: Vec3) -> Vec3 {
        match &self.profile {
            Profile::Uniform => self.intensity,
            Profile::Spot(s, None) => self.intensity * s.falloff(w),
            Profile::Spot(s, Some(t)) => {
                let falloff = s.falloff(w);
                if falloff > 0.0 {
                    self.intensity * falloff * t.eval(w)
                } else {
                    Vec3::ZERO
                }
            }
            Profile::Projector(p) => self.intensity * p.weight(w),
        }
    }

    /// Power Φ (luminance): `Y(∫I(ω) dω)` (`4π·Y(I)` for a point light).
    #[must_use]
    pub fn power(&self) -> f32 {
        match &self.profile {
            Profile::Uniform => super::luminance(self.intensity) * 4.0 * PI,
            Profile::Spot(s, None) => super::luminance(self.intensity) * s.solid_angle_integral(),
            Profile::Spot(_, Some(t)) => super::luminance(self.intensity * t.integral),
            Profile::Projector(p) => super::luminance(self.intensity * p.solid_angle_integral()),
        }
    }

    /// The narrowest rule that contains every direction the light emits in: a spot's beam cone, a
    /// projector's frustum, `None` for a point light.
    fn beam(&self) -> Option<PointDirection> {
        match &self.profile {
            Profile::Uniform => None,
            Profile::Spot(s, _) => Some(PointDirection::Cone { axis: s.axis, cos_max: s.cos_cutoff }),
            Profile::Projector(p) => Some(PointDirection::Frustum(*p.frustum())),
        }
    }

    /// NEE: the light seen from `p_ref`, `li = I(ω)/r²`, `pdf_w = 1` (the one point, chosen with
    /// certainty; `delta`). `None` at the light's own position or outside a spot's beam.
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let d = self.position - p_ref;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let li = self.intensity_toward(-wi) / dist2;
        if li == Vec3::ZERO || !li.is_finite() {
            return None;
        }
        Some(LightSample { wi_world: wi, dist, li, pdf_w: 1.0, p_light: self.position, n_light: -wi, delta: true })
    }

    /// The direction rule of photon emission toward a sphere (`center`, `radius`), method.md §2: the cone
    /// the sphere subtends from the light when the light is outside it, else the sphere of directions; a
    /// spot's beam cone or a projector's frustum instead when that has the smaller solid angle. Each
    /// contains every direction that leaves the light inside its beam toward the sphere, so either one
    /// samples all of them.
    #[must_use]
    pub fn direction_toward(&self, center: Vec3, radius: f32) -> PointDirection {
        let d = center - self.position;
        let dist2 = d.length_squared();
        let r2 = radius * radius;
        let toward = if dist2.is_finite() && dist2 > r2 {
            PointDirection::Cone { axis: d / dist2.sqrt(), cos_max: (1.0 - r2 / dist2).max(0.0).sqrt() }
        } else {
            PointDirection::Sphere
        };
        match self.beam() {
            Some(beam) if beam.solid_angle() < toward.solid_angle() => beam,
            _ => toward,
        }
    }

    /// A photon's start aimed at the sphere (`center`, `radius`): a direction by
    /// [`PointLight::direction_toward`]. The emission sample's `le` is the radiant intensity along the
    /// direction (W/sr), `pdf_a = 1` (the one point) and `n = dir`, so `le·cos/(pdf_a·pdf_w_dir)` is the
    /// photon's power as for area lights. `None` outside a spot's beam.
    #[must_use]
    pub fn sample_le_toward(&self, u_dir: Vec2, center: Vec3, radius: f32) -> Option<EmissionSample> {
        self.sample_le_with(self.direction_toward(center, radius), u_dir)
    }

    /// Unaimed emission (tests, `Light::sample_le`): the beam cone of a spot, the frustum of a projector,
    /// the sphere for a point light.
    #[must_use]
    pub fn sample_le(&self, u_dir: Vec2) -> Option<EmissionSample> {
        self.sample_le_with(self.beam().unwrap_or(PointDirection::Sphere), u_dir)
    }

    fn sample_le_with(&self, rule: PointDirection, u_dir: Vec2) -> Option<EmissionSample> {
        let (dir, pdf_w_dir) = rule.sample(u_dir);
        let le = self.intensity_toward(dir);
        if !(pdf_w_dir > 0.0 && pdf_w_dir.is_finite()) || le == Vec3::ZERO {
            return None;
        }
        Some(EmissionSample { origin: self.position, n: dir, dir, le, pdf_a: 1.0, pdf_w_dir, t_min: 0.0 })
    }
}

/// A distant directional light.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels in.
    dir: Vec3,
    /// Irradiance on a surface facing the light (W/m²).
    irradiance: Vec3,
}

impl DirectionalLight {
    /// A light travelling along `dir` (any length > 0); `None` for a zero or non-finite direction.
    #[must_use]
    pub fn new(dir: Vec3, irradiance: Vec3) -> Option<Self> {
        Some(Self { dir: dir.try_normalize()?, irradiance })
    }

    /// Unit direction of travel.
    #[must_use]
    pub fn dir(&self) -> Vec3 {
        self.dir
    }

    #[must_use]
    pub fn irradiance(&self) -> Vec3 {
        self.irradiance
    }

    /// Power Φ = π·R²·Y(E), R the scene's bounding radius (method.md §2).
    #[must_use]
    pub fn power(&self, scene_radius: f32) -> f32 {
        PI * scene_radius * scene_radius * super::luminance(self.irradiance)
    }

    /// NEE: `li = E` from `−dir`, `dist = ∞`, `pdf_w = 1` (`delta`).
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        (self.irradiance != Vec3::ZERO).then_some(LightSample {
            wi_world: -self.dir,
            dist: f32::INFINITY,
            li: self.irradiance,
            pdf_w: 1.0,
            p_light: p_ref - self.dir,
            n_light: self.dir,
            delta: true,
        })
    }

    /// A photon's start: an origin uniform on a disk of `radius` perpendicular to the light, centred on
    /// the line through `center`, `distance` before it (outside the scene), travelling along `dir`.
    /// `pdf_a = 1/(π·radius²)`, `pdf_w_dir = 1` (the one direction) and `le = E`, so the photon's power is
    /// `E·π·radius²` over the photon count, as for environment maps.
    #[must_use]
    pub fn sample_le_toward(&self, u_disk: Vec2, center: Vec3, radius: f32, distance: f32) -> Option<EmissionSample> {
        disk_emission(-self.dir, self.irradiance, 1.0, u_disk, center, radius, distance)
    }
}
