//! Textures: Mitsuba 3.9.1's `bitmap` (src/textures/bitmap.cpp over include/mitsuba/core/bitmap.h and
//! Dr.Jit's `Texture`), `checkerboard` (src/textures/checkerboard.cpp), `mesh_attribute`
//! (src/textures/mesh_attribute.cpp: read at a [`TexEval`]'s [`MeshPoint`]), `rawconstant`
//! (src/spectra/rawconstant.cpp: a constant as written) and the constant values Mitsuba
//! makes of an `<rgb>`/`<float>` (`srgb`/`uniform`, src/spectra/srgb.cpp), as its RGB variants evaluate
//! them at a texture coordinate. The material layer binds them to BSDF and emitter parameters; this
//! module knows no scene, BSDF or file format of scenes.
//!
//! ```toml
//! # a bitmap (keys and defaults as Mitsuba's)
//! diffuse_reflectance = { type = "bitmap", filename = "textures/wood.png", raw = false,
//!                         filter_type = "bilinear", wrap_mode = "repeat", format = "auto" }
//! # bilinear | nearest; repeat | mirror | clamp; auto | variant | float16 (fp16) | uint8
//! # a checkerboard (defaults: color0 0.4, color1 0.2)
//! reflectance = { type = "checkerboard", color0 = [0.1, 0.1, 0.1], color1 = 0.5 }
//! # both take `to_uv`, a 2-D affine transform of the texture coordinates (read by the scene layer)
//! # a mesh's per-vertex or per-face attribute (`mesh_attribute`; scale default 1)
//! reflectance = { type = "mesh_attribute", name = "vertex_color", scale = 1.0 }
//! # one value or three as written, no colour conversion or range check (`rawconstant`)
//! normalmap = { type = "rawconstant", value = [0.5, 0.5, 1.0] }
//! ```
//!
//! Texture coordinates as Mitsuba's: `(0, 0)` is the top-left corner of the image as stored in the file
//! (its first row), `u` runs along a row, `v` down the rows; `to_uv` applies first. A bilinear lookup
//! reads the four texels around `uv·size − ½` (texel centres at half-integers), a nearest lookup the
//! texel containing `uv·size`; texel indices outside the image wrap as [`WrapMode`] says.
//!
//! Images are decoded once per [`ImageCache`] into linear f32 texels, one or three channels per texel in
//! rows ([`TextureImage`]), the form a lookup reads fastest; what Mitsuba's storage precision (`format`)
//! does to the values (half precision for 16-bit and half-float sources) is applied at load, so lookups
//! give Mitsuba's numbers. Formats: PNG (8/16-bit; grey, grey+alpha, RGB, RGBA, palette), JPEG, OpenEXR
//! (R,G,B[,A] or Y[,A] channels, half or float), Radiance HDR, PFM and uncompressed BMP (`bmp`),
//! recognised by their first bytes as Mitsuba does. Alpha is dropped (Mitsuba's RGB variants store `Y` or `RGB`, `target_pixel_format`).

mod bitmap;
mod bmp;
mod cache;
mod checkerboard;
mod decode;
mod mesh_attribute;
mod rawconstant;
mod texels;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

pub use bitmap::{Bitmap, FilterType, WrapMode};
pub use cache::ImageCache;
pub use checkerboard::Checkerboard;
pub use decode::FileFormat;
pub use mesh_attribute::{AttributeTable, MeshAttribute, MeshPoint};
pub use texels::{srgb_to_linear, StorageFormat, TextureImage};

use crate::math::{Mat3, Vec2, Vec3};
use crate::props::{Plugin, PropError, Props, Textured};

/// Mitsuba's `luminance` of a linear RGB colour (include/mitsuba/core/spectrum.h): what `eval_1` and
/// `mean` of an RGB bitmap report.
#[inline]
#[must_use]
pub fn luminance(c: Vec3) -> f32 {
    c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169
}

