//! [`Image`]: a finished linear-RGB picture (f32 per channel, row 0 at the top), as produced by
//! [`super::Film::image`], read from an EXR file, or compared against a reference by `report::metrics`.

use crate::math::Vec3;

/// Rec. 709 / sRGB luminance weights (linear RGB → Y), ITU-R BT.709-6 item 3.3.
pub const LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Luminance Y of a linear Rec. 709 RGB value (see [`LUMINANCE_WEIGHTS`]).
#[must_use]
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    (LUMINANCE_WEIGHTS[0] as f32) * rgb.x + (LUMINANCE_WEIGHTS[1] as f32) * rgb.y + (LUMINANCE_WEIGHTS[2] as f32) * rgb.z
}

/// [`luminance`] in f64, for accumulators.
#[must_use]
#[inline]
pub fn luminance_f64(rgb: [f64; 3]) -> f64 {
    LUMINANCE_WEIGHTS[0] * rgb[0] + LUMINANCE_WEIGHTS[1] * rgb[1] + LUMINANCE_WEIGHTS[2] * rgb[2]
}

/// A linear RGB image, `width × height` pixels stored row by row, row 0 = top.
///
/// The fields are private so that `pixels.len() == width · height` always holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// An image from row-major pixels (row 0 = top). `None` if `pixels.len() != width · height`.
    #[must_use]
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Option<Self> {
        (pixels.len() == width as usize * height as usize).then_some(Self { width, height, pixels })
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    #[must_use]
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> Vec3) -> Self {
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self { width, height, pixels }
    }

    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// All pixels, row-major, row 0 = top.
    #[must_use]
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// All pixels, mutable (the length cannot change).
    pub fn pixels_mut(&mut self) -> &mut [Vec3] {
        &mut self.pixels
    }

    /// Pixel `(x, y)`.
    ///
    /// # Panics
    /// If `x >= width` or `y >= height` (like slice indexing). Use [`Image::try_get`] for unchecked input.
    #[must_use]
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {}×{} image",
            self.width,
            self.height
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Pixel `(x, y)`, or `None` outside the image.
    #[must_use]
    #[inline]
    pub fn try_get(&self, x: u32, y: u32) -> Option<Vec3> {
        (x < self.width && y < self.height).then(|| self.pixels[y as usize * self.width as usize + x as usize])
    }

    /// Sets pixel `(x, y)`; returns `false` (and changes nothing) outside the image.
    pub fn set(&mut self, x: u32, y: u32, rgb: Vec3) -> bool {
        if x < self.width && y < self.height {
            self.pixels[y as usize * self.width as usize + x as usize] = rgb;
            true
        } else {
            false
        }
    }

    /// The window `[x0, x1) × [y0, y1)` as a new image; `None` if it is empty or not inside the image.
    #[must_use]
    pub fn crop(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Option<Image> {
        if x0 >= x1 || y0 >= y1 || x1 > self.width || y1 > self.height {
            return None;
        }
        Some(Image::from_fn(x1 - x0, y1 - y0, |x, y| self.get(x0 + x, y0 + y)))
    }

    /// Mean of each channel over all pixels, summed in f64. A NaN or ±∞ pixel makes the mean non-finite
    /// (use `report::metrics` for means that exclude them). `[0, 0, 0]` for an empty image.
    #[must_use]
    pub fn mean(&self) -> [f64; 3] {
        if self.pixels.is_empty() {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            sum[0] += f64::from(p.x);
            sum[1] += f64::from(p.y);
            sum[2] += f64::from(p.z);
        }
        let n = self.pixels.len() as f64;
        [sum[0] / n, sum[1] / n, sum[2] / n]
    }

    /// Luminance of pixel `(x, y)` (panics outside the image, like [`Image::get`]).
    #[must_use]
    pub fn luminance(&self, x: u32, y: u32) -> f32 {
        luminance(self.get(x, y))
    }

    /// Mean luminance over all pixels (f64 sums), the luminance of [`Image::mean`].
    #[must_use]
    pub fn mean_luminance(&self) -> f64 {
        luminance_f64(self.mean())
    }

    /// Number of pixels with a NaN channel and number with an infinite (but no NaN) channel.
    #[must_use]
    pub fn non_finite_counts(&self) -> (u64, u64) {
        let mut nan = 0;
        let mut inf = 0;
        for p in &self.pixels {
            if p.is_nan() {
                nan += 1;
            } else if !p.is_finite() {
                inf += 1;
            }
        }
        (nan, inf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_of_white_is_one() {
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert!((luminance_f64([1.0; 3]) - 1.0).abs() < 1e-12);
        assert!((luminance(Vec3::new(0.0, 1.0, 0.0)) - 0.7152).abs() < 1e-6);
    }

    #[test]
    fn get_crop_mean() {
        let img = Image::from_fn(4, 3, |x, y| Vec3::new(x as f32, y as f32, 1.0));
        assert_eq!(img.get(3, 2), Vec3::new(3.0, 2.0, 1.0));
        assert_eq!(img.try_get(4, 0), None);
        let c = img.crop(1, 1, 3, 3).unwrap();
        assert_eq!((c.width(), c.height()), (2, 2));
        assert_eq!(c.get(0, 0), Vec3::new(1.0, 1.0, 1.0));
        assert_eq!(c.get(1, 1), Vec3::new(2.0, 2.0, 1.0));
        assert!(img.crop(1, 1, 1, 3).is_none());
        assert!(img.crop(0, 0, 5, 3).is_none());
        // x mean = 1.5, y mean = 1.0
        assert_eq!(img.mean(), [1.5, 1.0, 1.0]);
        assert!((img.mean_luminance() - (0.2126 * 1.5 + 0.7152 + 0.0722)).abs() < 1e-12);
        assert!(Image::from_pixels(2, 2, vec![Vec3::ZERO; 3]).is_none());
    }

    #[test]
    fn non_finite_counts() {
        let mut img = Image::new(3, 1);
        assert!(img.set(0, 0, Vec3::new(f32::NAN, f32::INFINITY, 0.0)));
        assert!(img.set(1, 0, Vec3::new(0.0, f32::NEG_INFINITY, 0.0)));
        assert!(!img.set(3, 0, Vec3::ONE));
        assert_eq!(img.non_finite_counts(), (1, 1));
        assert!(img.mean()[0].is_nan());
    }
}
