//! The equirectangular environment map (Mitsuba's `envmap` emitter): radiance from every direction at
//! infinity, looked up in a latitude–longitude image, importance-sampled ∝ luminance·sin θ.
//!
//! Mapping (Mitsuba 3 `envmap.cpp`): for a direction `d` in the map's local frame (`to_local` = inverse of
//! `to_world`), `u = atan2(d.x, −d.z)/(2π) mod 1`, `v = acos(d.y)/π`; row 0 is the top of the image (v = 0,
//! +y). Pixel (x, y) covers `u ∈ [x/W, (x+1)/W)`, `v ∈ [y/H, (y+1)/H)`; its value sits at the pixel centre and
//! [`EnvMap::eval`] interpolates bilinearly (wrapping in u, clamping in v).
//!
//! Sampling (pbrt-v4 `ImageInfiniteLight`): a piecewise-constant [`Distribution2D`] over the pixels with
//! weight `Ȳ·sin θ_c`, where θ_c is the pixel centre's polar angle and Ȳ is the mean over the pixel of the
//! bilinearly interpolated luminance (a separable [1, 6, 1]/8 filter of the pixel luminances). Using that
//! mean instead of the pixel's own luminance makes the pdf positive wherever `eval` is (bilinear
//! interpolation spreads a bright pixel over half of each neighbour), so NEE alone is unbiased. The sampled
//! (u, v) maps to a direction with `dω = 2π²·sin θ du dv`, hence `pdf_w = pdf_uv / (2π² sin θ)`.
//!
//! A map may carry a sun ([`EnvMap::with_sun`], Mitsuba's `sunsky`): a disc too small for any pixel grid
//! ([`EnvSun`], 0.27° in radius), added to the map's radiance and sampled as a second technique — the sun with
//! probability `p = Y(∫sun)/(Y(∫sun) + Y(∫map))`, the map otherwise; `pdf_li` is the mixture.

use super::env_sun::EnvSun;
use super::{disk_emission, infinite_light_sample, luminance, EmissionSample, LightError, LightSample};
use crate::math::{Mat3, Mat4, Vec2, Vec3};
use crate::sampling::distribution::Distribution2D;
use std::f32::consts::{FRAC_1_PI, PI, TAU};
use std::path::Path;

/// The largest f32 below 1 (a rescaled sample stays in [0, 1)).
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Largest image accepted (2²⁷ pixels, e.g. 16384 × 8192), so that a corrupt header cannot ask for
/// an absurd allocation.
const MAX_PIXELS: usize = 1 << 27;

/// An equirectangular environment map.
#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Radiance (scale applied), row-major, row 0 at the top.
    pixels: Vec<Vec3>,
    /// Rotation part of `to_world` (uniform scale removed) and its inverse.
    to_world: Mat3,
    to_local: Mat3,
    /// `None` if the map is black.
    distribution: Option<Distribution2D>,
    /// `∫ eval(ω) dω` over the sphere, exact for the bilinear interpolant (the sun's included).
    integral: Vec3,
    /// The sun's disc, if the map has one, and the probability of sampling it.
    sun: Option<EnvSun>,
    pub(super) sun_prob: f32,
}

/// `(u, v) ∈ [0, 1)×[0, 1]` of a unit direction in the map's local frame (Mitsuba's mapping).
#[must_use]
pub fn local_dir_to_uv(d: Vec3) -> Vec2 {
    let mut u = d.x.atan2(-d.z) * (1.0 / TAU);
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        u = 0.0;
    }
    Vec2::new(u, d.y.clamp(-1.0, 1.0).acos() * FRAC_1_PI)
}

/// Unit local direction of `(u, v)`: `θ = π v`, `φ = 2π u`, `d = (sin θ sin φ, cos θ, −sin θ cos φ)`.
#[must_use]
pub fn uv_to_local_dir(uv: Vec2) -> Vec3 {
    let (sin_theta, cos_theta) = (PI * uv.y).sin_cos();
    let (sin_phi, cos_phi) = (TAU * uv.x).sin_cos();
    Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
}

