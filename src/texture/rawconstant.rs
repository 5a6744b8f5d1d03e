//! Mitsuba 3.9.1's `rawconstant` texture (src/spectra/rawconstant.cpp): one value, or three, returned as
//! written wherever the texture is read — no sRGB conversion and no range check (a normal map's flat
//! `(0.5, 0.5, 1)`, which Mitsuba's own test scenes give as a `<vector>`). One value fills the three
//! channels; three are a colour.
//!
//! ```toml
//! normalmap = { type = "rawconstant", value = [0.5, 0.5, 1.0] }   # or one number: value = 0.5; required
//! ```
//!
//! One deviation: a one-number parameter (a roughness, a blend weight) on a three-value `rawconstant` reads
//! the mean of the three here; Mitsuba stops there with an error (`eval_1` "is not defined for 3D-valued
//! textures"). What the value drives still checks its own range (a reflectance in [0, 1]).

use super::TextureSpec;
use crate::math::Vec3;
use crate::props::{Plugin, PropError, Props};

pub(super) const PLUGIN: Plugin<TextureSpec> = Plugin { name: "rawconstant", keys: &["value"], nested: &[], build };

fn build(p: Props<'_, ()>) -> Result<TextureSpec, PropError> {
    if !p.has("value") {
        return Err(PropError::new("value", "missing: the texture's value, one number or three (Mitsuba requires it)"));
    }
    // A 3-vector, as Mitsuba's `<vector>` or `[x, y, z]`; otherwise one number.
    let value = match p.vec3("value") {
        Ok(Some(v)) => v,
        _ => Vec3::splat(p.float_or("value", 0.0)?),
    };
    Ok(TextureSpec::Constant(value))
}