/// The texture coordinates at barycentrics `(u, v)` of a triangle whose corners have `corners`:
/// `(1 − u − v)·c₀ + u·c₁ + v·c₂` (Mitsuba's `Mesh::compute_surface_interaction`). The one rule for a hit
/// (`Scene::tex_uv`) and for a point sampled on a textured area light (`light::AreaLight`); a triangle
/// without texture coordinates passes [`BARYCENTRIC_UVS`], which gives `(u, v)` itself, exactly.
#[inline]
#[must_use]
pub fn interpolate_uv(corners: [Vec2; 3], u: f32, v: f32) -> Vec2 {
    let [a, b, c] = corners;
    (1.0 - u - v) * a + u * b + v * c
}

/// The corners' texture coordinates of a triangle of a shape without any: [`interpolate_uv`] then gives
/// the barycentrics, as Mitsuba's meshes without uvs do.
pub const BARYCENTRIC_UVS: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

/// Mitsuba's `mean()` of a constant colour (`srgb`'s `dr::mean`, also its `eval_1`): the channel average.
#[inline]
fn channel_mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Where a texture is evaluated: the texture coordinates and, at a hit on a mesh, the point on the mesh
/// (what `mesh_attribute` reads; `None` elsewhere, e.g. on an emitter). A bare `Vec2` converts into one.
#[derive(Clone, Copy, Debug)]
pub struct TexEval<'a> {
    pub uv: Vec2,
    pub mesh: Option<MeshPoint<'a>>,
}

impl From<Vec2> for TexEval<'static> {
    #[inline]
    fn from(uv: Vec2) -> Self {
        Self { uv, mesh: None }
    }
}

/// A texture, loaded: what a parameter reads at a texture coordinate (or a point on a mesh).
#[derive(Clone, Debug)]
pub enum Texture {
    /// A constant colour (Mitsuba's `srgb` texture made of an `<rgb>`, or `uniform` of a `<float>`).
    Constant(Vec3),
    Bitmap(Bitmap),
    Checkerboard(Checkerboard),
    MeshAttribute(MeshAttribute),
}