fn invalid(path: &Path, message: impl Into<String>) -> LightError {
    LightError::Invalid {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// The rotation of `to_world` (a rotation, possibly with a reflection, times a positive uniform scale).
fn rotation_of(path: &Path, to_world: Mat4) -> Result<Mat3, LightError> {
    let m = Mat3::from_mat4(to_world);
    let cols = [m.x_axis, m.y_axis, m.z_axis];
    if !cols.iter().all(|c| c.is_finite()) {
        return Err(invalid(path, "to_world is not finite"));
    }
    let s = cols.iter().map(|c| c.length()).sum::<f32>() / 3.0;
    let orthogonal = (0..3).all(|i| (cols[i].length() - s).abs() <= 1e-3 * s && cols[i].dot(cols[(i + 1) % 3]).abs() <= 1e-3 * s * s);
    if s <= 0.0 || !orthogonal {
        return Err(invalid(
            path,
            "to_world of an environment map must be a rotation (optionally with a uniform scale)",
        ));
    }
    Ok(m * (1.0 / s))
}

impl EnvMap {
    /// Loads an equirectangular `.exr` (first RGB(A) layer, alpha ignored) or `.hdr` (Radiance RGBE) image.
    /// `scale` multiplies the radiance; `to_world` orients the map (its rotation part is used).
    pub fn load(path: &Path, scale: f32, to_world: Mat4) -> Result<EnvMap, LightError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let (width, height, rgb) = match ext.as_deref() {
            Some("exr") => read_exr(path)?,
            Some("hdr") => read_hdr(path)?,
            _ => return Err(LightError::UnsupportedFormat { path: path.to_path_buf() }),
        };
        Self::build(path, width, height, rgb, scale, to_world)
    }

    /// A map from `width × height` linear RGB pixels, row-major, row 0 at the top (errors name `<pixels>`).
    pub fn from_pixels(width: usize, height: usize, rgb: Vec<Vec3>, scale: f32, to_world: Mat4) -> Result<EnvMap, LightError> {
        Self::build(Path::new("<pixels>"), width, height, rgb, scale, to_world)
    }

    fn build(path: &Path, width: usize, height: usize, mut pixels: Vec<Vec3>, scale: f32, to_world: Mat4) -> Result<EnvMap, LightError> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(pixels.len()) {
            return Err(invalid(
                path,
                format!("{} pixels do not make a {width} × {height} image", pixels.len()),
            ));
        }
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(invalid(path, format!("scale {scale} must be finite and non-negative")));
        }
        let to_world = rotation_of(path, to_world)?;
        let max = pixels.iter().fold(0.0f32, |m, p| m.max(p.max_element()));
        for (i, p) in pixels.iter_mut().enumerate() {
            if !p.is_finite() || p.min_element() < 0.0 {
                let path = path.to_path_buf();
                return Err(LightError::BadTexel {
                    path,
                    x: i % width,
                    y: i / width,
                    r: p.x,
                    g: p.y,
                    b: p.z,
                });
            }
            *p *= scale;
            if !p.is_finite() {
                return Err(LightError::ScaleOverflow {
                    path: path.to_path_buf(),
                    x: i % width,
                    y: i / width,
                    scale,
                    max,
                    limit: f32::MAX / max,
                });
            }
        }
        let weights = sampling_weights(&pixels, width, height);
        let distribution = Distribution2D::new(&weights, width, height);
        let integral = bilinear_integral(&pixels, width, height);
        Ok(EnvMap {
            width,
            height,
            pixels,
            to_world,
            to_local: to_world.transpose(),
            distribution,
            integral,
            sun: None,
            sun_prob: 0.0,
        })
    }

    /// The map with `sun` added: its radiance adds to the map's, and NEE and photon emission sample it with
    /// probability `Y(∫sun)/(Y(∫sun) + Y(∫map))` (1 when the map is black).
    #[must_use]
    pub fn with_sun(mut self, sun: EnvSun) -> EnvMap {
        let (map, disc) = (luminance(self.integral).max(0.0), luminance(sun.integral()).max(0.0));
        self.sun_prob = if self.distribution.is_none() {
            1.0
        } else if disc + map > 0.0 {
            disc / (disc + map)
        } else {
            0.0
        };
        self.integral += sun.integral();
        self.sun = Some(sun);
        self
    }

    /// The sun's disc, if the map has one.
    #[must_use]
    pub fn sun(&self) -> Option<&EnvSun> {
        self.sun.as_ref()
    }

    /// Bytes the map keeps: its radiance per pixel and its sampling distribution.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        (self.pixels.len() * size_of::<Vec3>()) as u64 + self.distribution.as_ref().map_or(0, Distribution2D::memory_bytes)
    }

    /// Image width in pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height in pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Radiance of pixel (x, y), scale applied (panics outside the image, like slice indexing).
    #[must_use]
    pub fn pixel(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }

    /// Unit direction in the map's local frame.
    fn to_local_dir(&self, dir_world: Vec3) -> Vec3 {
        (self.to_local * dir_world).normalize_or_zero()
    }

    /// Radiance arriving from direction `dir_world` (pointing away from the scene, toward the environment):
    /// bilinear interpolation of the pixel centres, wrapping in u and clamping in v.
    #[must_use]
    pub fn eval(&self, dir_world: Vec3) -> Vec3 {
        let sun = self.sun.as_ref().map_or(Vec3::ZERO, |s| s.eval(dir_world.normalize_or_zero()));
        sun + self.eval_map(dir_world)
    }

    /// The image's bilinear interpolant alone (no sun).
    fn eval_map(&self, dir_world: Vec3) -> Vec3 {
        let d = self.to_local_dir(dir_world);
        if d == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let uv = local_dir_to_uv(d);
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let i0 = (x0 as i64).rem_euclid(w);
        let i1 = (i0 + 1) % w;
        let j0 = (y0 as i64).clamp(0, h - 1);
        let j1 = (y0 as i64 + 1).clamp(0, h - 1);
        let at = |i: i64, j: i64| self.pixels[(j * w + i) as usize];
        (1.0 - fy) * ((1.0 - fx) * at(i0, j0) + fx * at(i1, j0)) + fy * ((1.0 - fx) * at(i0, j1) + fx * at(i1, j1))
    }

    /// Solid-angle density with which [`EnvMap::sample_li`] produces `dir_world`: the image's
    /// `pdf_uv(u, v) / (2π² sin θ)` (0 at the poles and for a black map), mixed with the sun's.
    #[must_use]
    pub fn pdf_li(&self, dir_world: Vec3) -> f32 {
        match &self.sun {
            None => self.pdf_map(dir_world),
            Some(sun) => {
                let p = self.sun_prob;
                let map = if p < 1.0 { (1.0 - p) * self.pdf_map(dir_world) } else { 0.0 };
                map + p * sun.pdf(dir_world.normalize_or_zero())
            }
        }
    }

    /// The image's solid-angle density alone.
    pub(super) fn pdf_map(&self, dir_world: Vec3) -> f32 {
        let Some(dist) = &self.distribution else { return 0.0 };
        let d = self.to_local_dir(dir_world);
        let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
        if sin_theta.is_nan() || sin_theta <= 0.0 {
            return 0.0;
        }
        dist.pdf(local_dir_to_uv(d)) / (2.0 * PI * PI * sin_theta)
    }

    /// Samples a direction ∝ the importance distribution (the pdf is [`EnvMap::pdf_li`] of the direction).
    pub(super) fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let wi = match &self.sun {
            // u.x chooses the technique and is reused, rescaled, for the chosen one.
            Some(sun) if u.x < self.sun_prob => sun.sample(Vec2::new((u.x / self.sun_prob).min(1.0), u.y)),
            Some(_) => self.sample_map(Vec2::new(((u.x - self.sun_prob) / (1.0 - self.sun_prob)).clamp(0.0, ONE_MINUS_EPSILON), u.y))?,
            None => self.sample_map(u)?,
        };
        // The same code as pdf_li (one pdf code path; it also absorbs rounding across pixel borders).
        let pdf_w = self.pdf_li(wi);
        (pdf_w > 0.0 && pdf_w.is_finite()).then_some((wi, pdf_w))
    }

    /// A direction ∝ the image's distribution alone.
    fn sample_map(&self, u: Vec2) -> Option<Vec3> {
        let (uv, pdf_uv) = self.distribution.as_ref()?.sample_continuous(u);
        if pdf_uv.is_nan() || pdf_uv <= 0.0 {
            return None;
        }
        Some((self.to_world * uv_to_local_dir(uv)).normalize())
    }

    /// NEE: a direction toward the environment from `p_ref` (any point: the map is at infinity).
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3, u: Vec2) -> Option<LightSample> {
        let (wi, pdf_w) = self.sample_direction(u)?;
        infinite_light_sample(p_ref, wi, self.eval(wi), pdf_w)
    }

    /// Photon emission (method.md §2): the direction ω toward the environment ∝ the importance distribution
    /// (`u_dir`), the origin uniform (`u_disk`) on a disk of radius `radius` perpendicular to ω, centred at
    /// `center + radius·ω`; the photon travels along −ω. `pdf_w_dir` = [`EnvMap::pdf_li`] of ω,
    /// `pdf_a = 1/(π R²)`.
    #[must_use]
    pub fn sample_le(&self, u_dir: Vec2, u_disk: Vec2, center: Vec3, radius: f32) -> Option<EmissionSample> {
        self.sample_le_toward(u_dir, u_disk, center, radius, radius)
    }

    /// [`EnvMap::sample_le`] aimed at a sphere (`center`, `radius`) inside the scene: the disk has that
    /// sphere's radius and is centred at `center + distance·ω` (`distance` puts it outside the scene),
    /// `pdf_a = 1/(π·radius²)`.
    #[must_use]
    pub fn sample_le_toward(&self, u_dir: Vec2, u_disk: Vec2, center: Vec3, radius: f32, distance: f32) -> Option<EmissionSample> {
        let (omega, pdf_w) = self.sample_direction(u_dir)?;
        disk_emission(omega, self.eval(omega), pdf_w, u_disk, center, radius, distance)
    }

    /// `∫ eval(ω) dω` over the sphere (RGB), exact for the bilinear interpolant.
    #[must_use]
    pub fn integral(&self) -> Vec3 {
        self.integral
    }

    /// `∫ Y(eval(ω)) dω` over the sphere.
    #[must_use]
    pub fn integral_luminance(&self) -> f32 {
        luminance(self.integral)
    }

    /// Power Φ = π·R²·∫Y(Le) dω (method.md §2), R = the scene's bounding-sphere radius.
    #[must_use]
    pub fn power(&self, scene_radius: f32) -> f32 {
        PI * scene_radius * scene_radius * self.integral_luminance()
    }
}

