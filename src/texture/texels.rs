//! A decoded texture image: linear f32 texels in rows, one (grey) or three (RGB) channels, as Mitsuba
//! 3.9.1's `BitmapTexture` holds it after loading (src/textures/bitmap.cpp: `load_bitmap`,
//! `prepare_bitmap`, `rebuild_internals`), with the statistics its `mean()` and the material layer read.
//!
//! From the file's samples ([`super::decode`]) to texels, as Mitsuba does in its RGB variants:
//! - alpha is dropped (`target_pixel_format`: Y/YA → Y, RGB/RGBA → RGB; no premultiplication);
//! - sRGB-encoded samples (8- and 16-bit PNG, JPEG) are decoded to linear unless `raw`
//!   (`v ≤ 0.04045 ? v/12.92 : ((v + 0.055)/1.055)^2.4`, of `k/255` or `k/65535`); `raw` samples and the
//!   float formats keep their values (`k/255`, `k/65535`);
//! - the storage precision (`format`, [`StorageFormat`]) rounds: `auto` keeps 8-bit sources exact (Mitsuba
//!   stores the bytes and decodes them at each lookup, the same numbers), rounds 16-bit and half-float
//!   sources to half precision (it stores them as `float16`), keeps float sources; `float16` rounds every
//!   source to half; `variant` keeps every value in f32; `uint8` is `auto` for 8-bit sources;
//! - an image narrower or lower than 2 texels is padded to 2 by repeating its last column or row
//!   (`Bitmap::pad_to`), which changes how it wraps.

use std::path::{Path, PathBuf};

use super::decode::{Decoded, FileFormat, Samples};
use super::{luminance, TextureError};
use crate::math::Vec3;

/// Mitsuba's `format` key of `bitmap`: the precision the texels are stored at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum StorageFormat {
    /// 8-bit sources as they are, 16-bit and half sources as half floats, float sources as floats.
    #[default]
    Auto,
    /// Single-precision floats whatever the source.
    Variant,
    /// Half floats whatever the source (`float16`, or `fp16`).
    Float16,
    /// 8 bits per channel: the same as `Auto` for an 8-bit source; for others Mitsuba quantises with
    /// dithering, which caustica refuses rather than imitate.
    UInt8,
}

impl StorageFormat {
    /// Mitsuba's spellings (`fp16` kept for backwards compatibility, as Mitsuba does).
    pub(super) const NAMES: &'static [(&'static str, StorageFormat)] = &[
        ("auto", StorageFormat::Auto),
        ("variant", StorageFormat::Variant),
        ("float16", StorageFormat::Float16),
        ("fp16", StorageFormat::Float16),
        ("uint8", StorageFormat::UInt8),
    ];
}

/// The linear value of an sRGB-encoded `v ∈ [0, 1]` (IEC 61966-2-1; Mitsuba's `srgb_to_linear`).
#[must_use]
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// A decoded image: `width × height` texels of `channels` (1 or 3) linear f32 values, row-major from
/// the top row (the `v = 0` edge), with its statistics.
pub struct TextureImage {
    width: u32,
    height: u32,
    channels: usize,
    data: Vec<f32>,
    /// Mitsuba's `m_mean`: the mean over the texels of their luminance (RGB) or value (grey).
    mean: f32,
    mean_rgb: Vec3,
    min: Vec3,
    max: Vec3,
    source: Source,
}

/// Where an image came from and how it was decoded (for messages, `Debug` and the cache).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Source {
    pub path: PathBuf,
    pub format: Option<FileFormat>,
    /// The size in the file (before padding).
    pub width: u32,
    pub height: u32,
    pub depth: &'static str,
    /// sRGB samples were decoded to linear.
    pub srgb_decoded: bool,
    /// Values were rounded to half precision.
    pub half: bool,
}

