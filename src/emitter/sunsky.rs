//! Mitsuba 3.9.1's `sunsky` emitter (`src/emitters/sunsky.cpp`, `include/mitsuba/render/sunsky.h`): the
//! Hošek–Wilkie sky and the sun's disc ([`sunsky_model`](super::sunsky_model)), for a sun placed by
//! `sun_direction` (world space) or by a date, time and place ([`sunsky_position`](super::sunsky_position),
//! turned by `to_world`). The emitter's frame is z up, x toward the north; `to_world` may rotate it (and
//! scale uniformly). Mitsuba's RGB variants (scalar_rgb) are the reference; Mitsuba 0.6's `sky` and `sun`
//! are other models, which caustica does not read.
//!
//! ```toml
//! [[emitter]]
//! type = "sunsky"
//! sun_direction = [0.3, 0.4, 0.6]   # or: latitude, longitude, timezone, year, month, day, hour, minute, second
//! turbidity = 3        # [1, 10]
//! albedo = 0.3         # ground albedo, a number or [r, g, b], each in [0, 1]
//! sun_scale = 1        # ≥ 0
//! sky_scale = 1        # ≥ 0
//! sun_aperture = 0.5358  # degrees, in (0, 180)
//! to_world = { rotate = { axis = [0, 0, 1], angle = 30 } }
//! ```
//! Defaults are Mitsuba's: Tokyo (35.6894° N, 139.6917° E, UTC+9) on 10 July 2010 at 15:00.
//!
//! **What it becomes** (decision 35): an environment map ([`EnvMap`]) of the sky baked at load time,
//! [`SKY_WIDTH`] × [`SKY_HEIGHT`] pixels (0.35° each) holding the model's value at each pixel centre, plus
//! the sun's disc as an exact cone ([`EnvSun`]) that the map carries and samples. The sky is smooth at
//! that scale (its sharpest feature, the circumsolar peak, spans degrees), so the bilinear map stays within
//! 0.5 % of the model away from the sun and the horizon, which is far below the noise of a render (measured
//! by `tests_sunsky`); the disc is 0.27° in radius and needs no grid. Both then use the environment map's
//! sampling, pdf, power and photon emission unchanged. Mitsuba evaluates the sky analytically and samples it
//! with its own fitted mixture; an image's expectation does not depend on the sampling.
//!
//! Refused, each naming its key: `sun_direction` with any date, time or place key (Mitsuba refuses them
//! together), a zero `sun_direction`, `turbidity` outside [1, 10], an `albedo` outside [0, 1], a negative
//! scale, `sun_aperture` outside (0°, 180°), a `month` outside 1–12 or a `day` outside 1–31 (Mitsuba reads
//! them unchecked), `complex_sun = true` (Mitsuba's limb-darkened sun: not built), a `to_world` that shears.
//! A sun below the horizon makes the whole emitter black (Mitsuba warns and renders it so): it is left out.

use super::sunsky_model::{cone_solid_angle, sun_radiance, Sky, SUN_HALF_APERTURE_DEG};
use super::sunsky_position::{sun_angles, DateTimePlace};
use super::{Emitter, Plugin};
use crate::light::env::uv_to_local_dir;
use crate::light::{EnvMap, EnvSun, Light};
use crate::math::{Mat3, Mat4, Vec2, Vec3};
use crate::props::{PropError, Props};

/// The baked sky's resolution (decision 35): 0.35° per pixel.
pub(crate) const SKY_WIDTH: usize = 1024;
pub(crate) const SKY_HEIGHT: usize = 512;

/// The date, time and place keys, which `sun_direction` excludes.
const WHEN_AND_WHERE: [&str; 9] = ["latitude", "longitude", "timezone", "year", "month", "day", "hour", "minute", "second"];

pub(super) const PLUGIN: Plugin = Plugin {
    name: "sunsky",
    keys: &[
        "sun_direction", "latitude", "longitude", "timezone", "year", "month", "day", "hour", "minute", "second", "turbidity",
        "albedo", "sun_scale", "sky_scale", "sun_aperture", "complex_sun", "to_world",
    ],
    nested: &["to_world"],
    build,
};

/// Everything the emitter's image depends on, read and checked.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SunSky {
    /// The sun's unit direction in the emitter's local frame (z up).
    pub sun_local: Vec3,
    pub turbidity: f32,
    pub albedo: Vec3,
    pub sun_scale: f32,
    pub sky_scale: f32,
    /// Half of `sun_aperture`, radians.
    pub sun_half_aperture: f64,
    pub to_world: Mat4,
}

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let s = read(&mut p)?;
    Ok(Emitter::Built(s.light().map_err(|m| PropError::new("to_world", m))?))
}

