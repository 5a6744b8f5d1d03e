//! The film: where the renderer accumulates samples, and the images it writes.
//!
//! - [`Film`] keeps, for every pixel of its crop window, the **exact** sum of the RGB samples
//!   ([`exact::ExactSum`]), the f64 sum of their squared luminance (for the per-pixel variance) and the
//!   number of samples.
//! - Parallel rendering: split the crop window with [`Film::tiles`], let each worker fill a [`TileBuffer`]
//!   for its tile (f64 sums, samples added in the order the worker takes them), then [`Film::merge_tile`].
//!   A tile buffer's f64 sums are added to the film's RGB sums exactly, so the image does not depend on
//!   the order in which tile buffers are merged, nor on how they are grouped: a render's passes and tiles
//!   can be rendered by separate processes and their films added ([`Film::add_film`], `render::part`)
//!   into the bits one process makes, provided each (pass, tile) buffer is filled the same way.
//!   The luminance² sums are plain f64 additions: the variance may differ in the last bit between
//!   groupings (it is a statistic, not part of the image).
//! - Non-finite samples (NaN or ±∞ in any channel) are **not** accumulated: they are counted
//!   ([`Film::nan_count`], [`Film::inf_count`]) and still count as a sample of their pixel, i.e. they act
//!   as a zero-valued sample, so every pixel keeps the same sample count and its mean stays comparable.
//! - [`Film::image`] gives the per-pixel mean as an [`Image`]; [`io`] reads and writes EXR/PNG atomically.
//!
//! Box pixel filter: a sample contributes only to the pixel it was taken in.

pub mod exact;
mod image;
pub mod io;
pub mod partial;

pub use self::exact::ExactSum;
pub use self::image::{luminance, luminance_f64, Image, LUMINANCE_WEIGHTS};
pub use io::{read_exr, write_exr, write_png, ImageError, Tonemap};

use crate::math::Vec3;

/// A pixel rectangle `[x0, x1) × [y0, y1)` in film coordinates (row 0 = top).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

/// A tile of the crop window, in film coordinates.
pub type Tile = Rect;

impl Rect {
    #[must_use]
    pub fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Self {
        Self { x0, y0, x1, y1 }
    }

    #[must_use]
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    #[must_use]
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Number of pixels.
    #[must_use]
    pub fn area(&self) -> u64 {
        u64::from(self.width()) * u64::from(self.height())
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    #[must_use]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    /// `true` if `other` lies entirely inside `self`.
    #[must_use]
    pub fn contains_rect(&self, other: &Rect) -> bool {
        other.x0 >= self.x0 && other.y0 >= self.y0 && other.x1 <= self.x1 && other.y1 <= self.y1
    }

    /// Row-major index of `(x, y)` inside the rectangle, `None` outside.
    #[must_use]
    #[inline]
    fn index(&self, x: u32, y: u32) -> Option<usize> {
        self.contains(x, y)
            .then(|| (y - self.y0) as usize * self.width() as usize + (x - self.x0) as usize)
    }
}

/// Errors from building or combining films (programming errors surfaced as values, not panics).
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum FilmError {
    #[error("crop window {crop:?} is empty or not inside the {width}×{height} film")]
    InvalidCrop { width: u32, height: u32, crop: Rect },
    #[error("tile {tile:?} is not inside the film's crop window {crop:?}")]
    TileOutsideCrop { tile: Rect, crop: Rect },
    #[error("cannot add a {other_width}×{other_height} film with crop {other_crop:?} to a {width}×{height} film with crop {crop:?}")]
    Mismatch {
        width: u32,
        height: u32,
        crop: Rect,
        other_width: u32,
        other_height: u32,
        other_crop: Rect,
    },
}

/// Samples of one pixel in a [`TileBuffer`]: plain f64 sums in the order the samples were added.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SampleSum {
    rgb: [f64; 3],
    lum_sq: f64,
    count: u64,
}

/// What happened to one added sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SampleKind {
    Finite,
    Nan,
    Inf,
}

