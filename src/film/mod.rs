//! The film: where the renderer accumulates samples, and the images it writes.
//!
//! - [`Film`] keeps, for every pixel of its crop window, the **exact** sum of the filter-weighted RGB
//!   samples ([`exact::ExactSum`]), the f64 sum of the squared luminance of the samples taken in the pixel
//!   (for their variance) and their number; with a filter wider than a pixel ([`filter::PixelFilter`]),
//!   also the exact sum of the filter weights ([`PixelWeight`]). A pixel's value is `Σ w·L / Σ w`
//!   (Mitsuba's `hdrfilm`); with the box filter `w = 1` and `Σ w` is the sample count, stored once.
//! - Parallel rendering: split the crop window with [`Film::tiles`], let each worker fill a [`TileBuffer`]
//!   for its tile ([`Film::tile_buffer`]: f64 sums, samples added in the order the worker takes them; with
//!   a wide filter it covers the tile and a border of [`PixelFilter::border`] pixels, into which the
//!   tile's samples splat), then [`Film::merge_tile`]. A tile buffer's f64 sums (of f32 values: `w·L` is
//!   rounded to f32 once, deterministically) are added to the film's exact sums, so the image does not
//!   depend on the order in which tile buffers are merged, nor on how they are grouped: a render's passes
//!   and tiles can be rendered by separate processes and their films added ([`Film::add_film`],
//!   `render::part`) into the bits one process makes, provided each (pass, tile) buffer is filled the same
//!   way. The luminance sums and `Σ w²` are plain f64 additions: the variance may differ in the last bit
//!   between groupings (it is a statistic, not part of the image).
//! - Non-finite samples (NaN or ±∞ in any channel) are **not** accumulated: they are counted
//!   ([`Film::nan_count`], [`Film::inf_count`]) and still count as a sample of their pixel (and add their
//!   filter weights), i.e. they act as a zero-valued sample, so every pixel keeps the same sample count
//!   and its mean stays comparable.
//! - Statistics (of the luminance Y): [`Film::value_variance`] estimates the variance of a pixel's value;
//!   with the box filter it is `s²/n` (`s²` the sample variance of the pixel's `n` samples), under a filter
//!   the ratio estimator's `Σ w²·(Y − v)² / (Σ w)²` (`v` the pixel's value), scaled by `n'/(n' − 1)` with
//!   `n' = (Σ w)²/Σ w²` the effective sample count (so that it is `s²/n` again for `w = 1`). It counts
//!   the image's own variation within the filter's reach (at an edge) as noise, so it errs high there.
//!   [`Film::luminance_variance`] is the per-sample variance, `n` times that (`s²` for the box filter).
//!   Under a filter neighbouring pixels share samples, so their errors are correlated.
//! - [`Film::image`] gives the per-pixel value as an [`Image`]; [`io`] reads and writes EXR/PNG atomically.
//! - AOV channels ([`Film::with_aov_channels`], `scene::aov`): a sample may carry values besides its
//!   radiance ([`TileBuffer::add_at_aov`]), splatted with the same filter weights as the radiance, so that
//!   a pixel's AOV is `Σ w·a / Σ w` ([`Film::aov_planes`]; Mitsuba's film splats AOVs with the image's
//!   weights). Their sums are plain f64 (a statistic of the visible surfaces, not the image): the RGB sums
//!   and every RGB value are the same bits with or without them, and a render merged in other groupings
//!   (rounds) may differ in the AOVs' last bits.

pub mod exact;
pub mod exr_scan;
pub mod filter;
mod image;
pub mod io;
pub mod partial;

pub use self::exact::ExactSum;
pub use self::filter::PixelFilter;
pub use self::image::{luminance, luminance_f64, Image, LUMINANCE_WEIGHTS};
pub use io::{read_exr, write_exr, write_png, ImageError, Tonemap};

use crate::math::{Vec2, Vec3};

pub use crate::math::Rect;