/// An integer key, or `default`.
fn int_or(p: &Props<'_, Mat4>, key: &str, default: u32, range: std::ops::RangeInclusive<u32>) -> Result<i32, PropError> {
    let v = p.u32_or(key, default)?;
    if !range.contains(&v) || i32::try_from(v).is_err() {
        return Err(PropError::new(key, format!("{v} is outside {}–{}", range.start(), range.end())));
    }
    Ok(v as i32)
}

/// A non-negative finite number, or 1.
fn scale(p: &Props<'_, Mat4>, key: &str) -> Result<f32, PropError> {
    let v = p.float_or(key, 1.0)?;
    if v < 0.0 {
        return Err(PropError::new(key, format!("the scale must be ≥ 0, got {v}")));
    }
    Ok(v)
}

pub(crate) fn read(p: &mut Props<'_, Mat4>) -> Result<SunSky, PropError> {
    let to_world = p.take_nested("to_world").unwrap_or(Mat4::IDENTITY);
    let (linear, _) = crate::math::invertible_linear_part(to_world).map_err(|m| PropError::new("to_world", m))?;
    let turbidity = p.in_range_or("turbidity", 3.0, 1.0, 10.0, "the turbidity")?;
    let albedo = p.reflectance_or("albedo", Vec3::splat(0.3))?;
    let sun_scale = scale(p, "sun_scale")?;
    let sky_scale = scale(p, "sky_scale")?;
    let aperture = p.float_or("sun_aperture", 0.5358)?;
    if !(aperture > 0.0 && aperture < 180.0) {
        return Err(PropError::new("sun_aperture", format!("the sun's aperture must be in (0°, 180°), got {aperture}")));
    }
    if p.bool_or("complex_sun", false)? {
        return Err(PropError::new(
            "complex_sun",
            "Mitsuba's limb-darkened sun (`complex_sun = true`) is not supported; the default uniform sun is (same power)",
        ));
    }
    let sun_local = match p.vec3("sun_direction")? {
        Some(d) => {
            if let Some(k) = WHEN_AND_WHERE.iter().find(|k| p.has(k)) {
                return Err(PropError::new(k, "give either `sun_direction` or a date, time and place, not both (Mitsuba refuses both)"));
            }
            let d = crate::math::normalize_any(d).ok_or_else(|| PropError::new("sun_direction", "the direction is zero"))?;
            // `sun_direction` is in world space (Mitsuba's `m_sun_dir`); the model needs it in the local frame.
            crate::math::normalize_any(linear.inverse() * d).ok_or_else(|| PropError::new("to_world", "cannot be inverted"))?
        }
        None => {
            let when = DateTimePlace {
                latitude: p.float_or("latitude", 35.6894)?,
                longitude: p.float_or("longitude", 139.6917)?,
                timezone: p.float_or("timezone", 9.0)?,
                year: int_or(p, "year", 2010, 0..=1_000_000)?,
                month: int_or(p, "month", 7, 1..=12)?,
                day: int_or(p, "day", 10, 1..=31)?,
                hour: p.float_or("hour", 15.0)?,
                minute: p.float_or("minute", 0.0)?,
                second: p.float_or("second", 0.0)?,
            };
            let (theta, phi) = sun_angles(&when);
            Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
        }
    };
    Ok(SunSky {
        sun_local,
        turbidity,
        albedo,
        sun_scale,
        sky_scale,
        // Mitsuba's `deg_to_rad(0.5 · sun_aperture)` in f32.
        sun_half_aperture: f64::from((0.5 * aperture).to_radians()),
        to_world,
    })
}

/// `1 − cos x` in f32, as Mitsuba computes it for the sun's cone.
fn one_minus_cos_f32(x: f32) -> f32 {
    1.0 - x.cos()
}

/// Emitter-local (z up) direction of an environment map's local (y up) direction: a rotation by 90° about x.
fn sky_from_map(d: Vec3) -> Vec3 {
    Vec3::new(d.x, -d.z, d.y)
}

impl SunSky {
    /// The sun's elevation η = π/2 − θ (radians).
    pub(crate) fn sun_elevation(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 - f64::from(self.sun_local.z.clamp(-1.0, 1.0)).acos()
    }

    fn sky(&self) -> Sky {
        let a = self.albedo.as_dvec3();
        Sky::new(f64::from(self.turbidity), [a.x, a.y, a.z], self.sun_elevation(), f64::from(self.sky_scale))
    }