/// Per-pixel sampling weights: the pixel mean of the bilinearly interpolated luminance (separable
/// [1, 6, 1]/8 filter, wrapping in x, clamping in y) times sin θ at the pixel centre.
fn sampling_weights(pixels: &[Vec3], width: usize, height: usize) -> Vec<f32> {
    const K: [f32; 3] = [0.125, 0.75, 0.125];
    let lum: Vec<f32> = pixels.iter().map(|&p| luminance(p).max(0.0)).collect();
    let mut horizontal = vec![0.0f32; lum.len()];
    for y in 0..height {
        let row = &lum[y * width..(y + 1) * width];
        for x in 0..width {
            let left = row[(x + width - 1) % width];
            let right = row[(x + 1) % width];
            horizontal[y * width + x] = K[0] * left + K[1] * row[x] + K[2] * right;
        }
    }
    let mut weights = vec![0.0f32; lum.len()];
    for y in 0..height {
        let up = y.saturating_sub(1);
        let down = (y + 1).min(height - 1);
        let sin_theta = (PI * (y as f32 + 0.5) / height as f32).sin();
        for x in 0..width {
            let v = K[0] * horizontal[up * width + x] + K[1] * horizontal[y * width + x] + K[2] * horizontal[down * width + x];
            weights[y * width + x] = v * sin_theta;
        }
    }
    weights
}