/// A tile of the crop window, in film coordinates.
pub type Tile = Rect;

/// Errors from building or combining films (programming errors surfaced as values, not panics).
#[derive(Debug, thiserror::Error, PartialEq)]
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
    #[error("cannot add samples reconstructed with the {other} filter to a film with the {film} filter")]
    FilterMismatch { film: PixelFilter, other: PixelFilter },
    #[error("reconstruction filter: {0}")]
    Filter(#[from] filter::FilterError),
    #[error("cannot add samples with {other} AOV channels to a film with {film}")]
    AovMismatch { film: usize, other: usize },
}

/// Samples of one pixel in a [`TileBuffer`]: plain f64 sums in the order the samples were added.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SampleSum {
    /// Σ w·L (w = 1 for the box filter).
    rgb: [f64; 3],
    lum_sq: f64,
    count: u64,
}

/// The filter's sums of one pixel in a [`TileBuffer`] (wide filters only): Σ w, Σ w², Σ w²·Y, Σ w²·Y².
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct WeightSum {
    weight: f64,
    weight_sq: f64,
    wsq_lum: f64,
    wsq_lum_sq: f64,
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
    /// Σ w·rgb over the finite samples splatted into the pixel (w = 1 for the box filter), exact.
    pub rgb: [ExactSum; 3],
    /// Σ Y² (Y = luminance) over the finite samples taken in the pixel.
    pub lum_sq: f64,
    /// Number of samples taken in this pixel, including non-finite ones (which add nothing to the sums).
    pub count: u64,
}

impl PixelSum {
    /// Adds a tile buffer's sums (RGB exactly).
    #[inline]
    fn add_samples(&mut self, o: &SampleSum) {
        for (s, v) in self.rgb.iter_mut().zip(o.rgb) {
            s.add_f64(v);
        }
        self.lum_sq += o.lum_sq;
        self.count += o.count;
    }

    /// Adds what a tile buffer's sums gained since `before`, an earlier copy of them: the RGB exactly (so
    /// that the film holds the exact sum of the latest sums, as if they had been added once), the
    /// luminance² sum and the count by f64 and integer differences.
    #[inline]
    fn add_samples_since(&mut self, o: &SampleSum, before: &SampleSum) {
        for ((s, v), b) in self.rgb.iter_mut().zip(o.rgb).zip(before.rgb) {
            s.add_f64(v);
            s.add_f64(-b);
        }
        self.lum_sq += o.lum_sq - before.lum_sq;
        self.count += o.count - before.count;
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
}

/// A wide filter's sums of one pixel of the film (none with the box filter, whose weight is the count).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelWeight {
    /// Σ w over every sample splatted into the pixel (non-finite ones too), exact.
    pub weight: ExactSum,
    /// Σ w², Σ w²·Y and Σ w²·Y² (Y the luminance; 0 for a non-finite sample), for the variance of the
    /// pixel's value ([`Film::value_variance`]).
    pub weight_sq: f64,
    pub wsq_lum: f64,
    pub wsq_lum_sq: f64,
}

impl PixelWeight {
    #[inline]
    fn add_samples(&mut self, o: &WeightSum) {
        self.weight.add_f64(o.weight);
        self.weight_sq += o.weight_sq;
        self.wsq_lum += o.wsq_lum;
        self.wsq_lum_sq += o.wsq_lum_sq;
    }

    /// [`PixelSum::add_samples_since`] for the filter's sums (the weight exactly).
    #[inline]
    fn add_samples_since(&mut self, o: &WeightSum, before: &WeightSum) {
        self.weight.add_f64(o.weight);
        self.weight.add_f64(-before.weight);
        self.weight_sq += o.weight_sq - before.weight_sq;
        self.wsq_lum += o.wsq_lum - before.wsq_lum;
        self.wsq_lum_sq += o.wsq_lum_sq - before.wsq_lum_sq;
    }