    /// The sky's RGB radiance from the unit local direction `d` (0 below the horizon; no sun).
    pub(crate) fn sky_radiance(&self, sky: &Sky, d: Vec3) -> Vec3 {
        if d.z < 0.0 || self.sky_scale == 0.0 {
            return Vec3::ZERO;
        }
        let (s, d64) = (self.sun_local.as_dvec3(), d.as_dvec3());
        // The angle between two unit vectors, precise at any angle (Mitsuba's `dr::unit_angle`).
        let gamma = 2.0 * (0.5 * (s - d64).length()).clamp(-1.0, 1.0).asin();
        let [r, g, b] = sky.eval(f64::from(d.z), gamma);
        Vec3::new(r as f32, g as f32, b as f32)
    }

    /// The radiance Mitsuba's `eval` returns inside the sun's disc: the table's standard sun times the ratio
    /// of the standard sun's solid angle to the chosen one's (`get_area_ratio`), both computed as Mitsuba
    /// computes them, `1 − cos α` in f32.
    pub(crate) fn mitsuba_sun_radiance(&self) -> Vec3 {
        let [r, g, b] = sun_radiance(f64::from(self.turbidity), self.sun_elevation());
        let ratio = f64::from(one_minus_cos_f32(SUN_HALF_APERTURE_DEG.to_radians() as f32)) / f64::from(one_minus_cos_f32(self.sun_half_aperture as f32));
        Vec3::new(r as f32, g as f32, b as f32) * (f64::from(self.sun_scale) * ratio) as f32
    }

    /// The radiance of our disc: Mitsuba's sun irradiance spread over the disc's exact solid angle. Mitsuba's
    /// disc covers `2π(1 − cos α)` with the cosine in f32 (its hit test and its sampling pdf both use it),
    /// which for the standard sun is 0.22 % below the exact solid angle; its irradiance is therefore the
    /// radiance times that f32 solid angle, and ours, `EnvSun` being exact, is the same irradiance.
    pub(crate) fn sun_disc_radiance(&self) -> Vec3 {
        let mitsuba_solid_angle = std::f64::consts::TAU * f64::from(one_minus_cos_f32(self.sun_half_aperture as f32));
        self.mitsuba_sun_radiance() * (mitsuba_solid_angle / cone_solid_angle(self.sun_half_aperture)) as f32
    }

    /// Mitsuba's `eval` from the unit local direction `d`: the analytic sky plus the sun's disc (whose
    /// radiance differs from the light's by Mitsuba's f32 solid angle, [`SunSky::sun_disc_radiance`]).
    #[cfg(test)]
    pub(crate) fn radiance(&self, d: Vec3) -> Vec3 {
        if self.sun_local.z < 0.0 || d.z < 0.0 {
            return Vec3::ZERO;
        }
        let sun = EnvSun::new(self.sun_local, self.sun_half_aperture, self.mitsuba_sun_radiance()).map_or(Vec3::ZERO, |s| s.eval(d));
        self.sky_radiance(&self.sky(), d) + sun
    }

    /// The light: the sky baked into an environment map, carrying the sun's disc; `None` when it emits
    /// nothing (both scales 0, or the sun below the horizon). Errors are `to_world`'s.
    pub(crate) fn light(&self) -> Result<Option<Light>, String> {
        if self.sun_local.z < 0.0 || (self.sun_scale == 0.0 && self.sky_scale == 0.0) {
            return Ok(None);
        }
        let sky = self.sky();
        let mut pixels = vec![Vec3::ZERO; SKY_WIDTH * SKY_HEIGHT];
        if self.sky_scale > 0.0 {
            // Only the upper half of the rows is above the horizon (v < 1/2).
            for y in 0..SKY_HEIGHT / 2 {
                for x in 0..SKY_WIDTH {
                    let uv = Vec2::new((x as f32 + 0.5) / SKY_WIDTH as f32, (y as f32 + 0.5) / SKY_HEIGHT as f32);
                    // Mitsuba keeps the rare negative RGB values of the model; a map holds none.
                    pixels[y * SKY_WIDTH + x] = self.sky_radiance(&sky, sky_from_map(uv_to_local_dir(uv))).max(Vec3::ZERO);
                }
            }
        }
        let map_to_sky = Mat4::from_mat3(Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y));
        let map = EnvMap::from_pixels(SKY_WIDTH, SKY_HEIGHT, pixels, 1.0, self.to_world * map_to_sky).map_err(|e| match e {
            crate::light::LightError::Invalid { message, .. } => message,
            e => e.to_string(),
        })?;
        let sun_world = crate::math::normalize_any(Mat3::from_mat4(self.to_world) * self.sun_local).ok_or("cannot be inverted")?;
        let radiance = self.sun_disc_radiance();
        let map = match EnvSun::new(sun_world, self.sun_half_aperture, radiance) {
            Some(sun) => map.with_sun(sun),
            None => map,
        };
        Ok((map.integral_luminance() > 0.0).then_some(Light::Env(map)))
    }
}