/// Sorts a sample: counted in any case, its finite channels as f64 and its luminance, or its kind.
#[inline]
fn finite_sample(rgb: Vec3) -> Result<[f64; 3], SampleKind> {
    if rgb.is_nan() {
        return Err(SampleKind::Nan);
    }
    if !rgb.is_finite() {
        return Err(SampleKind::Inf);
    }
    Ok([f64::from(rgb.x), f64::from(rgb.y), f64::from(rgb.z)])
}

impl SampleSum {
    #[inline]
    fn add(&mut self, rgb: Vec3) -> SampleKind {
        self.count += 1;
        match finite_sample(rgb) {
            Ok(c) => {
                self.rgb[0] += c[0];
                self.rgb[1] += c[1];
                self.rgb[2] += c[2];
                let y = luminance_f64(c);
                self.lum_sq += y * y;
                SampleKind::Finite
            }
            Err(kind) => kind,
        }
    }
}

/// Accumulated samples of one pixel of the film.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSum {
    /// Σ rgb over the finite samples, exact.
    pub rgb: [ExactSum; 3],
    /// Σ Y² (Y = luminance) over the finite samples. Σ Y itself is `luminance_f64(rgb)` by linearity.
    pub lum_sq: f64,
    /// Number of samples taken in this pixel, including non-finite ones (which add nothing to the sums).
    pub count: u64,
}

impl PixelSum {
    #[inline]
    fn add(&mut self, rgb: Vec3) -> SampleKind {
        self.count += 1;
        match finite_sample(rgb) {
            Ok(c) => {
                for (s, v) in self.rgb.iter_mut().zip(c) {
                    s.add_f64(v);
                }
                let y = luminance_f64(c);
                self.lum_sq += y * y;
                SampleKind::Finite
            }
            Err(kind) => kind,
        }
    }

    /// Adds a tile buffer's sums (RGB exactly).
    #[inline]
    fn add_samples(&mut self, o: &SampleSum) {
        for (s, v) in self.rgb.iter_mut().zip(o.rgb) {
            s.add_f64(v);
        }
        self.lum_sq += o.lum_sq;
        self.count += o.count;
    }

    /// Adds another pixel's sums (RGB exactly).
    #[inline]
    pub fn merge(&mut self, o: &PixelSum) {
        for (s, v) in self.rgb.iter_mut().zip(&o.rgb) {
            s.add(v);
        }
        self.lum_sq += o.lum_sq;
        self.count += o.count;
    }

    /// Σ rgb rounded to f64.
    #[must_use]
    pub fn rgb_f64(&self) -> [f64; 3] {
        [self.rgb[0].to_f64(), self.rgb[1].to_f64(), self.rgb[2].to_f64()]
    }

    /// Mean RGB (zero for a pixel without samples).
    #[must_use]
    pub fn mean(&self) -> [f64; 3] {
        if self.count == 0 {
            return [0.0; 3];
        }
        let n = self.count as f64;
        let s = self.rgb_f64();
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// Unbiased sample variance of the luminance of this pixel's samples,
    /// `(Σ Y² − (Σ Y)²/n) / (n − 1)` (clamped at 0 against rounding); `None` with fewer than 2 samples.
    #[must_use]
    pub fn luminance_variance(&self) -> Option<f64> {
        if self.count < 2 {
            return None;
        }
        let n = self.count as f64;
        let sum_y = luminance_f64(self.rgb_f64());
        Some(((self.lum_sq - sum_y * sum_y / n) / (n - 1.0)).max(0.0))
    }
}

/// Counts the non-finite samples seen by an accumulator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct NonFinite {
    nan: u64,
    inf: u64,
}

impl NonFinite {
    #[inline]
    fn record(&mut self, kind: SampleKind) {
        match kind {
            SampleKind::Finite => {}
            SampleKind::Nan => self.nan += 1,
            SampleKind::Inf => self.inf += 1,
        }
    }
}

/// Per-tile accumulator owned by one worker; merged into the film with [`Film::merge_tile`].
#[derive(Clone, Debug)]
pub struct TileBuffer {
    tile: Tile,
    pixels: Vec<SampleSum>,
    non_finite: NonFinite,
}

