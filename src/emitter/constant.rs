//! Mitsuba's `constant` emitter: the same `radiance` from every direction (default 1), an environment
//! with no image.
//!
//! ```toml
//! [[emitter]]
//! type = "constant"
//! radiance = 0.5
//! ```

use super::{power, Emitter, Plugin};
use crate::math::Mat4;
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin {
    name: "constant",
    keys: &["radiance"],
    nested: &[],
    build,
};

fn build(p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    Ok(Emitter::Constant { radiance: power(&p, "radiance")? })
}
