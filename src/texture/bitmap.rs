//! Mitsuba's `bitmap` texture (src/textures/bitmap.cpp; the lookup is Dr.Jit's `Texture::eval`,
//! drjit/texture_impl.h `tex_eval` and `tex_wrap`, which Mitsuba 3.9.1 calls in its scalar variants).
//!
//! At `uv` (after `to_uv`), on an image of `W × H` texels:
//! - `nearest`: the texel `(⌊u·W⌋, ⌊v·H⌋)`;
//! - `bilinear`: `p = uv·(W, H) − ½`, the texels `⌊p⌋ + {0, 1}²` weighted by `1 − f` and `f`, `f = p − ⌊p⌋`
//!   (texel centres at half-integer coordinates: `uv = (x + ½)/W` reads texel `x` alone);
//! - an index outside `[0, W)` wraps per [`WrapMode`]: `repeat` modulo W (also below 0), `mirror` reflects
//!   every other period (−1 → 0, −2 → 1, W → W − 1), `clamp` to the nearest edge texel.
//!
//! ```toml
//! reflectance = { type = "bitmap", filename = "checker.png", filter_type = "nearest", wrap_mode = "clamp" }
//! ```

use std::sync::Arc;

use super::texels::{StorageFormat, TextureImage};
use super::{choice_or, luminance, BitmapSpec, TextureSpec};
use crate::math::{Mat3, Vec2, Vec3};
use crate::props::{Plugin, PropError, Props};

/// How a lookup reads the texels near `uv` (Mitsuba's `filter_type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FilterType {
    Nearest,
    #[default]
    Bilinear,
}

/// What a texel index outside the image reads (Mitsuba's `wrap_mode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum WrapMode {
    #[default]
    Repeat,
    Mirror,
    Clamp,
}

impl WrapMode {
    /// Index `i` of a row or column of `n` texels, wrapped into `[0, n)` (Dr.Jit's `tex_wrap`).
    #[inline]
    pub(super) fn wrap(self, i: i64, n: u32) -> usize {
        let n = i64::from(n);
        if (0..n).contains(&i) {
            return i as usize;
        }
        // The neighbouring periods without a division (most lookups outside [0, 1) are near it).
        (match self {
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Repeat if (-n..0).contains(&i) => i + n,
            WrapMode::Repeat if (n..2 * n).contains(&i) => i - n,
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Mirror if (-n..0).contains(&i) => -1 - i,
            WrapMode::Mirror if (n..2 * n).contains(&i) => 2 * n - 1 - i,
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }) as usize
    }
}

/// A bitmap texture: an image (shared: [`super::ImageCache`]), its filter, wrap mode and `to_uv`.
#[derive(Clone)]
pub struct Bitmap {
    image: Arc<TextureImage>,
    filter: FilterType,
    wrap: WrapMode,
    to_uv: Mat3,
}

impl std::fmt::Debug for Bitmap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bitmap")
            .field("image", &self.image)
            .field("filter", &self.filter)
            .field("wrap", &self.wrap)
            .field("to_uv", &self.to_uv)
            .finish()
    }
}

impl Bitmap {
    /// A bitmap reading `image`, with the identity `to_uv`.
    #[must_use]
    pub fn new(image: Arc<TextureImage>, filter: FilterType, wrap: WrapMode) -> Self {
        Bitmap { image, filter, wrap, to_uv: Mat3::IDENTITY }
    }

    /// The same bitmap with `to_uv` applied to the coordinates before the lookup.
    #[must_use]
    pub fn with_to_uv(self, to_uv: Mat3) -> Self {
        Bitmap { to_uv, ..self }
    }

    #[must_use]
    pub fn image(&self) -> &TextureImage {
        &self.image
    }

    /// The shared image (to compare identity: `Arc::ptr_eq`).
    #[must_use]
    pub fn image_arc(&self) -> &Arc<TextureImage> {
        &self.image
    }

    #[must_use]
    pub fn filter(&self) -> FilterType {
        self.filter
    }

    #[must_use]
    pub fn wrap(&self) -> WrapMode {
        self.wrap
    }

    #[must_use]
    pub fn to_uv(&self) -> Mat3 {
        self.to_uv
    }

    /// The colour at `uv` (a grey image's value in all three channels).
    #[inline]
    #[must_use]
    pub fn eval_rgb(&self, uv: Vec2) -> Vec3 {
        if self.image.channels() == 1 {
            Vec3::splat(self.lookup::<1>(uv)[0])
        } else {
            Vec3::from_array(self.lookup::<3>(uv))
        }
    }