impl TileBuffer {
    /// An empty buffer for `tile` (film coordinates).
    #[must_use]
    pub fn new(tile: Tile) -> Self {
        Self {
            tile,
            pixels: vec![SampleSum::default(); tile.area() as usize],
            non_finite: NonFinite::default(),
        }
    }

    /// Empties the buffer and points it at `tile`, reusing its allocation.
    pub fn reset(&mut self, tile: Tile) {
        self.tile = tile;
        self.pixels.clear();
        self.pixels.resize(tile.area() as usize, SampleSum::default());
        self.non_finite = NonFinite::default();
    }

    #[must_use]
    pub fn tile(&self) -> Tile {
        self.tile
    }

    /// Adds one sample taken in pixel `(x, y)` (film coordinates, inside the tile).
    /// A sample outside the tile is a caller bug: it asserts in debug builds and is ignored in release.
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, rgb: Vec3) {
        debug_assert!(self.tile.contains(x, y), "sample at ({x}, {y}) outside tile {:?}", self.tile);
        if let Some(i) = self.tile.index(x, y) {
            let kind = self.pixels[i].add(rgb);
            self.non_finite.record(kind);
        }
    }

    /// Number of NaN samples added to this buffer.
    #[must_use]
    pub fn nan_count(&self) -> u64 {
        self.non_finite.nan
    }

    /// Number of infinite (non-NaN) samples added to this buffer.
    #[must_use]
    pub fn inf_count(&self) -> u64 {
        self.non_finite.inf
    }
}

/// The accumulation film. See the module documentation.
#[derive(Clone, Debug)]
pub struct Film {
    width: u32,
    height: u32,
    crop: Rect,
    pixels: Vec<PixelSum>,
    non_finite: NonFinite,
}

impl Film {
    /// A `width × height` film recording every pixel. Errors if either size is zero.
    pub fn new(width: u32, height: u32) -> Result<Self, FilmError> {
        Self::with_crop(width, height, Rect::new(0, 0, width, height))
    }

    /// A `width × height` film that records only the pixels of `crop` (film coordinates).
    /// Errors if `crop` is empty or not inside the film.
    pub fn with_crop(width: u32, height: u32, crop: Rect) -> Result<Self, FilmError> {
        if crop.is_empty() || !Rect::new(0, 0, width, height).contains_rect(&crop) {
            return Err(FilmError::InvalidCrop { width, height, crop });
        }
        Ok(Self {
            width,
            height,
            crop,
            pixels: vec![PixelSum::default(); crop.area() as usize],
            non_finite: NonFinite::default(),
        })
    }

    /// Full film width (not the crop's).
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Full film height (not the crop's).
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    #[must_use]
    pub fn crop(&self) -> Rect {
        self.crop
    }

    /// Tiles of at most `tile_size × tile_size` pixels covering the crop window exactly once, in scan
    /// order (left to right, then top to bottom); border tiles are smaller. `tile_size = 0` is taken as 1.
    #[must_use]
    pub fn tiles(&self, tile_size: u32) -> Vec<Tile> {
        let s = tile_size.max(1);
        let mut tiles = Vec::new();
        let mut y0 = self.crop.y0;
        while y0 < self.crop.y1 {
            let y1 = y0.saturating_add(s).min(self.crop.y1);
            let mut x0 = self.crop.x0;
            while x0 < self.crop.x1 {
                let x1 = x0.saturating_add(s).min(self.crop.x1);
                tiles.push(Rect::new(x0, y0, x1, y1));
                x0 = x1;
            }
            y0 = y1;
        }
        tiles
    }

    /// Adds one sample directly (single-threaded use). Samples outside the crop window are ignored
    /// (they assert in debug builds).
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, rgb: Vec3) {
        debug_assert!(self.crop.contains(x, y), "sample at ({x}, {y}) outside crop {:?}", self.crop);
        if let Some(i) = self.crop.index(x, y) {
            let kind = self.pixels[i].add(rgb);
            self.non_finite.record(kind);
        }
    }

