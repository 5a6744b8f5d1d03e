//! Mitsuba's `spot` emitter (`spot.cpp`): `intensity` (W/sr at the centre, default 1) from the origin of
//! `to_world`, shining along its +z (a `look_at` aims it), full inside `beam_width` and falling off to zero
//! at `cutoff_angle` (degrees).
//!
//! A spot's `to_world` must not shear or scale non-uniformly (rotations, uniform scales, mirrors and
//! translations only): Mitsuba measures the beam's angles in the spot's own frame, and such a transform
//! would make the beam elliptical.
//!
//! ```toml
//! [[emitter]]
//! type = "spot"
//! intensity = 50
//! cutoff_angle = 25      # (0, 180], default 20
//! beam_width = 15        # [0, cutoff_angle], default ¾ of the cutoff
//! to_world = { look_at = { origin = [0, 5, 0], target = [0, 0, 0], up = [0, 0, 1] } }
//! ```

use super::{power, similarity_scale, Emitter, Plugin};
use crate::light::{Light, PointLight, SpotProfile};
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};

/// Mitsuba's default `cutoff_angle` of a spot, degrees.
const SPOT_CUTOFF_DEG: f32 = 20.0;
/// Mitsuba's default `beam_width` as a fraction of the cutoff angle.
const SPOT_BEAM_FRACTION: f32 = 0.75;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "spot",
    keys: &["intensity", "cutoff_angle", "beam_width", "to_world"],
    nested: &["to_world"],
    build,
};

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let to_world = p.take_nested("to_world").unwrap_or(Mat4::IDENTITY);
    let intensity = power(&p, "intensity")?;
    let cutoff = p.float_or("cutoff_angle", SPOT_CUTOFF_DEG)?;
    if !(cutoff > 0.0 && cutoff <= 180.0) {
        return Err(PropError::new("cutoff_angle", format!("the cutoff angle must be in (0, 180] degrees, got {cutoff}")));
    }
    let beam = p.float_or("beam_width", SPOT_BEAM_FRACTION * cutoff)?;
    if !(0.0..=cutoff).contains(&beam) {
        return Err(PropError::new("beam_width", format!("the beam width must be in [0, cutoff_angle = {cutoff}] degrees, got {beam}")));
    }
    let linear = Mat3::from_mat4(to_world);
    similarity_scale(linear, "spot").map_err(|m| PropError::new("to_world", m))?;
    let profile = SpotProfile::new(linear * Vec3::Z, cutoff, beam)
        .ok_or_else(|| PropError::new("to_world", "the transform maps the spot's axis +z to a zero vector"))?;
    let position = to_world.transform_point3(Vec3::ZERO);
    Ok(Emitter::Delta((intensity != Vec3::ZERO).then(|| Light::Point(PointLight::new(position, intensity, Some(profile))))))
}