impl std::fmt::Debug for TextureImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TextureImage")
            .field("path", &self.source.path)
            .field("format", &self.source.format)
            .field("size", &(self.width, self.height))
            .field("channels", &self.channels)
            .field("depth", &self.source.depth)
            .field("srgb_decoded", &self.source.srgb_decoded)
            .field("half", &self.source.half)
            .field("mean", &self.mean)
            .finish_non_exhaustive()
    }
}

impl TextureImage {
    /// An image from a file's samples, decoded as Mitsuba's RGB variants load it (module docs).
    pub(super) fn from_decoded(path: &Path, d: Decoded, raw: bool, format: StorageFormat) -> Result<Self, TextureError> {
        let depth = d.samples.depth_name();
        let half = match format {
            StorageFormat::Auto => d.samples.bytes_per_sample() == 2,
            StorageFormat::Variant => false,
            StorageFormat::Float16 => true,
            StorageFormat::UInt8 if d.samples.bytes_per_sample() == 1 => false,
            StorageFormat::UInt8 => {
                return Err(TextureError::Unsupported {
                    path: path.to_path_buf(),
                    what: format!("format = \"uint8\" on a {depth} image: Mitsuba quantises it to 8 bits with dithering, which caustica does not reproduce (use \"auto\")"),
                })
            }
        };
        let srgb_decoded = d.srgb && !raw;
        let out_channels = if d.channels <= 2 { 1 } else { 3 };
        let pixels = d.width as usize * d.height as usize;
        // `decode::read` checked that the samples make `pixels × channels`.
        let round = |v: f32| if half { half::f16::from_f32(v).to_f32() } else { v };
        let mut data = Vec::with_capacity(pixels * out_channels);
        let mut gather = |value: &dyn Fn(usize) -> f32| {
            for p in 0..pixels {
                for c in 0..out_channels {
                    data.push(round(value(p * d.channels + c)));
                }
            }
        };
        match &d.samples {
            Samples::U8(s) => {
                let table: Vec<f32> = (0..=255u8)
                    .map(|k| if srgb_decoded { srgb_to_linear(f64::from(k) / 255.0) as f32 } else { f32::from(k) * (1.0 / 255.0) })
                    .collect();
                gather(&|i| table[s[i] as usize]);
            }
            Samples::U16(s) => {
                let table: Vec<f32> = (0..=u16::MAX)
                    .map(|k| if srgb_decoded { srgb_to_linear(f64::from(k) / 65535.0) as f32 } else { f32::from(k) / 65535.0 })
                    .collect();
                gather(&|i| table[s[i] as usize]);
            }
            Samples::Half(s) | Samples::F32(s) => gather(&|i| s[i]),
        }
        let source = Source {
            path: path.to_path_buf(),
            format: Some(d.format),
            width: d.width,
            height: d.height,
            depth,
            srgb_decoded,
            half,
        };
        Self::build(source, d.width, d.height, out_channels, data)
    }

    /// An image of linear texels given in memory: `channels` (1 or 3) values per texel, rows from the top;
    /// `name` stands for its file in messages. Padded to 2×2 as a file's image.
    pub fn from_linear(name: &str, width: u32, height: u32, channels: usize, data: Vec<f32>) -> Result<Self, TextureError> {
        let path = PathBuf::from(name);
        if width == 0 || height == 0 {
            return Err(TextureError::Empty { path, width: width.into(), height: height.into() });
        }
        if !(channels == 1 || channels == 3) || data.len() as u64 != u64::from(width) * u64::from(height) * channels as u64 {
            let what = format!("{} values do not make {width}×{height} texels of 1 or 3 channels ({channels} given)", data.len());
            return Err(TextureError::Unsupported { path, what });
        }
        let source = Source { path, format: None, width, height, depth: "float", srgb_decoded: false, half: false };
        Self::build(source, width, height, channels, data)
    }

