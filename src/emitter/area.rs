//! Mitsuba's `area` emitter, attached to a shape: its surface emits `radiance` on the side its normals
//! face (Mitsuba's `area.cpp`; default radiance 1). The radiance may be a texture, read at each point's
//! uv (`light::AreaLight`); the constructor checks the texture's range and keeps its mean.
//!
//! ```toml
//! [[shape]]
//! type = "rectangle"
//! emitter = { type = "area", radiance = [10, 9, 8] }
//! ```

use super::{power, Emitter, Plugin};
use crate::math::Mat4;
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin {
    name: super::AREA,
    keys: &["radiance"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    Ok(Emitter::Area { radiance: power(&p, "radiance")? })
}
