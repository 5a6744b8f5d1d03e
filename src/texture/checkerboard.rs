//! Mitsuba's `checkerboard` texture (src/textures/checkerboard.cpp): at `uv` (after `to_uv`), with
//! `(a, b) = (frac(u) > ½, frac(v) > ½)` (`frac(x) = x − ⌊x⌋`, so the pattern repeats every unit, also below
//! 0), `eval` gives `color0` where `a = b` and `color1` elsewhere: `color0` on `[0, ½]²`.
//!
//! `eval_1` in Mitsuba 3.9.1 takes the colours the other way round (`color0` where `a ≠ b`); caustica does
//! the same, so a scalar parameter (a roughness, a blend weight) reads what Mitsuba reads. Each colour's
//! `eval_1` is its channel average (a constant's).
//!
//! ```toml
//! reflectance = { type = "checkerboard", color0 = [0.9, 0.9, 0.9], color1 = 0.1 }   # defaults 0.4, 0.2
//! # an RGB colour must be a reflectance; a number is any finite value, as Mitsuba's `uniform` (the parameter
//! # the texture drives checks its range: diff_trans = { type = "checkerboard", color0 = 0.4, color1 = 1.4 })
//! ```

use super::{channel_mean, TextureSpec};
use crate::math::{Mat3, Vec2, Vec3};
use crate::props::{Plugin, PropError, Props};

/// Mitsuba's `checkerboard` with constant colours.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkerboard {
    pub color0: Vec3,
    pub color1: Vec3,
    /// Applied to the coordinates first (identity by default).
    pub to_uv: Mat3,
}

impl Checkerboard {
    /// Whether `uv` (before `to_uv`) lies on a `color0` square of `eval`.
    #[inline]
    fn on_color0(&self, uv: Vec2) -> bool {
        let uv = self.to_uv.transform_point2(uv);
        (uv.x - uv.x.floor() > 0.5) == (uv.y - uv.y.floor() > 0.5)
    }

    /// The colour at `uv` (Mitsuba's `eval`).
    #[inline]
    #[must_use]
    pub fn eval_rgb(&self, uv: Vec2) -> Vec3 {
        if self.on_color0(uv) {
            self.color0
        } else {
            self.color1
        }
    }

    /// Mitsuba's `eval_1`: the channel average of `color1` where `eval` gives `color0`, and of `color0`
    /// elsewhere (the colours swapped, as Mitsuba 3.9.1 has it).
    #[inline]
    #[must_use]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        channel_mean(if self.on_color0(uv) { self.color1 } else { self.color0 })
    }
}

pub(super) const PLUGIN: Plugin<TextureSpec> = Plugin {
    name: "checkerboard",
    // `to_uv` is read by the scene layer (a transform).
    keys: &["color0", "color1", "to_uv"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<TextureSpec, PropError> {
    // Mitsuba reads both with `get_texture`: an RGB value must be a reflectance, a number is unbounded (a
    // `diff_trans` of 1.4 in Mitsuba's own test scenes).
    let color0 = p.texture_value_or("color0", Vec3::splat(0.4))?;
    let color1 = p.texture_value_or("color1", Vec3::splat(0.2))?;
    Ok(TextureSpec::Checkerboard { color0, color1 })
}
