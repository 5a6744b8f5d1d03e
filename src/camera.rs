//! The perspective camera: Mitsuba's `perspective` sensor (fov, fov_axis, to_world) over a film of
//! `width × height` pixels with an optional crop window.
//!
//! ```toml
//! [sensor]
//! type = "perspective"
//! fov = 39.3077            # degrees, in (0, 180)
//! fov_axis = "smaller"     # x (default, as Mitsuba) | y | diagonal | smaller | larger
//! to_world = { look_at = { origin = [0, 0, 3.9], target = [0, 0, 0], up = [0, 1, 0] } }
//! film = { width = 256, height = 256, crop = [0, 0, 128, 256] }   # crop = [x0, y0, x1, y1], exclusive
//! # film.rfilter = { type = "box" }   # the pixel reconstruction filter (`film::filter`; default gaussian)
//! ```
//!
//! Conventions (Mitsuba's): in camera space the camera looks along +z with +y up and **+x to the left of the
//! image** (`look_at` builds the columns left, up, dir). Film coordinates are pixels with (0, 0) the
//! top-left corner of the full film and y growing downwards; the pixel (i, j) covers [i, i+1) × [j, j+1).
//! The crop window only selects which pixels are rendered; rays are those of the full film. There is no
//! near clip (rays start at the camera position).

use crate::film::PixelFilter;
use crate::math::{Mat3, Mat4, Ray, Rect, Vec2, Vec3};

/// Which film axis `fov` spans (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FovAxis {
    #[default]
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    /// The axis Mitsuba names `name` (`x`, `y`, `diagonal`, `smaller`, `larger`; any case, as Mitsuba).
    #[must_use]
    pub fn from_name(name: &str) -> Option<FovAxis> {
        Some(match name.to_ascii_lowercase().as_str() {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }
}

/// The field of view (degrees) of a 35 mm equivalent focal length written as `"50mm"` or `"50"`, across
/// the film's diagonal ([`FovAxis::Diagonal`]), as Mitsuba's `parse_fov` (src/render/sensor.cpp):
/// `2·atan(√(36² + 24²) / 2f)`. `None` unless the length is a positive number.
#[must_use]
pub fn focal_length_fov(text: &str) -> Option<f32> {
    let mm: f64 = text.strip_suffix("mm").unwrap_or(text).trim().parse().ok().filter(|f: &f64| f.is_finite() && *f > 0.0)?;
    Some((2.0 * (36f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees()) as f32)
}

/// The half-extents `(tan_x, tan_y)` of a film of `width × height` at distance 1 for a field of view of
/// `fov_deg` across `axis` (Mitsuba's `parse_fov` with the film's aspect, then `perspective_projection`):
/// `tan_x / tan_y = width / height`. The perspective camera's film, and a projector's (`light::projector`).
#[must_use]
pub fn film_tan_half(fov_deg: f32, axis: FovAxis, width: u32, height: u32) -> Vec2 {
    let (w, h) = (width as f32, height as f32);
    let t = (0.5 * fov_deg.to_radians()).tan();
    let axis_is_x = match axis {
        FovAxis::X => Some(true),
        FovAxis::Y => Some(false),
        FovAxis::Smaller => Some(w <= h),
        FovAxis::Larger => Some(w >= h),
        FovAxis::Diagonal => None,
    };
    match axis_is_x {
        Some(true) => Vec2::new(t, t * h / w),
        Some(false) => Vec2::new(t * w / h, t),
        None => {
            let d = (w * w + h * h).sqrt();
            Vec2::new(t * w / d, t * h / d)
        }
    }
}

/// Largest accepted film: 2³¹ pixels (e.g. 46340 × 46340), so that a pixel's index fits in 31 bits wherever
/// it is computed. Whether the film fits in memory is a separate check (`render::memory`), made against the
/// machine's memory before the render starts.
pub const MAX_FILM_PIXELS: u64 = 1 << 31;

/// Invalid camera parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("the film must be at least 1×1 pixels, got {width}×{height}")]
    ZeroSizeFilm { width: u32, height: u32 },
    #[error("the film is too large: {width}×{height} pixels (at most {MAX_FILM_PIXELS} pixels)")]
    FilmTooLarge { width: u32, height: u32 },
    #[error("fov must be in (0, 180) degrees, got {0}")]
    Fov(f32),
    #[error("crop window [{x0}, {y0}, {x1}, {y1}] must satisfy 0 ≤ x0 < x1 ≤ {width} and 0 ≤ y0 < y1 ≤ {height}")]
    Crop {
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        width: u32,
        height: u32,
    },
    #[error("the camera's to_world is not finite, not affine or singular")]
    Transform,
}

/// A pinhole perspective camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    camera_to_world: Mat4,
    /// Linear part of `camera_to_world` (maps camera-space directions to world space).
    basis: Mat3,
    origin: Vec3,
    fov_deg: f32,
    fov_axis: FovAxis,
    width: u32,
    height: u32,
    crop: Rect,
    /// How the film reconstructs pixels from the samples (the film's `rfilter`).
    filter: PixelFilter,
    /// tan of half the field of view along film x and film y.
    tan_half: Vec2,
}

