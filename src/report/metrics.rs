//! Image error metrics against a reference, for error-vs-time reports and render tests.
//!
//! All sums are in f64 over the three RGB channels. For an image `I` and reference `R` over the valid
//! pixels `P` of a region (both finite in all channels), with `n = 3·|P|` channel values:
//!
//! - `rmse   = sqrt( Σ (I−R)² / n )`
//! - `mae    = Σ |I−R| / n`
//! - `relmse = Σ (I−R)² / (R² + ε) / n`, per channel, `ε = `[`RELMSE_EPSILON`]` = 1e-2` (keeps dark pixels
//!   from dominating; a common choice in rendering papers).
//! - `mean_image`, `mean_reference`: per-channel means over the same valid pixels; `mean_ratio` is their
//!   quotient and `luminance_ratio` the quotient of their luminances (Rec. 709 weights).
//! - `block_rmse`: the region is cut into `block × block` blocks aligned at the region's top-left corner.
//!   Blocks at the right and bottom border may be partial; they are kept, with their mean taken over their
//!   own (valid) pixels. Per block `b`, `e_b = mean over RGB of (mean_b(I) − mean_b(R))²`; then
//!   `block_rmse = sqrt( Σ_b n_b·e_b / Σ_b n_b )`, weighting each block by its valid pixel count `n_b`
//!   (a partial block counts in proportion to its size; blocks without valid pixels are skipped). Block
//!   means average out per-pixel noise, so this measures bias/low-frequency error, the quantity to compare
//!   with a noisy reference (the Mitsuba reference has ~5% per-pixel noise, ~0.3% on 16×16 blocks).
//!
//! Pixels of the image with a NaN or ±∞ channel are excluded from every sum and counted (`nan_count`:
//! has a NaN; `inf_count`: infinite, no NaN). Non-finite reference pixels are excluded too and counted in
//! `reference_non_finite`. With no valid pixel the metrics are NaN (serialised to JSON as `null`).

use crate::film::{luminance_f64, Image, Rect};

/// The ε of relMSE, added to the squared reference value of each channel.
pub const RELMSE_EPSILON: f64 = 1e-2;

/// Errors from metrics and region specifications.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum MetricsError {
    #[error("image is {image_width}×{image_height} but the reference is {reference_width}×{reference_height}")]
    SizeMismatch {
        image_width: u32,
        image_height: u32,
        reference_width: u32,
        reference_height: u32,
    },
    #[error(
        "region `{spec}`: {reason} (expected `x0,y0,x1,y1` or `name=x0,y0,x1,y1`; each value a pixel index or a percentage such as `62%`)"
    )]
    ParseRegion { spec: String, reason: String },
    #[error("region `{name}` [{x0},{x1})×[{y0},{y1}) is empty after clipping to the {width}×{height} image")]
    EmptyRegion {
        name: String,
        x0: i64,
        y0: i64,
        x1: i64,
        y1: i64,
        width: u32,
        height: u32,
    },
    #[error("block size must be at least 1 pixel")]
    InvalidBlock,
}

/// A named pixel rectangle `[x0, x1) × [y0, y1)` (exclusive ends; row 0 = top), always non-empty and
/// inside the image it was made for (every constructor clips and rejects empty results). Its bounds are
/// the one [`Rect`] type of crop windows and tiles; `region.x0` reads through to them.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Region {
    pub name: String,
    #[serde(flatten)]
    pub rect: Rect,
}

impl std::ops::Deref for Region {
    type Target = Rect;
    fn deref(&self) -> &Rect {
        &self.rect
    }
}

/// Fraction → pixel bounds with the rounding used everywhere: the start is `floor(f·size)`, the end is
/// `ceil(f·size)` (so the region covers every pixel the fractional rectangle touches), each computed in
/// f64 with a 1e-9 tolerance so that products meant to be integers (0.8·100 = 80.00000000000001) are not
/// pushed to the next pixel.
fn fraction_to_pixel(f: f64, size: u32, is_end: bool) -> i64 {
    let v = f * f64::from(size);
    let v = if is_end { (v - 1e-9).ceil() } else { (v + 1e-9).floor() };
    v.clamp(-1.0, f64::from(size) + 1.0) as i64
}

impl Region {
    /// A region clipped to a `width × height` image; an error if nothing is left.
    pub fn new(name: impl Into<String>, x0: i64, y0: i64, x1: i64, y1: i64, width: u32, height: u32) -> Result<Self, MetricsError> {
        let name = name.into();
        let cx0 = x0.clamp(0, i64::from(width));
        let cy0 = y0.clamp(0, i64::from(height));
        let cx1 = x1.clamp(0, i64::from(width));
        let cy1 = y1.clamp(0, i64::from(height));
        if cx0 >= cx1 || cy0 >= cy1 {
            return Err(MetricsError::EmptyRegion {
                name,
                x0,
                y0,
                x1,
                y1,
                width,
                height,
            });
        }
        // The clamps above bound every value by a u32.
        Ok(Self {
            name,
            rect: Rect::new(cx0 as u32, cy0 as u32, cx1 as u32, cy1 as u32),
        })
    }