/// `∫ eval dω` in closed form. Averaged over u (periodic), the bilinear interpolant is the row mean `m_j`;
/// in θ it is linear between the row centres θ_j = π(j + ½)/H and constant beyond the first and last centre:
/// `∫ = 2π [m_0 (1 − cos θ_0) + Σ_j ∫_{θ_j}^{θ_j+1} m(θ) sin θ dθ + m_{H−1} (1 + cos θ_{H−1})]`, with
/// `∫ (m_j + (m_{j+1} − m_j)(θ − θ_j)/Δ) sin θ dθ = m_j (cos θ_j − cos θ_{j+1}) + (m_{j+1} − m_j)/Δ ·
/// (sin θ_{j+1} − sin θ_j − Δ cos θ_{j+1})`.
fn bilinear_integral(pixels: &[Vec3], width: usize, height: usize) -> Vec3 {
    let means: Vec<[f64; 3]> = pixels
        .chunks_exact(width)
        .map(|row| {
            let s = row.iter().fold([0.0f64; 3], |a, p| {
                [a[0] + f64::from(p.x), a[1] + f64::from(p.y), a[2] + f64::from(p.z)]
            });
            s.map(|c| c / width as f64)
        })
        .collect();
    let delta = std::f64::consts::PI / height as f64;
    let theta = |j: usize| delta * (j as f64 + 0.5);
    let mut total = [0.0f64; 3];
    for c in 0..3 {
        let mut acc = means[0][c] * (1.0 - theta(0).cos()) + means[height - 1][c] * (1.0 + theta(height - 1).cos());
        for j in 0..height - 1 {
            let (a, b) = (theta(j), theta(j + 1));
            let (m0, m1) = (means[j][c], means[j + 1][c]);
            acc += m0 * (a.cos() - b.cos()) + (m1 - m0) / delta * (b.sin() - a.sin() - delta * b.cos());
        }
        total[c] = std::f64::consts::TAU * acc;
    }
    Vec3::new(total[0] as f32, total[1] as f32, total[2] as f32)
}

/// Pixels decoded by the `exr` crate (`data` stays empty when the header asks for too many pixels).
struct ExrPixels {
    width: usize,
    height: usize,
    data: Vec<Vec3>,
}