    /// Pads to 2×2, checks every value is finite and takes the statistics.
    fn build(source: Source, width: u32, height: u32, channels: usize, mut data: Vec<f32>) -> Result<Self, TextureError> {
        for (i, v) in data.iter().enumerate() {
            if !v.is_finite() {
                let p = (i / channels) as u64;
                let (x, y) = ((p % u64::from(width)) as u32, (p / u64::from(width)) as u32);
                return Err(TextureError::NonFinite { path: source.path, x, y, value: *v });
            }
        }
        let (width, height) = pad_to_2(&mut data, width, height, channels);
        let texels = data.len() / channels;
        let mut sum = [0f64; 3];
        let mut lum_sum = 0f64;
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for t in data.chunks_exact(channels) {
            let c = if channels == 1 { Vec3::splat(t[0]) } else { Vec3::new(t[0], t[1], t[2]) };
            for k in 0..3 {
                sum[k] += f64::from(c[k]);
            }
            lum_sum += f64::from(if channels == 1 { t[0] } else { luminance(c) });
            min = min.min(c);
            max = max.max(c);
        }
        let n = texels as f64;
        let mean_rgb = Vec3::new((sum[0] / n) as f32, (sum[1] / n) as f32, (sum[2] / n) as f32);
        Ok(TextureImage { width, height, channels, data, mean: (lum_sum / n) as f32, mean_rgb, min, max, source })
    }

    /// Width in texels (at least 2).
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels (at least 2).
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Values per texel: 1 (grey) or 3 (RGB).
    #[must_use]
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The texels, row-major from the top, `channels` values each.
    #[inline]
    #[must_use]
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Texel `(x, y)` (from the top left) as RGB (grey: its value three times).
    #[must_use]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        let i = (y as usize * self.width as usize + x as usize) * self.channels;
        if self.channels == 1 {
            Vec3::splat(self.data[i])
        } else {
            Vec3::new(self.data[i], self.data[i + 1], self.data[i + 2])
        }
    }

    /// Mitsuba's `mean()` of the bitmap: the texels' mean luminance (RGB) or value (grey).
    #[must_use]
    pub fn mean(&self) -> f32 {
        self.mean
    }

    /// Each channel's mean over the texels.
    #[must_use]
    pub fn mean_rgb(&self) -> Vec3 {
        self.mean_rgb
    }

    /// Each channel's smallest texel value.
    #[must_use]
    pub fn min(&self) -> Vec3 {
        self.min
    }

    /// Each channel's largest texel value.
    #[must_use]
    pub fn max(&self) -> Vec3 {
        self.max
    }

    /// Bytes the texels take.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        (self.data.len() * std::mem::size_of::<f32>()) as u64
    }

    /// The file it was read from (or the name given to [`TextureImage::from_linear`]).
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.source.path
    }

    /// The file's format (`None`: made in memory).
    #[must_use]
    pub fn format(&self) -> Option<FileFormat> {
        self.source.format
    }

    pub(super) fn source(&self) -> &Source {
        &self.source
    }
}

/// The bytes an image of `width × height` file pixels keeps as texels of `channels` values (after padding).
pub(super) fn stored_bytes(width: u64, height: u64, channels: u64) -> u64 {
    width.max(2).saturating_mul(height.max(2)).saturating_mul(channels).saturating_mul(4)
}

/// Mitsuba's `Bitmap::pad_to(2)`: repeats the last column, then the last row, until the image is at least
/// 2×2. Returns the new size.
fn pad_to_2(data: &mut Vec<f32>, width: u32, height: u32, channels: usize) -> (u32, u32) {
    let (w, h) = (width.max(2), height.max(2));
    if (w, h) == (width, height) {
        return (w, h);
    }
    let (src_row, dst_row) = (width as usize * channels, w as usize * channels);
    let mut out = Vec::with_capacity(dst_row * h as usize);
    for y in 0..height as usize {
        let row = &data[y * src_row..(y + 1) * src_row];
        out.extend_from_slice(row);
        let last = &row[src_row - channels..];
        for _ in width..w {
            out.extend_from_slice(last);
        }
    }
    for _ in height..h {
        let start = out.len() - dst_row;
        out.extend_from_within(start..start + dst_row);
    }
    *data = out;
    (w, h)
}
