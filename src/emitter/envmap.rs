//! Mitsuba's `envmap` emitter: an equirectangular image (EXR, HDR, PFM...) of the radiance arriving from
//! each direction, times `scale`, oriented by `to_world` (Mitsuba's `envmap.cpp`; `light::EnvMap`). The
//! image is loaded with the scene's other files, after every key of the scene has been checked.
//!
//! ```toml
//! [[emitter]]
//! type = "envmap"
//! filename = "sky.exr"   # relative to the scene file
//! scale = 1.0            # ≥ 0 (default 1)
//! to_world = { rotate = { axis = [0, 1, 0], angle = 90 } }
//! ```

use super::{Emitter, Plugin};
use crate::math::Mat4;
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin {
    name: "envmap",
    keys: &["filename", "scale", "to_world"],
    nested: &["to_world"],
    build,
};

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let Some(filename) = p.string("filename")? else {
        return Err(PropError::new("", "emitter type `envmap` needs `filename`"));
    };
    let scale = p.float_or("scale", 1.0)?;
    if scale < 0.0 {
        return Err(PropError::new("scale", format!("the scale must be ≥ 0, got {scale}")));
    }
    let to_world = p.take_nested("to_world").unwrap_or(Mat4::IDENTITY);
    crate::math::invertible_linear_part(to_world).map_err(|m| PropError::new("to_world", m))?;
    Ok(Emitter::Env { filename: filename.to_string(), scale, to_world })
}