    /// The value at `uv`: a grey image's, an RGB image's luminance (Mitsuba's `eval_1`).
    #[inline]
    #[must_use]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        if self.image.channels() == 1 {
            self.lookup::<1>(uv)[0]
        } else {
            luminance(Vec3::from_array(self.lookup::<3>(uv)))
        }
    }

    /// The gradient of [`Bitmap::eval_1`] with respect to `(u, v)` (Mitsuba's `BitmapTexture::eval_1_grad`):
    /// zero for `nearest`; for `bilinear` the derivatives of the interpolation across the four texels around
    /// `uv` (a texel's number: its value, or an RGB texel's luminance), per texel, taken back through
    /// `to_uv` by its transposed 2×2 part and then scaled by the resolution, in Mitsuba's order (which
    /// differs from the chain rule only for a `to_uv` that mixes `u` and `v` on a non-square image).
    #[must_use]
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        if self.filter == FilterType::Nearest {
            return Vec2::ZERO;
        }
        let uv = self.to_uv.transform_point2(uv);
        let [f00, f10, f01, f11] = if self.image.channels() == 1 {
            self.corners::<1>(uv).map(|t| t[0])
        } else {
            self.corners::<3>(uv).map(|t| luminance(Vec3::from_array(t)))
        };
        let (w, h) = (self.image.width() as f32, self.image.height() as f32);
        let (px, py) = (uv.x * w - 0.5, uv.y * h - 0.5);
        let (tx, ty) = (px - px.floor(), py - py.floor());
        let (sx, sy) = (1.0 - tx, 1.0 - ty);
        // Partial derivatives per texel along x and y.
        let dx = sy * (f10 - f00) + ty * (f11 - f01);
        let dy = sx * (f01 - f00) + tx * (f11 - f10);
        let m = self.to_uv;
        Vec2::new(w * (m.x_axis.x * dx + m.x_axis.y * dy), h * (m.y_axis.x * dx + m.y_axis.y * dy))
    }

    /// The four texels a bilinear lookup at `uv` (after `to_uv`) reads, in Dr.Jit's corner order (0,0),
    /// (1,0), (0,1), (1,1) (its `eval_fetch`).
    #[inline]
    fn corners<const C: usize>(&self, uv: Vec2) -> [[f32; C]; 4] {
        debug_assert_eq!(self.image.channels(), C);
        let (w, h) = (self.image.width(), self.image.height());
        let data = self.image.data();
        let texel = |x: usize, y: usize| -> [f32; C] {
            let i = (y * w as usize + x) * C;
            std::array::from_fn(|c| data[i + c])
        };
        let (px, py) = (uv.x * w as f32 - 0.5, uv.y * h as f32 - 0.5);
        let (ix, iy) = (px.floor() as i64, py.floor() as i64);
        let (x0, x1) = (self.wrap.wrap(ix, w), self.wrap.wrap(ix.saturating_add(1), w));
        let (y0, y1) = (self.wrap.wrap(iy, h), self.wrap.wrap(iy.saturating_add(1), h));
        [texel(x0, y0), texel(x1, y0), texel(x0, y1), texel(x1, y1)]
    }

    /// The filtered texels at `uv`, `C` (the image's channel count) values.
    #[inline]
    fn lookup<const C: usize>(&self, uv: Vec2) -> [f32; C] {
        debug_assert_eq!(self.image.channels(), C);
        let uv = self.to_uv.transform_point2(uv);
        let (w, h) = (self.image.width(), self.image.height());
        let data = self.image.data();
        let texel = |x: usize, y: usize| -> [f32; C] {
            let i = (y * w as usize + x) * C;
            std::array::from_fn(|c| data[i + c])
        };
        match self.filter {
            FilterType::Nearest => {
                // `as i64` saturates (NaN → 0): any coordinate gives some texel.
                let x = self.wrap.wrap((uv.x * w as f32).floor() as i64, w);
                let y = self.wrap.wrap((uv.y * h as f32).floor() as i64, h);
                texel(x, y)
            }
            FilterType::Bilinear => {
                let (px, py) = (uv.x * w as f32 - 0.5, uv.y * h as f32 - 0.5);
                let (fx, fy) = (px.floor(), py.floor());
                let (tx, ty) = (px - fx, py - fy);
                let (ix, iy) = (fx as i64, fy as i64);
                let (x0, x1) = (self.wrap.wrap(ix, w), self.wrap.wrap(ix.saturating_add(1), w));
                let (y0, y1) = (self.wrap.wrap(iy, h), self.wrap.wrap(iy.saturating_add(1), h));
                let (sx, sy) = (1.0 - tx, 1.0 - ty);
                let (t00, t10, t01, t11) = (texel(x0, y0), texel(x1, y0), texel(x0, y1), texel(x1, y1));
                // Dr.Jit's corner order and weights: (0,0), (1,0), (0,1), (1,1).
                std::array::from_fn(|c| t00[c] * (sx * sy) + t10[c] * (tx * sy) + t01[c] * (sx * ty) + t11[c] * (tx * ty))
            }
        }
    }
}

pub(super) const PLUGIN: Plugin<TextureSpec> = Plugin {
    name: "bitmap",
    // `to_uv` is read by the scene layer (a transform); `accel` (CUDA texture hardware) changes no image here.
    keys: &["filename", "raw", "filter_type", "wrap_mode", "format", "to_uv", "accel"],
    nested: &[],
    build,
};

fn build(p: Props<'_, ()>) -> Result<TextureSpec, PropError> {
    let filename = match p.string("filename")? {
        Some(f) if !f.is_empty() => f.to_string(),
        Some(_) => return Err(PropError::new("filename", "the file name is empty")),
        None => return Err(PropError::new("filename", "missing: a bitmap texture reads the image named by `filename`")),
    };
    let raw = p.bool_or("raw", false)?;
    let filter = choice_or(&p, "filter_type", &[("bilinear", FilterType::Bilinear), ("nearest", FilterType::Nearest)], FilterType::Bilinear)?;
    let wrap = choice_or(&p, "wrap_mode", &[("repeat", WrapMode::Repeat), ("mirror", WrapMode::Mirror), ("clamp", WrapMode::Clamp)], WrapMode::Repeat)?;
    let format = choice_or(&p, "format", StorageFormat::NAMES, StorageFormat::Auto)?;
    p.bool_or("accel", true)?;
    Ok(TextureSpec::Bitmap(BitmapSpec { filename, raw, filter, wrap, format }))
}