impl Texture {
    /// The colour at `uv` (Mitsuba's `eval` in an RGB variant; a one-channel bitmap gives its value in
    /// all three channels).
    #[inline]
    #[must_use]
    pub fn eval_rgb<'a>(&self, at: impl Into<TexEval<'a>>) -> Vec3 {
        let at = at.into();
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.eval_rgb(at.uv),
            Texture::Checkerboard(c) => c.eval_rgb(at.uv),
            Texture::MeshAttribute(a) => a.eval_rgb(at.mesh.as_ref()),
        }
    }

    /// One number at `uv` (Mitsuba's `eval_1`): a one-channel bitmap's value, an RGB bitmap's
    /// [`luminance`], a constant's channel average; a checkerboard's is its colours' channel average with
    /// the colours the other way round than `eval` (see [`Checkerboard::eval_1`]).
    #[inline]
    #[must_use]
    pub fn eval_1<'a>(&self, at: impl Into<TexEval<'a>>) -> f32 {
        let at = at.into();
        match self {
            Texture::Constant(c) => channel_mean(*c),
            Texture::Bitmap(b) => b.eval_1(at.uv),
            Texture::Checkerboard(c) => c.eval_1(at.uv),
            Texture::MeshAttribute(a) => a.eval_1(at.mesh.as_ref()),
        }
    }

    /// The gradient of [`Texture::eval_1`] with respect to `(u, v)` (Mitsuba's `eval_1_grad`, which
    /// `bumpmap` reads): a bitmap's ([`Bitmap::eval_1_grad`]); zero for a constant and a checkerboard, whose
    /// value is flat wherever it is differentiable (Mitsuba has no `eval_1_grad` for them and refuses them
    /// under a `bumpmap`; here they leave its normals unperturbed); zero for a mesh attribute too (no
    /// gradient in `(u, v)`; Mitsuba refuses it there as well).
    #[inline]
    #[must_use]
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(uv),
            Texture::Constant(_) | Texture::Checkerboard(_) | Texture::MeshAttribute(_) => Vec2::ZERO,
        }
    }

    /// Mitsuba's `mean()`, a single number: a bitmap's mean over its texels of [`luminance`] (or of its
    /// value, one channel), a constant's channel average, a checkerboard's average of its two colours'
    /// channel averages. (Mitsuba's `plastic` and `roughplastic` weigh their sampling by it.)
    #[must_use]
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Constant(c) => channel_mean(*c),
            Texture::Bitmap(b) => b.image().mean(),
            Texture::Checkerboard(c) => 0.5 * (channel_mean(c.color0) + channel_mean(c.color1)),
            Texture::MeshAttribute(a) => a.summary_before_load().mean_1,
        }
    }

    /// What a plugin's constructor and the material layer see of the texture before any hit
    /// (`props::Textured`): its per-channel mean, its mean number and its per-channel maximum (a mesh
    /// attribute's before the meshes are read: [`MeshAttribute::summary_before_load`]).
    #[must_use]
    pub fn summary(&self) -> Textured {
        Textured { mean: self.mean_rgb(), mean_1: self.mean(), max: self.max(), min: self.min() }
    }

    /// Each channel's mean over the texture (a bitmap: over its texels; a checkerboard: half of each
    /// colour): e.g. the mean radiance of a textured emitter.
    #[must_use]
    pub fn mean_rgb(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.image().mean_rgb(),
            Texture::Checkerboard(c) => 0.5 * (c.color0 + c.color1),
            Texture::MeshAttribute(a) => a.summary_before_load().mean,
        }
    }

    /// Each channel's largest value anywhere on the texture (an interpolated value never exceeds the
    /// largest texel): whether a parameter can be nonzero anywhere, with [`Texture::min`].
    #[must_use]
    pub fn max(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.image().max(),
            Texture::Checkerboard(c) => c.color0.max(c.color1),
            Texture::MeshAttribute(a) => a.summary_before_load().max,
        }
    }

    /// Each channel's smallest value anywhere on the texture.
    #[must_use]
    pub fn min(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.image().min(),
            Texture::Checkerboard(c) => c.color0.min(c.color1),
            Texture::MeshAttribute(a) => a.summary_before_load().min,
        }
    }

    /// Width and height in texels (Mitsuba's `resolution()`): a bitmap's image's, 1 × 1 for the others.
    #[must_use]
    pub fn resolution(&self) -> (u32, u32) {
        match self {
            Texture::Bitmap(b) => (b.image().width(), b.image().height()),
            Texture::Constant(_) | Texture::Checkerboard(_) | Texture::MeshAttribute(_) => (1, 1),
        }
    }

    /// Whether the value depends on the texture coordinate (Mitsuba's `is_spatially_varying`).
    #[must_use]
    pub fn is_spatially_varying(&self) -> bool {
        !matches!(self, Texture::Constant(_))
    }

    /// The same texture with `to_uv` (a 2-D affine transform as a 3×3 matrix: `uv' = M·(u, v, 1)`, its
    /// last row ignored as Mitsuba's `ScalarAffineTransform3f`) applied to the coordinates before the
    /// lookup. A constant and a mesh attribute ignore it.
    #[must_use]
    pub fn with_to_uv(self, to_uv: Mat3) -> Self {
        match self {
            Texture::Constant(_) | Texture::MeshAttribute(_) => self,
            Texture::Bitmap(b) => Texture::Bitmap(b.with_to_uv(to_uv)),
            Texture::Checkerboard(c) => Texture::Checkerboard(Checkerboard { to_uv, ..c }),
        }
    }

    /// The bytes of decoded texels this texture holds (its image's; several textures may share one image:
    /// [`ImageCache::memory_bytes`] counts each image once).
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        match self {
            Texture::Bitmap(b) => b.image().memory_bytes(),
            Texture::Constant(_) | Texture::Checkerboard(_) | Texture::MeshAttribute(_) => 0,
        }
    }
}

/// A `bitmap` as the scene file gives it, not yet loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct BitmapSpec {
    /// The file name as written (relative names resolve against the scene's directory at load).
    pub filename: String,
    /// `raw`: no sRGB decoding of 8- and 16-bit images.
    pub raw: bool,
    pub filter: FilterType,
    pub wrap: WrapMode,
    pub format: StorageFormat,
}