    /// Adds a worker's tile buffer. Errors (and changes nothing) if its tile is not inside the crop window.
    pub fn merge_tile(&mut self, buffer: &TileBuffer) -> Result<(), FilmError> {
        let t = buffer.tile;
        if !self.crop.contains_rect(&t) {
            return Err(FilmError::TileOutsideCrop { tile: t, crop: self.crop });
        }
        let tw = t.width() as usize;
        for (row, y) in (t.y0..t.y1).enumerate() {
            let start = self.crop.index(t.x0, y).unwrap_or_default();
            let dst = &mut self.pixels[start..start + tw];
            let src = &buffer.pixels[row * tw..(row + 1) * tw];
            for (d, s) in dst.iter_mut().zip(src) {
                d.add_samples(s);
            }
        }
        self.non_finite.nan += buffer.non_finite.nan;
        self.non_finite.inf += buffer.non_finite.inf;
        Ok(())
    }

    /// Adds every sample of `other` (e.g. another pass). Both films must have the same size and crop.
    pub fn add_film(&mut self, other: &Film) -> Result<(), FilmError> {
        if (self.width, self.height, self.crop) != (other.width, other.height, other.crop) {
            return Err(FilmError::Mismatch {
                width: self.width,
                height: self.height,
                crop: self.crop,
                other_width: other.width,
                other_height: other.height,
                other_crop: other.crop,
            });
        }
        for (d, s) in self.pixels.iter_mut().zip(&other.pixels) {
            d.merge(s);
        }
        self.non_finite.nan += other.non_finite.nan;
        self.non_finite.inf += other.non_finite.inf;
        Ok(())
    }

    /// The accumulated sums of pixel `(x, y)` (film coordinates); `None` outside the crop window.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> Option<&PixelSum> {
        self.crop.index(x, y).map(|i| &self.pixels[i])
    }

    /// Unbiased sample variance of the luminance of the samples in pixel `(x, y)`;
    /// `None` outside the crop or with fewer than 2 samples. Divide by the count for the variance of the mean.
    #[must_use]
    pub fn luminance_variance(&self, x: u32, y: u32) -> Option<f64> {
        self.pixel(x, y).and_then(PixelSum::luminance_variance)
    }

    /// The per-pixel mean of the crop window as an image of the crop's size (pixel `(0, 0)` of the image is
    /// film pixel `(crop.x0, crop.y0)`). Pixels without samples are black.
    #[must_use]
    pub fn image(&self) -> Image {
        let w = self.crop.width();
        Image::from_fn(w, self.crop.height(), |x, y| {
            let m = self.pixels[y as usize * w as usize + x as usize].mean();
            Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
        })
    }

    /// Every pixel's sums, row-major over the crop window (pixel `(crop.x0, crop.y0)` first).
    #[must_use]
    pub fn sums(&self) -> &[PixelSum] {
        &self.pixels
    }

    /// A film made of stored sums (the inverse of [`Film::sums`] with [`Film::nan_count`] and
    /// [`Film::inf_count`]), for reading films back from files. Errors if `crop` is not a valid crop window
    /// of a `width × height` film; `None` if `sums` does not have one entry per pixel of the crop.
    pub fn from_sums(width: u32, height: u32, crop: Rect, sums: Vec<PixelSum>, nan: u64, inf: u64) -> Result<Option<Self>, FilmError> {
        let mut film = Self::with_crop(width, height, crop)?;
        if sums.len() != film.pixels.len() {
            return Ok(None);
        }
        film.pixels = sums;
        film.non_finite = NonFinite { nan, inf };
        Ok(Some(film))
    }

    /// Number of NaN samples added so far (not accumulated).
    #[must_use]
    pub fn nan_count(&self) -> u64 {
        self.non_finite.nan
    }

    /// Number of ±∞ samples (without NaN) added so far (not accumulated).
    #[must_use]
    pub fn inf_count(&self) -> u64 {
        self.non_finite.inf
    }

    /// Total number of samples added, non-finite ones included.
    #[must_use]
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count).sum()
    }

    /// Mean number of samples per pixel of the crop window (non-finite samples included).
    #[must_use]
    pub fn samples_per_pixel(&self) -> f64 {
        self.total_samples() as f64 / self.crop.area() as f64
    }
}

#[cfg(test)]
mod tests;
