//! Mitsuba's `directional` emitter (`directional.cpp`): `irradiance` (W/m², default 1) arriving along
//! `direction` (the way the light travels), or along the image of +z under `to_world`; not both.
//!
//! ```toml
//! [[emitter]]
//! type = "directional"
//! direction = [0, -1, -1]
//! irradiance = 3
//! ```

use super::{either_or_to_world, power, Emitter, Plugin};
use crate::light::{DirectionalLight, Light};
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin {
    name: "directional",
    keys: &["irradiance", "direction", "to_world"],
    nested: &["to_world"],
    build,
};

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let (direction, to_world) = either_or_to_world(&mut p, "direction")?;
    let irradiance = power(&p, "irradiance")?;
    let (key, dir) = match direction {
        Some(d) => ("direction", d),
        None => ("to_world", Mat3::from_mat4(to_world.unwrap_or(Mat4::IDENTITY)) * Vec3::Z),
    };
    let light = DirectionalLight::new(dir, irradiance)
        .ok_or_else(|| PropError::new(key, "the direction is zero: a directional light needs a direction"))?;
    Ok(Emitter::Built((irradiance != Vec3::ZERO).then_some(Light::Directional(light))))
}