    /// The whole image, named `image`.
    #[must_use]
    pub fn whole(width: u32, height: u32) -> Self {
        Self {
            name: "image".to_owned(),
            rect: Rect::new(0, 0, width, height),
        }
    }

    /// A region given as fractions of the image size (columns `fx0..fx1`, rows `fy0..fy1`), rounded
    /// outward: `x0 = floor(fx0·W)`, `x1 = ceil(fx1·W)` (same for y with H), then clipped.
    pub fn from_fractions(
        name: impl Into<String>,
        width: u32,
        height: u32,
        fx0: f64,
        fy0: f64,
        fx1: f64,
        fy1: f64,
    ) -> Result<Self, MetricsError> {
        let name = name.into();
        if ![fx0, fy0, fx1, fy1].iter().all(|f| f.is_finite()) {
            return Err(MetricsError::ParseRegion {
                spec: name,
                reason: "fractions must be finite".to_owned(),
            });
        }
        Self::new(
            name,
            fraction_to_pixel(fx0, width, false),
            fraction_to_pixel(fy0, height, false),
            fraction_to_pixel(fx1, width, true),
            fraction_to_pixel(fy1, height, true),
            width,
            height,
        )
    }

    /// The caustic region of the cornell-caustics reference (`scenes/reference/cornell-caustics/`):
    /// rows 86%–94%, columns 62%–80%. At 256×256 this is x ∈ [158, 205), y ∈ [220, 241).
    pub fn cornell_caustic(width: u32, height: u32) -> Result<Self, MetricsError> {
        Self::from_fractions("caustic", width, height, 0.62, 0.86, 0.80, 0.94)
    }

    /// Parses `x0,y0,x1,y1` (named after the spec itself) or `name=x0,y0,x1,y1`. Each value is a pixel
    /// index (may be negative or beyond the image: the region is clipped) or a percentage `p%` of the
    /// width (x) or height (y), rounded as in [`Region::from_fractions`].
    pub fn parse(spec: &str, width: u32, height: u32) -> Result<Self, MetricsError> {
        let err = |reason: &str| MetricsError::ParseRegion {
            spec: spec.to_owned(),
            reason: reason.to_owned(),
        };
        let (name, bounds) = match spec.split_once('=') {
            Some((n, b)) => {
                let n = n.trim();
                if n.is_empty() {
                    return Err(err("empty name before `=`"));
                }
                (n.to_owned(), b)
            }
            None => (spec.trim().to_owned(), spec),
        };
        let parts: Vec<&str> = bounds.split(',').map(str::trim).collect();
        if parts.len() != 4 {
            return Err(err(&format!("expected 4 comma-separated values, found {}", parts.len())));
        }
        let mut v = [0i64; 4];
        for (i, part) in parts.iter().enumerate() {
            let size = if i % 2 == 0 { width } else { height };
            v[i] = if let Some(p) = part.strip_suffix('%') {
                let p: f64 = p.trim().parse().map_err(|_| err(&format!("`{part}` is not a percentage")))?;
                if !p.is_finite() {
                    return Err(err(&format!("`{part}` is not a finite percentage")));
                }
                fraction_to_pixel(p / 100.0, size, i >= 2)
            } else {
                part.parse().map_err(|_| err(&format!("`{part}` is not an integer pixel index")))?
            };
        }
        Self::new(name, v[0], v[1], v[2], v[3], width, height)
    }

    /// Number of pixels.
    #[must_use]
    pub fn pixels(&self) -> u64 {
        self.rect.area()
    }

    /// The region clipped to a `width × height` image (regions built for another size, or edited fields).
    fn clipped(&self, width: u32, height: u32) -> Result<Self, MetricsError> {
        Self::new(
            self.name.clone(),
            self.x0.into(),
            self.y0.into(),
            self.x1.into(),
            self.y1.into(),
            width,
            height,
        )
    }
}

/// Error metrics of one region (see the module documentation for the definitions).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Metrics {
    /// Pixels in the region.
    pub pixels: u64,
    /// Pixels used in the sums (finite in image and reference).
    pub valid_pixels: u64,
    /// Image pixels with a NaN channel (excluded).
    pub nan_count: u64,
    /// Image pixels with an infinite channel and no NaN (excluded).
    pub inf_count: u64,
    /// Reference pixels with a non-finite channel (excluded; the image pixel there is not counted above).
    pub reference_non_finite: u64,
    pub rmse: f64,
    pub relmse: f64,
    pub mae: f64,
    pub mean_image: [f64; 3],
    pub mean_reference: [f64; 3],
    /// `mean_image / mean_reference` per channel.
    pub mean_ratio: [f64; 3],
    /// Luminance of `mean_image` over luminance of `mean_reference`.
    pub luminance_ratio: f64,
    /// Block size in pixels.
    pub block: u32,
    /// Blocks with at least one valid pixel.
    pub blocks: u64,
    pub block_rmse: f64,
}

/// Metrics of one named region.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RegionMetrics {
    pub region: Region,
    pub metrics: Metrics,
}