    /// Adds another pixel's sums (the weight exactly).
    #[inline]
    pub fn merge(&mut self, o: &PixelWeight) {
        self.weight.add(&o.weight);
        self.weight_sq += o.weight_sq;
        self.wsq_lum += o.wsq_lum;
        self.wsq_lum_sq += o.wsq_lum_sq;
    }
}

/// Unbiased sample variance `(Σ Y² − (Σ Y)²/n) / (n − 1)` (clamped at 0 against rounding); `None` with
/// fewer than 2 samples.
fn sample_variance(n: u64, sum_y: f64, sum_y2: f64) -> Option<f64> {
    if n < 2 {
        return None;
    }
    let n = n as f64;
    Some(((sum_y2 - sum_y * sum_y / n) / (n - 1.0)).max(0.0))
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

/// The most pixels a sample reaches along one axis: `2·border + 1` for the widest filter accepted.
const MAX_TAPS: usize = 2 * filter::MAX_RADIUS as usize + 1;

/// Per-tile accumulator owned by one worker; made by [`Film::tile_buffer`], merged with [`Film::merge_tile`].
#[derive(Clone, Debug)]
pub struct TileBuffer {
    tile: Tile,
    filter: PixelFilter,
    /// The wide filter's weights (Mitsuba's table); unused for the box filter.
    table: filter::FilterTable,
    /// The crop window: the buffer's region never leaves it.
    crop: Rect,
    /// The pixels the tile's samples reach: the tile grown by the filter's border, within the crop (the
    /// tile itself for the box filter).
    region: Rect,
    /// Over `region`.
    pixels: Vec<SampleSum>,
    /// Over `region`; empty for the box filter.
    weights: Vec<WeightSum>,
    /// AOV values per sample (module docs).
    aov_channels: usize,
    /// Over `region`, `aov_channels` per pixel: Σ w·a.
    aovs: Vec<f64>,
    non_finite: NonFinite,
}

/// `tile` grown by `border` pixels on every side, within `crop`.
fn grow(tile: Tile, border: u32, crop: Rect) -> Rect {
    Rect::new(
        tile.x0.saturating_sub(border).max(crop.x0),
        tile.y0.saturating_sub(border).max(crop.y0),
        tile.x1.saturating_add(border).min(crop.x1),
        tile.y1.saturating_add(border).min(crop.y1),
    )
}

impl TileBuffer {
    /// An empty box-filter buffer for `tile` (film coordinates).
    #[must_use]
    pub fn new(tile: Tile) -> Self {
        Self::with_filter(tile, PixelFilter::Box, tile)
    }

    /// An empty buffer for `tile` of a film with `filter` and crop window `crop` (which should contain the
    /// tile: [`Film::merge_tile`] refuses it otherwise).
    #[must_use]
    pub fn with_filter(tile: Tile, filter: PixelFilter, crop: Rect) -> Self {
        Self::with_aov_channels(tile, filter, crop, 0)
    }

    /// [`TileBuffer::with_filter`] for samples that carry `aov_channels` AOV values.
    #[must_use]
    pub fn with_aov_channels(tile: Tile, filter: PixelFilter, crop: Rect, aov_channels: usize) -> Self {
        let table = filter::FilterTable::new(&filter);
        let mut b = Self { tile, filter, table, crop, region: tile, pixels: Vec::new(), weights: Vec::new(), aov_channels, aovs: Vec::new(), non_finite: NonFinite::default() };
        b.reset(tile);
        b
    }

    /// Bytes per pixel of a buffer for a film with `filter` (its border aside), for `render::memory`.
    #[must_use]
    pub fn bytes_per_pixel(filter: PixelFilter) -> usize {
        size_of::<SampleSum>() + if filter.is_box() { 0 } else { size_of::<WeightSum>() }
    }

    /// Empties the buffer and points it at `tile`, reusing its allocation.
    pub fn reset(&mut self, tile: Tile) {
        self.tile = tile;
        self.region = if self.filter.is_box() { tile } else { grow(tile, self.filter.border(), self.crop) };
        let n = self.region.area() as usize;
        self.pixels.clear();
        self.pixels.resize(n, SampleSum::default());
        self.weights.clear();
        if !self.filter.is_box() {
            self.weights.resize(n, WeightSum::default());
        }
        self.aovs.clear();
        self.aovs.resize(n * self.aov_channels, 0.0);
        self.non_finite = NonFinite::default();
    }

    #[must_use]
    pub fn tile(&self) -> Tile {
        self.tile
    }

    /// Adds one sample taken in pixel `(x, y)` (film coordinates, inside the tile) at the pixel's centre.
    /// A sample outside the tile is a caller bug: it asserts in debug builds and is ignored in release.
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, rgb: Vec3) {
        self.add_at(x, y, Vec2::splat(0.5), rgb);
    }

    /// Adds one sample taken at film position `(x, y) + offset` (`(x, y)` inside the tile, `offset` in
    /// `[0, 1)²`): with the box filter to pixel `(x, y)` alone, else `w·rgb` and `w` to every pixel within
    /// the filter's radius (`ImageBlock::put`; `w` from [`filter::FilterTable`]). Outside the tile: as
    /// [`TileBuffer::add`].
    #[inline]
    pub fn add_at(&mut self, x: u32, y: u32, offset: Vec2, rgb: Vec3) {
        debug_assert!(self.tile.contains(x, y), "sample at ({x}, {y}) outside tile {:?}", self.tile);
        if self.filter.is_box() {
            // The region is the tile.
            if let Some(i) = self.region.index(x, y) {
                let kind = self.pixels[i].add(rgb);
                self.non_finite.record(kind);
            }
        } else if self.tile.contains(x, y) {
            self.splat::<false>(x, y, offset, rgb, &[]);
        }
    }

    /// [`TileBuffer::add_at`] of a sample that carries the AOV values `aov` (one per AOV channel of the
    /// buffer; module docs): they go to the same pixels with the same weights. The radiance is added
    /// exactly as `add_at` adds it.
    #[inline]
    pub fn add_at_aov(&mut self, x: u32, y: u32, offset: Vec2, rgb: Vec3, aov: &[f32]) {
        debug_assert!(self.tile.contains(x, y), "sample at ({x}, {y}) outside tile {:?}", self.tile);
        debug_assert_eq!(aov.len(), self.aov_channels, "one value per AOV channel");
        let n = self.aov_channels;
        if self.filter.is_box() {
            if let Some(i) = self.region.index(x, y) {
                let kind = self.pixels[i].add(rgb);
                self.non_finite.record(kind);
                for (s, &a) in self.aovs[i * n..(i + 1) * n].iter_mut().zip(aov) {
                    *s += f64::from(a);
                }
            }
        } else if self.tile.contains(x, y) {
            self.splat::<true>(x, y, offset, rgb, aov);
        }
    }

    /// The wide filter's splat (see [`TileBuffer::add_at`]), with the AOV values `aov` when `AOV`.
    #[inline]
    fn splat<const AOV: bool>(&mut self, x: u32, y: u32, offset: Vec2, rgb: Vec3, aov: &[f32]) {
        let sample = finite_sample(rgb);
        // The pixel the sample was taken in: its count and Σ Y².
        let own = self.region.index(x, y).unwrap_or_default();
        self.pixels[own].count += 1;
        let lum = match sample {
            Ok(c) => luminance_f64(c),
            Err(kind) => {
                self.non_finite.record(kind);
                0.0
            }
        };
        self.pixels[own].lum_sq += lum * lum;
        // Per axis, the pixels of the region whose centre lies within the radius: `i` with
        // `|i + ½ − p| < r`, `p = x + offset`, i.e. at most `border` pixels on either side of the sample's.
        let border = self.filter.border() as i64;
        let table = &self.table;
        let taps = |p: u32, o: f32, lo: u32, hi: u32, w: &mut [f32; MAX_TAPS]| -> (u32, usize) {
            let first = (i64::from(p) - border).max(i64::from(lo));
            let last = (i64::from(p) + border).min(i64::from(hi) - 1);
            let mut n = 0;
            for i in first..=last {
                w[n] = table.weight((i - i64::from(p)) as f32 + 0.5 - o);
                n += 1;
            }
            (first as u32, n)
        };
        let (mut wx, mut wy) = ([0f32; MAX_TAPS], [0f32; MAX_TAPS]);
        let (x0, nx) = taps(x, offset.x, self.region.x0, self.region.x1, &mut wx);
        let (y0, ny) = taps(y, offset.y, self.region.y0, self.region.y1, &mut wy);
        for (j, &fy) in wy[..ny].iter().enumerate() {
            let row = self.region.index(x0, y0 + j as u32).unwrap_or_default();
            for (i, &fx) in wx[..nx].iter().enumerate() {
                let w = fx * fy;
                let k = row + i;
                let ws = &mut self.weights[k];
                let w2 = f64::from(w) * f64::from(w);
                ws.weight += f64::from(w);
                ws.weight_sq += w2;
                ws.wsq_lum += w2 * lum;
                ws.wsq_lum_sq += w2 * lum * lum;
                if sample.is_ok() {
                    // w·L rounded to f32 once: on the 2⁻¹⁴⁹ grid, so the film's sums stay exact.
                    let c = rgb * w;
                    let p = &mut self.pixels[k].rgb;
                    p[0] += f64::from(c.x);
                    p[1] += f64::from(c.y);
                    p[2] += f64::from(c.z);
                }
                if AOV {
                    let n = self.aov_channels;
                    for (s, &a) in self.aovs[k * n..(k + 1) * n].iter_mut().zip(aov) {
                        *s += f64::from(w) * f64::from(a);
                    }
                }
            }
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
    filter: PixelFilter,
    pixels: Vec<PixelSum>,
    /// One per pixel with a wide filter; empty with the box filter.
    weights: Vec<PixelWeight>,
    /// AOV channels per pixel (module docs) and their sums Σ w·a, `aov_channels` per pixel.
    aov_channels: usize,
    aovs: Vec<f64>,
    non_finite: NonFinite,
}

impl Film {
    /// A `width × height` box-filter film recording every pixel. Errors if either size is zero.
    pub fn new(width: u32, height: u32) -> Result<Self, FilmError> {
        Self::with_crop(width, height, Rect::new(0, 0, width, height))
    }

    /// A `width × height` box-filter film that records only the pixels of `crop` (film coordinates).
    /// Errors if `crop` is empty or not inside the film.
    pub fn with_crop(width: u32, height: u32, crop: Rect) -> Result<Self, FilmError> {
        Self::with_filter(width, height, crop, PixelFilter::Box)
    }

    /// [`Film::with_crop`] reconstructing pixels with `filter` (errors if it is out of range).
    pub fn with_filter(width: u32, height: u32, crop: Rect, filter: PixelFilter) -> Result<Self, FilmError> {
        if crop.is_empty() || !Rect::new(0, 0, width, height).contains_rect(&crop) {
            return Err(FilmError::InvalidCrop { width, height, crop });
        }
        let filter = filter.checked()?;
        let n = crop.area() as usize;
        Ok(Self {
            width,
            height,
            crop,
            filter,
            pixels: vec![PixelSum::default(); n],
            weights: if filter.is_box() { Vec::new() } else { vec![PixelWeight::default(); n] },
            aov_channels: 0,
            aovs: Vec::new(),
            non_finite: NonFinite::default(),
        })
    }

    /// The film with `n` AOV channels (module docs), empty.
    #[must_use]
    pub fn with_aov_channels(mut self, n: usize) -> Self {
        self.aov_channels = n;
        self.aovs = vec![0.0; self.crop.area() as usize * n];
        self
    }

    /// AOV channels per pixel.
    #[must_use]
    pub fn aov_channels(&self) -> usize {
        self.aov_channels
    }

    /// The film a camera renders into: its size, crop window and filter.
    pub fn for_camera(camera: &crate::camera::Camera) -> Result<Self, FilmError> {
        Self::with_filter(camera.width(), camera.height(), camera.crop(), camera.filter())
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

    #[must_use]
    pub fn filter(&self) -> PixelFilter {
        self.filter
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

    /// An empty buffer for `tile`, with this film's filter (and, for a wide one, the border it splats into).
    #[must_use]
    pub fn tile_buffer(&self, tile: Tile) -> TileBuffer {
        TileBuffer::with_aov_channels(tile, self.filter, self.crop, self.aov_channels)
    }

    /// Adds one sample at the centre of pixel `(x, y)` directly (single-threaded use). Samples outside the
    /// crop window are ignored (they assert in debug builds).
    pub fn add(&mut self, x: u32, y: u32, rgb: Vec3) {
        debug_assert!(self.crop.contains(x, y), "sample at ({x}, {y}) outside crop {:?}", self.crop);
        if self.crop.contains(x, y) {
            let mut b = self.tile_buffer(Rect::new(x, y, x + 1, y + 1));
            b.add(x, y, rgb);
            let _ = self.merge_tile(&b);
        }
    }

    /// Adds a worker's tile buffer. Errors (and changes nothing) if its tile is not inside the crop window
    /// or it was made for another filter.
    pub fn merge_tile(&mut self, buffer: &TileBuffer) -> Result<(), FilmError> {
        let r = buffer.region;
        if !self.crop.contains_rect(&buffer.tile) || !self.crop.contains_rect(&r) {
            return Err(FilmError::TileOutsideCrop { tile: buffer.tile, crop: self.crop });
        }
        if buffer.filter != self.filter {
            return Err(FilmError::FilterMismatch { film: self.filter, other: buffer.filter });
        }
        if buffer.aov_channels != self.aov_channels {
            return Err(FilmError::AovMismatch { film: self.aov_channels, other: buffer.aov_channels });
        }
        let rw = r.width() as usize;
        let n = self.aov_channels;
        for (row, y) in (r.y0..r.y1).enumerate() {
            let start = self.crop.index(r.x0, y).unwrap_or_default();
            for (d, s) in self.aovs[start * n..(start + rw) * n].iter_mut().zip(&buffer.aovs[row * rw * n..(row + 1) * rw * n]) {
                *d += s;
            }
            let src = &buffer.pixels[row * rw..(row + 1) * rw];
            for (d, s) in self.pixels[start..start + rw].iter_mut().zip(src) {
                d.add_samples(s);
            }
            if !self.filter.is_box() {
                let src = &buffer.weights[row * rw..(row + 1) * rw];
                for (d, s) in self.weights[start..start + rw].iter_mut().zip(src) {
                    d.add_samples(s);
                }
            }
        }
        self.non_finite.nan += buffer.non_finite.nan;
        self.non_finite.inf += buffer.non_finite.inf;
        Ok(())
    }

    /// Adds what `buffer` gained since `before`, an earlier copy of the same buffer that was merged then
    /// (`None`: nothing was, and this is [`Film::merge_tile`]). The render merges a tile's buffer after
    /// every round of a pass (`render::round`), so that the film is whole between rounds, while the buffer
    /// keeps adding the pass's samples in their order: the RGB sums (and filter weights) are added and
    /// subtracted exactly, so after the last round the film holds exactly what one merge of the final
    /// buffer would give — the same image bit for bit. The luminance² and `Σ w²` sums (variance only) are
    /// f64 differences and may differ from one merge in the last bits. Errors (and changes nothing) as
    /// [`Film::merge_tile`] does, or if `before` is not a copy of a buffer of the same tile and filter.
    pub fn merge_tile_since(&mut self, buffer: &TileBuffer, before: Option<&TileBuffer>) -> Result<(), FilmError> {
        let Some(before) = before else { return self.merge_tile(buffer) };
        let r = buffer.region;
        if !self.crop.contains_rect(&buffer.tile) || !self.crop.contains_rect(&r) || before.tile != buffer.tile || before.region != r {
            return Err(FilmError::TileOutsideCrop { tile: buffer.tile, crop: self.crop });
        }
        if buffer.filter != self.filter || before.filter != self.filter {
            return Err(FilmError::FilterMismatch { film: self.filter, other: buffer.filter });
        }
        if buffer.aov_channels != self.aov_channels || before.aov_channels != self.aov_channels {
            return Err(FilmError::AovMismatch { film: self.aov_channels, other: buffer.aov_channels });
        }
        let rw = r.width() as usize;
        let n = self.aov_channels;
        for (row, y) in (r.y0..r.y1).enumerate() {
            let start = self.crop.index(r.x0, y).unwrap_or_default();
            let range = row * rw..(row + 1) * rw;
            let aov_range = row * rw * n..(row + 1) * rw * n;
            for ((d, s), b) in self.aovs[start * n..(start + rw) * n].iter_mut().zip(&buffer.aovs[aov_range.clone()]).zip(&before.aovs[aov_range]) {
                *d += s - b;
            }
            for ((d, s), b) in self.pixels[start..start + rw].iter_mut().zip(&buffer.pixels[range.clone()]).zip(&before.pixels[range.clone()]) {
                d.add_samples_since(s, b);
            }
            if !self.filter.is_box() {
                for ((d, s), b) in self.weights[start..start + rw].iter_mut().zip(&buffer.weights[range.clone()]).zip(&before.weights[range]) {
                    d.add_samples_since(s, b);
                }
            }
        }
        self.non_finite.nan += buffer.non_finite.nan - before.non_finite.nan;
        self.non_finite.inf += buffer.non_finite.inf - before.non_finite.inf;
        Ok(())
    }

    /// Adds every sample of `other` (e.g. another pass). Both films must have the same size, crop and filter.
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
        if self.filter != other.filter {
            return Err(FilmError::FilterMismatch { film: self.filter, other: other.filter });
        }
        if self.aov_channels != other.aov_channels {
            return Err(FilmError::AovMismatch { film: self.aov_channels, other: other.aov_channels });
        }
        for (d, s) in self.aovs.iter_mut().zip(&other.aovs) {
            *d += s;
        }
        for (d, s) in self.pixels.iter_mut().zip(&other.pixels) {
            d.merge(s);
        }
        for (d, s) in self.weights.iter_mut().zip(&other.weights) {
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

    /// `Σ w` of the pixel at index `i` of the crop window (its sample count with the box filter).
    fn weight(&self, i: usize) -> f64 {
        match self.weights.get(i) {
            Some(pw) => pw.weight.to_f64(),
            None => self.pixels[i].count as f64,
        }
    }

    /// The value of the pixel at index `i` of the crop window: `Σ w·rgb / Σ w` (black where `Σ w = 0`, as
    /// Mitsuba's `develop` leaves it).
    fn value(&self, i: usize) -> [f64; 3] {
        let w = self.weight(i);
        if w == 0.0 {
            return [0.0; 3];
        }
        self.pixels[i].rgb_f64().map(|s| s / w)
    }

    /// The AOV channels' values over the crop window, one plane per channel (row-major, as [`Film::image`]):
    /// `Σ w·a / Σ w` per pixel, 0 where `Σ w = 0`.
    #[must_use]
    pub fn aov_planes(&self) -> Vec<Vec<f32>> {
        let n = self.aov_channels;
        let pixels = self.pixels.len();
        let mut planes = vec![Vec::with_capacity(pixels); n];
        for i in 0..pixels {
            let w = self.weight(i);
            for (c, plane) in planes.iter_mut().enumerate() {
                plane.push(if w == 0.0 { 0.0 } else { (self.aovs[i * n + c] / w) as f32 });
            }
        }
        planes
    }

    /// The per-sample variance of the luminance in pixel `(x, y)`: with the box filter the unbiased sample
    /// variance of its samples, under a filter `n ·` [`Film::value_variance`] (module docs); `None` outside
    /// the crop or with fewer than 2 samples taken in the pixel.
    #[must_use]
    pub fn luminance_variance(&self, x: u32, y: u32) -> Option<f64> {
        let i = self.crop.index(x, y)?;
        let p = &self.pixels[i];
        if self.filter.is_box() {
            return sample_variance(p.count, luminance_f64(p.rgb_f64()), p.lum_sq);
        }
        (p.count >= 2).then(|| self.value_variance(x, y)).flatten().map(|v| v * p.count as f64)
    }

    /// The estimated variance of the luminance of pixel `(x, y)`'s value (module docs): `s²/n` with the
    /// box filter, `Σ w²·(Y − v)²/(Σ w)² · n'/(n' − 1)` under a filter; `None` outside the crop, with fewer
    /// than 2 samples (box) or an effective count `n' ≤ 1` (filter).
    #[must_use]
    pub fn value_variance(&self, x: u32, y: u32) -> Option<f64> {
        let i = self.crop.index(x, y)?;
        let p = &self.pixels[i];
        let Some(w) = self.weights.get(i) else {
            return sample_variance(p.count, luminance_f64(p.rgb_f64()), p.lum_sq).map(|s2| s2 / p.count as f64);
        };
        let sum = w.weight.to_f64();
        let n_eff = sum * sum / w.weight_sq;
        if n_eff.is_nan() || n_eff <= 1.0 {
            return None;
        }
        let v = luminance_f64(self.value(i));
        let spread = (w.wsq_lum_sq - 2.0 * v * w.wsq_lum + v * v * w.weight_sq).max(0.0);
        Some(spread / (sum * sum) * n_eff / (n_eff - 1.0))
    }

    /// The per-pixel value of the crop window as an image of the crop's size (pixel `(0, 0)` of the image
    /// is film pixel `(crop.x0, crop.y0)`). Pixels without samples are black.
    #[must_use]
    pub fn image(&self) -> Image {
        let w = self.crop.width();
        Image::from_fn(w, self.crop.height(), |x, y| {
            let m = self.value(y as usize * w as usize + x as usize);
            Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
        })
    }

    /// Every pixel's sums, row-major over the crop window (pixel `(crop.x0, crop.y0)` first).
    #[must_use]
    pub fn sums(&self) -> &[PixelSum] {
        &self.pixels
    }

    /// Every pixel's filter sums, as [`Film::sums`]; empty with the box filter.
    #[must_use]
    pub fn weights(&self) -> &[PixelWeight] {
        &self.weights
    }

    /// A film made of stored sums (the inverse of [`Film::sums`] and [`Film::weights`] with
    /// [`Film::nan_count`] and [`Film::inf_count`]), for reading films back from files. Errors if `crop` is
    /// not a valid crop window of a `width × height` film or the filter is out of range; `None` if `sums`
    /// (or, for a wide filter, `weights`; for the box filter it must be empty) does not have one entry per
    /// pixel of the crop.
    #[allow(clippy::too_many_arguments)]
    pub fn from_sums(
        width: u32,
        height: u32,
        crop: Rect,
        filter: PixelFilter,
        sums: Vec<PixelSum>,
        weights: Vec<PixelWeight>,
        nan: u64,
        inf: u64,
    ) -> Result<Option<Self>, FilmError> {
        let mut film = Self::with_filter(width, height, crop, filter)?;
        if sums.len() != film.pixels.len() || weights.len() != film.weights.len() {
            return Ok(None);
        }
        film.pixels = sums;
        film.weights = weights;
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
