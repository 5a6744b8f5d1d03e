//! Mitsuba's `point` emitter (`point.cpp`): `intensity` (W/sr, default 1) from `position`, or from the
//! image of the origin under `to_world`; not both.
//!
//! ```toml
//! [[emitter]]
//! type = "point"
//! position = [0, 4, 0]
//! intensity = 20
//! ```

use super::{either_or_to_world, power, Emitter, Plugin};
use crate::light::{Light, PointLight};
use crate::math::{Mat4, Vec3};
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin {
    name: "point",
    keys: &["intensity", "position", "to_world"],
    nested: &["to_world"],
    build,
};

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let (position, to_world) = either_or_to_world(&mut p, "position")?;
    let intensity = power(&p, "intensity")?;
    let position = position.unwrap_or_else(|| to_world.unwrap_or(Mat4::IDENTITY).transform_point3(Vec3::ZERO));
    Ok(Emitter::Built((intensity != Vec3::ZERO).then(|| Light::Point(PointLight::new(position, intensity, None)))))
}