/// Result of [`compare`]: whole-image metrics and one entry per region.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    pub block: u32,
    pub relmse_epsilon: f64,
    pub whole: Metrics,
    pub regions: Vec<RegionMetrics>,
}

/// Per-block running sums.
#[derive(Clone, Copy, Default)]
struct BlockSum {
    image: [f64; 3],
    reference: [f64; 3],
    count: u64,
}

/// Metrics of `image` against `reference` over `region` (clipped to the image) with `block × block` blocks.
pub fn region_metrics(image: &Image, reference: &Image, region: &Region, block: u32) -> Result<Metrics, MetricsError> {
    check_sizes(image, reference)?;
    if block == 0 {
        return Err(MetricsError::InvalidBlock);
    }
    let r = region.clipped(image.width(), image.height())?;
    let blocks_x = r.width().div_ceil(block) as usize;
    let blocks_y = r.height().div_ceil(block) as usize;
    let mut blocks = vec![BlockSum::default(); blocks_x * blocks_y];

    let (mut nan_count, mut inf_count, mut reference_non_finite, mut valid) = (0u64, 0u64, 0u64, 0u64);
    let mut sq = 0.0f64;
    let mut rel = 0.0f64;
    let mut abs = 0.0f64;
    let mut sum_i = [0.0f64; 3];
    let mut sum_r = [0.0f64; 3];
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let pi = image.get(x, y);
            let pr = reference.get(x, y);
            if pi.is_nan() {
                nan_count += 1;
                continue;
            }
            if !pi.is_finite() {
                inf_count += 1;
                continue;
            }
            if !pr.is_finite() {
                reference_non_finite += 1;
                continue;
            }
            valid += 1;
            let b = &mut blocks[((y - r.y0) / block) as usize * blocks_x + ((x - r.x0) / block) as usize];
            b.count += 1;
            for c in 0..3 {
                let (vi, vr) = (f64::from(pi[c]), f64::from(pr[c]));
                let d = vi - vr;
                sq += d * d;
                rel += d * d / (vr * vr + RELMSE_EPSILON);
                abs += d.abs();
                sum_i[c] += vi;
                sum_r[c] += vr;
                b.image[c] += vi;
                b.reference[c] += vr;
            }
        }
    }

    let n = 3.0 * valid as f64;
    let mean_image = sum_i.map(|s| s / valid as f64);
    let mean_reference = sum_r.map(|s| s / valid as f64);
    let mean_ratio = [0, 1, 2].map(|c| mean_image[c] / mean_reference[c]);

    let mut block_sq = 0.0f64;
    let mut block_weight = 0u64;
    let mut used_blocks = 0u64;
    for b in blocks.iter().filter(|b| b.count > 0) {
        let k = b.count as f64;
        let e: f64 = (0..3).map(|c| (b.image[c] / k - b.reference[c] / k).powi(2)).sum::<f64>() / 3.0;
        block_sq += k * e;
        block_weight += b.count;
        used_blocks += 1;
    }

    Ok(Metrics {
        pixels: r.pixels(),
        valid_pixels: valid,
        nan_count,
        inf_count,
        reference_non_finite,
        rmse: (sq / n).sqrt(),
        relmse: rel / n,
        mae: abs / n,
        mean_image,
        mean_reference,
        mean_ratio,
        luminance_ratio: luminance_f64(mean_image) / luminance_f64(mean_reference),
        block,
        blocks: used_blocks,
        block_rmse: (block_sq / block_weight as f64).sqrt(),
    })
}

fn check_sizes(image: &Image, reference: &Image) -> Result<(), MetricsError> {
    if (image.width(), image.height()) != (reference.width(), reference.height()) {
        return Err(MetricsError::SizeMismatch {
            image_width: image.width(),
            image_height: image.height(),
            reference_width: reference.width(),
            reference_height: reference.height(),
        });
    }
    Ok(())
}

/// Whole-image metrics plus metrics for each region (regions are clipped to the image; one that ends up
/// empty is an error).
pub fn compare(image: &Image, reference: &Image, regions: &[Region], block: u32) -> Result<Comparison, MetricsError> {
    check_sizes(image, reference)?;
    let whole_region = Region::whole(image.width(), image.height());
    if image.width() == 0 || image.height() == 0 {
        return Err(MetricsError::EmptyRegion {
            name: whole_region.name,
            x0: 0,
            y0: 0,
            x1: image.width().into(),
            y1: image.height().into(),
            width: image.width(),
            height: image.height(),
        });
    }
    let whole = region_metrics(image, reference, &whole_region, block)?;
    let regions = regions
        .iter()
        .map(|region| {
            Ok(RegionMetrics {
                region: region.clipped(image.width(), image.height())?,
                metrics: region_metrics(image, reference, region, block)?,
            })
        })
        .collect::<Result<Vec<_>, MetricsError>>()?;
    Ok(Comparison {
        width: image.width(),
        height: image.height(),
        block,
        relmse_epsilon: RELMSE_EPSILON,
        whole,
        regions,
    })
}

#[cfg(test)]
#[path = "metrics_tests.rs"]
mod tests;