impl Camera {
    /// A camera with the full film as its crop window.
    pub fn new(camera_to_world: Mat4, fov_deg: f32, fov_axis: FovAxis, width: u32, height: u32) -> Result<Camera, CameraError> {
        if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(CameraError::Fov(fov_deg));
        }
        let basis = Mat3::from_mat4(camera_to_world);
        let det = basis.determinant();
        let affine = camera_to_world.row(3) == crate::math::Vec4::W;
        if !camera_to_world.is_finite() || !affine || !det.is_finite() || det == 0.0 {
            return Err(CameraError::Transform);
        }
        let mut camera = Camera {
            camera_to_world,
            basis,
            origin: camera_to_world.w_axis.truncate(),
            fov_deg,
            fov_axis,
            width: 1,
            height: 1,
            crop: Rect::new(0, 0, 1, 1),
            filter: PixelFilter::default(),
            tan_half: Vec2::ONE,
        };
        camera.set_resolution(width, height)?;
        Ok(camera)
    }

    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The crop window (`x1`/`y1` exclusive).
    #[must_use]
    pub fn crop(&self) -> Rect {
        self.crop
    }

    /// The film's reconstruction filter ([`PixelFilter::default`] unless set).
    #[must_use]
    pub fn filter(&self) -> PixelFilter {
        self.filter
    }

    /// Sets the film's reconstruction filter (checked by the caller: `PixelFilter::checked`).
    pub fn set_filter(&mut self, filter: PixelFilter) {
        self.filter = filter;
    }

    #[must_use]
    pub fn fov_deg(&self) -> f32 {
        self.fov_deg
    }

    #[must_use]
    pub fn fov_axis(&self) -> FovAxis {
        self.fov_axis
    }

    #[must_use]
    pub fn camera_to_world(&self) -> Mat4 {
        self.camera_to_world
    }

    /// The camera position in world space.
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.origin
    }

    /// Changes the film size, keeping `fov` on its axis; the crop window becomes the full film.
    pub fn set_resolution(&mut self, width: u32, height: u32) -> Result<(), CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::ZeroSizeFilm { width, height });
        }
        if u64::from(width) * u64::from(height) > MAX_FILM_PIXELS {
            return Err(CameraError::FilmTooLarge { width, height });
        }
        self.tan_half = film_tan_half(self.fov_deg, self.fov_axis, width, height);
        self.width = width;
        self.height = height;
        self.crop = Rect::new(0, 0, width, height);
        Ok(())
    }

    /// Sets the crop window (exclusive upper bounds) within the film.
    pub fn set_crop(&mut self, crop: Rect) -> Result<(), CameraError> {
        let Rect { x0, y0, x1, y1 } = crop;
        if x0 >= x1 || y0 >= y1 || x1 > self.width || y1 > self.height {
            return Err(CameraError::Crop {
                x0,
                y0,
                x1,
                y1,
                width: self.width,
                height: self.height,
            });
        }
        self.crop = crop;
        Ok(())
    }

    /// The primary ray through film position (`film_x`, `film_y`) in pixels, (0, 0) = top-left corner of
    /// the full film. The direction is unit length; `t ∈ [0, ∞)`.
    #[must_use]
    pub fn generate_ray(&self, film_x: f32, film_y: f32) -> Ray {
        // Normalised device coordinates in [-1, 1], x to the right, y downwards.
        let ndc_x = 2.0 * film_x / self.width as f32 - 1.0;
        let ndc_y = 2.0 * film_y / self.height as f32 - 1.0;
        // Camera space: +x is left and +y is up (Mitsuba), so both flip.
        let d_camera = Vec3::new(-ndc_x * self.tan_half.x, -ndc_y * self.tan_half.y, 1.0);
        let dir = (self.basis * d_camera).normalize();
        Ray::new(self.origin, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::look_at;

    fn angle_deg(a: Vec3, b: Vec3) -> f32 {
        a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn centre_ray_points_at_the_target_and_right_is_right() {
        let (o, t) = (Vec3::new(0.0, 0.0, 3.9), Vec3::ZERO);
        let cam = Camera::new(look_at(o, t, Vec3::Y).unwrap(), 39.3077, FovAxis::Smaller, 256, 256).unwrap();
        let r = cam.generate_ray(128.0, 128.0);
        assert_eq!(r.origin, o);
        assert!(r.dir.abs_diff_eq((t - o).normalize(), 1e-6), "{}", r.dir);
        // Right edge of the image looks towards +x (the green wall of the Cornell box), top towards +y.
        assert!(cam.generate_ray(256.0, 128.0).dir.x > 0.1);
        assert!(cam.generate_ray(128.0, 0.0).dir.y > 0.1);
        // Cornell: a ray at the left edge, mid-height, sees x = -tan(fov/2)·3.9 at z = 0.
        let r = cam.generate_ray(0.0, 128.0);
        let x_at_0 = r.origin.x + r.dir.x * (-r.origin.z / r.dir.z);
        assert!((x_at_0 + 3.9 * (0.5f32 * 39.3077f32.to_radians()).tan()).abs() < 1e-5);
    }

    #[test]
    fn edge_rays_match_fov_on_the_chosen_axis() {
        let m = look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, 0.0), Vec3::Y).unwrap();
        let fwd = (Vec3::new(-2.0, 0.5, 0.0) - Vec3::new(1.0, 2.0, 3.0)).normalize();
        let fov = 50.0f32;
        let (w, h) = (640u32, 480u32);
        let (wf, hf) = (w as f32, h as f32);
        let half_x = |cam: &Camera| angle_deg(cam.generate_ray(0.0, hf / 2.0).dir, fwd);
        let half_y = |cam: &Camera| angle_deg(cam.generate_ray(wf / 2.0, 0.0).dir, fwd);
        let tx = |deg: f32| (0.5 * deg.to_radians()).tan();
        for (axis, on_x) in [
            (FovAxis::X, true),
            (FovAxis::Y, false),
            (FovAxis::Smaller, false),
            (FovAxis::Larger, true),
        ] {
            let cam = Camera::new(m, fov, axis, w, h).unwrap();
            let (chosen, other, ratio) = if on_x {
                (half_x(&cam), half_y(&cam), hf / wf)
            } else {
                (half_y(&cam), half_x(&cam), wf / hf)
            };
            assert!((chosen - fov / 2.0).abs() < 1e-3, "{axis:?}: {chosen}");
            // The other axis: tan scales with the aspect ratio.
            assert!((other.to_radians().tan() - tx(fov) * ratio).abs() < 1e-5, "{axis:?}: {other}");
        }
        // Portrait film: `smaller` is now x.
        let cam = Camera::new(m, fov, FovAxis::Smaller, 300, 500).unwrap();
        assert!((angle_deg(cam.generate_ray(0.0, 250.0).dir, fwd) - fov / 2.0).abs() < 1e-3);
        // Diagonal: the corner ray makes half the fov with the axis.
        let cam = Camera::new(m, fov, FovAxis::Diagonal, w, h).unwrap();
        assert!((angle_deg(cam.generate_ray(0.0, 0.0).dir, fwd) - fov / 2.0).abs() < 1e-3);
        assert!((angle_deg(cam.generate_ray(wf, hf).dir, fwd) - fov / 2.0).abs() < 1e-3);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let m = Mat4::IDENTITY;
        assert_eq!(Camera::new(m, 0.0, FovAxis::X, 4, 4), Err(CameraError::Fov(0.0)));
        assert_eq!(Camera::new(m, 180.0, FovAxis::X, 4, 4), Err(CameraError::Fov(180.0)));
        assert!(matches!(Camera::new(m, f32::NAN, FovAxis::X, 4, 4), Err(CameraError::Fov(_))));
        assert_eq!(
            Camera::new(m, 40.0, FovAxis::X, 0, 4),
            Err(CameraError::ZeroSizeFilm { width: 0, height: 4 })
        );
        assert_eq!(Camera::new(Mat4::ZERO, 40.0, FovAxis::X, 4, 4), Err(CameraError::Transform));
        let mut cam = Camera::new(m, 40.0, FovAxis::X, 8, 4).unwrap();
        assert!(cam.set_crop(Rect::new(2, 1, 8, 4)).is_ok());
        assert_eq!(cam.crop(), Rect::new(2, 1, 8, 4));
        assert!(cam.set_crop(Rect::new(2, 1, 9, 4)).is_err() && cam.set_crop(Rect::new(3, 1, 3, 4)).is_err());
        assert!(cam.set_resolution(16, 0).is_err());
        assert_eq!(
            cam.set_resolution(100_000, 100_000),
            Err(CameraError::FilmTooLarge {
                width: 100_000,
                height: 100_000
            })
        );
        cam.set_resolution(16, 8).unwrap();
        assert_eq!((cam.width(), cam.height(), cam.crop()), (16, 8, Rect::new(0, 0, 16, 8)));
    }
}