/// What the scene file says of a texture, not yet loaded (no file read).
#[derive(Clone, Debug, PartialEq)]
pub enum TextureSpec {
    Constant(Vec3),
    Bitmap(BitmapSpec),
    Checkerboard { color0: Vec3, color1: Vec3 },
    /// `mesh_attribute`: the attribute's name and scale.
    MeshAttribute { name: String, scale: f32 },
}

impl TextureSpec {
    /// The texture: a bitmap's image is read through `cache` (each file decoded once per cache and set of
    /// decoding options, however many textures use it), a relative file name resolved against `base_dir`.
    pub fn load(&self, base_dir: &Path, cache: &mut ImageCache) -> Result<Texture, TextureError> {
        Ok(match self {
            TextureSpec::Constant(c) => Texture::Constant(*c),
            TextureSpec::Checkerboard { color0, color1 } => {
                Texture::Checkerboard(Checkerboard { color0: *color0, color1: *color1, to_uv: Mat3::IDENTITY })
            }
            // (The scene layer sets `table`.)
            TextureSpec::MeshAttribute { name, scale } => Texture::MeshAttribute(MeshAttribute { name: name.clone(), scale: *scale, table: 0 }),
            TextureSpec::Bitmap(spec) => {
                let path = base_dir.join(&spec.filename);
                let image = cache.load(&path, spec.raw, spec.format)?;
                Texture::Bitmap(Bitmap::new(image, spec.filter, spec.wrap))
            }
        })
    }
}

/// A texture's file that cannot be used; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: not an image caustica reads (PNG, JPEG, OpenEXR, Radiance HDR or PFM, recognised by the file's first bytes; Mitsuba also reads BMP, TGA and PPM)")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: not a readable {} image: {message}", format.name())]
    Decode { path: PathBuf, format: FileFormat, message: String },
    #[error("{path}: {what}")]
    Unsupported { path: PathBuf, what: String },
    #[error("{path}: the image is empty ({width}×{height} pixels)")]
    Empty { path: PathBuf, width: u64, height: u64 },
    #[error("{path}: its header declares {width}×{height} pixels, which take {} to read and keep, more than the {} left of the texture memory limit ({}): a corrupt header, or images too large for this machine", crate::sys::gb(*bytes), crate::sys::gb(*available), crate::sys::gb(*limit))]
    TooLarge { path: PathBuf, width: u64, height: u64, bytes: u64, available: u64, limit: u64 },
    #[error("{path}: pixel ({x}, {y}) (from the top left) has a non-finite value ({value}); textures must be finite")]
    NonFinite { path: PathBuf, x: u32, y: u32, value: f32 },
}

/// The texture types the scene files name (Mitsuba's plugin names), with their keys and constructors.
#[cfg_attr(not(test), allow(dead_code))] // read by the scene layer's texture descriptions (to be wired)
pub(crate) const PLUGINS: &[&Plugin<TextureSpec>] = &[&bitmap::PLUGIN, &checkerboard::PLUGIN, &mesh_attribute::PLUGIN, &rawconstant::PLUGIN];

/// The texture plugin named `name`.
#[cfg_attr(not(test), allow(dead_code))] // as PLUGINS
#[must_use]
pub(crate) fn plugin(name: &str) -> Option<&'static Plugin<TextureSpec>> {
    crate::props::find(PLUGINS, name)
}

/// A string key that must be one of `names` (Mitsuba's spelling), or `default` when absent.
fn choice_or<T: Copy>(p: &Props<'_, ()>, key: &str, names: &[(&str, T)], default: T) -> Result<T, PropError> {
    let Some(s) = p.string(key)? else { return Ok(default) };
    names.iter().find(|(n, _)| *n == s).map(|&(_, v)| v).ok_or_else(|| {
        let list: Vec<String> = names.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        PropError::new(key, format!("\"{s}\" is not one of {}", list.join(", ")))
    })
}
