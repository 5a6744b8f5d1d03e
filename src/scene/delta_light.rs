//! `point`, `spot` and `directional` emitters of a scene file → [`Light`] (Mitsuba 3's parameters and
//! defaults: `point.cpp`, `spot.cpp`, `directional.cpp`).
//!
//! | type | keys | placement |
//! |---|---|---|
//! | `point` | `intensity` (W/sr, default 1) | `position`, or `to_world` (the image of the origin); not both |
//! | `spot` | `intensity` (W/sr at the centre, default 1), `cutoff_angle` (degrees, default 20), `beam_width` (default ¾ of the cutoff) | `to_world`: at its origin, shining along its +z (a `look_at` aims it) |
//! | `directional` | `irradiance` (W/m², default 1) | `direction` (the way the light travels), or `to_world` (its +z); not both |
//!
//! A spot's `to_world` must not shear or scale non-uniformly (rotations, uniform scales, mirrors and
//! translations only): Mitsuba measures the beam's angles in the spot's own frame, and such a transform
//! would make the beam elliptical. Emitters of zero intensity or irradiance are left out, like the others.

use super::desc::{Colour, EmitterDesc};
use super::error::{ErrorContext, SceneError};
use super::spans::join_key;
use super::transform::to_world_matrix;
use crate::light::{DirectionalLight, Light, PointLight, SpotProfile};
use crate::math::{Mat3, Vec3};

/// Mitsuba's default `cutoff_angle` of a spot, degrees.
pub(crate) const SPOT_CUTOFF_DEG: f32 = 20.0;
/// Mitsuba's default `beam_width` as a fraction of the cutoff angle.
pub(crate) const SPOT_BEAM_FRACTION: f32 = 0.75;

/// A non-negative colour at `key.name`, default 1 (Mitsuba's default intensity and irradiance).
fn colour(ctx: &ErrorContext, key: &str, name: &str, c: Option<Colour>) -> Result<Vec3, SceneError> {
    c.map_or(Ok(Vec3::ONE), |c| ctx.radiance(&join_key(key, name), c.0))
}

/// Refuses `name` together with `to_world` (Mitsuba refuses both).
fn exclusive(ctx: &ErrorContext, key: &str, e: &EmitterDesc, name: &str, given: bool) -> Result<(), SceneError> {
    if given && e.to_world.is_some() {
        return Err(ctx.key_error(&join_key(key, name), format!("give either `{name}` or `to_world`, not both (Mitsuba refuses both)")));
    }
    Ok(())
}

/// A `point` emitter at key path `key` (`None` if it emits nothing).
pub(crate) fn point(ctx: &ErrorContext, key: &str, e: &EmitterDesc) -> Result<Option<Light>, SceneError> {
    exclusive(ctx, key, e, "position", e.position.is_some())?;
    let to_world = to_world_matrix(ctx, &join_key(key, "to_world"), e.to_world.as_ref())?;
    let intensity = colour(ctx, key, "intensity", e.intensity)?;
    let position = match e.position {
        Some(p) => ctx.finite3(&join_key(key, "position"), Vec3::from(p))?,
        None => to_world.transform_point3(Vec3::ZERO),
    };
    Ok((intensity != Vec3::ZERO).then(|| Light::Point(PointLight::new(position, intensity, None))))
}

/// A `spot` emitter at key path `key` (`None` if it emits nothing).
pub(crate) fn spot(ctx: &ErrorContext, key: &str, e: &EmitterDesc) -> Result<Option<Light>, SceneError> {
    let to_world_key = join_key(key, "to_world");
    let to_world = to_world_matrix(ctx, &to_world_key, e.to_world.as_ref())?;
    let intensity = colour(ctx, key, "intensity", e.intensity)?;
    let cutoff_key = join_key(key, "cutoff_angle");
    let cutoff = ctx.finite(&cutoff_key, e.cutoff_angle.unwrap_or(SPOT_CUTOFF_DEG))?;
    if !(cutoff > 0.0 && cutoff <= 180.0) {
        return Err(ctx.key_error(&cutoff_key, format!("the cutoff angle must be in (0, 180] degrees, got {cutoff}")));
    }
    let beam_key = join_key(key, "beam_width");
    let beam = ctx.finite(&beam_key, e.beam_width.unwrap_or(SPOT_BEAM_FRACTION * cutoff))?;
    if !(0.0..=cutoff).contains(&beam) {
        return Err(ctx.key_error(&beam_key, format!("the beam width must be in [0, cutoff_angle = {cutoff}] degrees, got {beam}")));
    }
    let linear = Mat3::from_mat4(to_world);
    check_similarity(linear).map_err(|m| ctx.key_error(&to_world_key, m))?;
    let profile = SpotProfile::new(linear * Vec3::Z, cutoff, beam)
        .ok_or_else(|| ctx.key_error(&to_world_key, "the transform maps the spot's axis +z to a zero vector"))?;
    let position = to_world.transform_point3(Vec3::ZERO);
    Ok((intensity != Vec3::ZERO).then(|| Light::Point(PointLight::new(position, intensity, Some(profile)))))
}

/// A `directional` emitter at key path `key` (`None` if it emits nothing).
pub(crate) fn directional(ctx: &ErrorContext, key: &str, e: &EmitterDesc) -> Result<Option<Light>, SceneError> {
    exclusive(ctx, key, e, "direction", e.direction.is_some())?;
    let to_world_key = join_key(key, "to_world");
    let to_world = to_world_matrix(ctx, &to_world_key, e.to_world.as_ref())?;
    let irradiance = colour(ctx, key, "irradiance", e.irradiance)?;
    let (dir_key, dir) = match e.direction {
        Some(d) => {
            let k = join_key(key, "direction");
            let d = ctx.finite3(&k, Vec3::from(d))?;
            (k, d)
        }
        None => (to_world_key, Mat3::from_mat4(to_world) * Vec3::Z),
    };
    let light = DirectionalLight::new(dir, irradiance)
        .ok_or_else(|| ctx.key_error(&dir_key, "the direction is zero: a directional light needs a direction"))?;
    Ok((irradiance != Vec3::ZERO).then_some(Light::Directional(light)))
}

/// `Ok` if `m` is a rotation (or mirror) times a uniform scale: orthogonal columns of one length
/// (relative tolerance 10⁻⁴).
fn check_similarity(m: Mat3) -> Result<(), String> {
    let cols = [m.x_axis, m.y_axis, m.z_axis];
    let len2 = cols.map(Vec3::length_squared);
    let s2 = (len2[0] + len2[1] + len2[2]) / 3.0;
    let tol = 1e-4 * s2;
    let equal = len2.iter().all(|l| (l - s2).abs() <= 2.0 * tol);
    let orthogonal = [(0, 1), (0, 2), (1, 2)].iter().all(|&(i, j)| cols[i].dot(cols[j]).abs() <= tol);
    if s2 > 0.0 && s2.is_finite() && equal && orthogonal {
        Ok(())
    } else {
        Err("a spot's transform may rotate, mirror, scale uniformly and translate, but not shear or scale non-uniformly (the beam would not be round)".into())
    }
}