fn read_exr(path: &Path) -> Result<(usize, usize, Vec<Vec3>), LightError> {
    use exr::prelude::{read, ReadChannels, ReadLayers};
    let file = std::fs::File::open(path).map_err(|source| LightError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // The chunk table first: a corrupt chunk size must not reach the decoder's allocation.
    crate::film::exr_scan::scan_exr(path).map_err(|e| match e {
        crate::film::ImageError::Io { source, .. } => LightError::Io { path: path.to_path_buf(), source },
        e => LightError::Decode { path: path.to_path_buf(), message: e.reason() },
    })?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution, _| {
                let (width, height) = (resolution.width(), resolution.height());
                let fits = width.checked_mul(height).is_some_and(|n| n <= MAX_PIXELS);
                ExrPixels {
                    width,
                    height,
                    data: if fits { vec![Vec3::ZERO; width * height] } else { Vec::new() },
                }
            },
            |pixels: &mut ExrPixels, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = pos.y() * pixels.width + pos.x();
                if let Some(p) = pixels.data.get_mut(i) {
                    *p = Vec3::new(r, g, b);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::BufReader::new(file))
        .map_err(|e| LightError::Decode {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let pixels = image.layer_data.channel_data.pixels;
    if pixels.data.len() != pixels.width * pixels.height || pixels.data.is_empty() {
        return Err(invalid(
            path,
            format!(
                "{} × {} pixels is empty or too large (limit {MAX_PIXELS} pixels)",
                pixels.width, pixels.height
            ),
        ));
    }
    Ok((pixels.width, pixels.height, pixels.data))
}

/// Reads a Radiance RGBE `.hdr` file with the `image` crate. The format's first line is `#?` plus the name
/// of the writing program; `image` accepts only `#?RADIANCE`, so another name (`#?RGBE`, written by Ward's
/// `rgbe.c` and by our shared assets; stb_image accepts both) is rewritten to it before decoding.
fn read_hdr(path: &Path) -> Result<(usize, usize, Vec<Vec3>), LightError> {
    let mut bytes = std::fs::read(path).map_err(|source| LightError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    const SIGNATURE: &[u8] = b"#?RADIANCE";
    if bytes.starts_with(b"#?") && !bytes.starts_with(SIGNATURE) {
        if let Some(end) = bytes.iter().take(128).position(|&b| b == b'\n') {
            bytes.splice(..end, SIGNATURE.iter().copied());
        }
    }
    let decode_error = |e: image::ImageError| LightError::Decode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Hdr);
    let (width, height) = reader().into_dimensions().map_err(decode_error)?;
    let (width, height) = (width as usize, height as usize);
    if !width.checked_mul(height).is_some_and(|n| n > 0 && n <= MAX_PIXELS) {
        return Err(invalid(
            path,
            format!("{width} × {height} pixels is empty or too large (limit {MAX_PIXELS} pixels)"),
        ));
    }
    let image = reader().decode().map_err(decode_error)?.into_rgb32f();
    let data = image.pixels().map(|p| Vec3::new(p.0[0], p.0[1], p.0[2])).collect();
    Ok((width, height, data))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    /// (a) The pdf of the (u, v) sampler carried to solid angle (`pdf_uv / (2π² sin θ(v))`) equals
    /// `pdf_li` recomputed from the world direction (a round trip through `to_world`, atan2 and acos),
    /// within 1e-3 relative, for almost every sample: only the rare ones that rounding moves into a
    /// neighbouring pixel may differ.
    #[test]
    fn sampling_pdf_equals_pdf_li_after_the_round_trip() {
        let (w, h) = (24, 12);
        let mut s = Sampler::for_key(31, 0, 0);
        let pixels: Vec<Vec3> = (0..w * h).map(|_| Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 4.0).collect();
        let to_world = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(-0.4) * Mat4::from_scale(Vec3::splat(2.0));
        let env = EnvMap::from_pixels(w, h, pixels, 1.5, to_world).unwrap();
        let dist = env.distribution.as_ref().unwrap();
        let n = 100_000;
        let mut off = 0;
        for _ in 0..n {
            let (uv, pdf_uv) = dist.sample_continuous(s.next_2d());
            let wi = (env.to_world * uv_to_local_dir(uv)).normalize();
            let expected = pdf_uv / (2.0 * PI * PI * (PI * uv.y).sin());
            let got = env.pdf_li(wi);
            if (got - expected).abs() > 1e-3 * expected {
                off += 1;
            }
        }
        println!("pdf round trip: {off} of {n} samples disagree beyond 1e-3");
        assert!(off <= n / 10_000, "{off} of {n} samples disagree");
    }
}
