//! The camera: Mitsuba's `perspective`, `thinlens` and `orthographic` sensors over a film of
//! `width × height` pixels with an optional crop window.
//!
//! ```toml
//! [sensor]
//! type = "perspective"     # perspective (default) | thinlens | orthographic
//! fov = 39.3077            # degrees, in (0, 180); or focal_length = "50mm" (not for orthographic)
//! fov_axis = "smaller"     # x (default, as Mitsuba) | y | diagonal | smaller | larger
//! to_world = { look_at = { origin = [0, 0, 3.9], target = [0, 0, 0], up = [0, 1, 0] } }
//! film = { width = 256, height = 256, crop = [0, 0, 128, 256] }   # crop = [x0, y0, x1, y1], exclusive
//! # film.rfilter = { type = "box" }   # the pixel reconstruction filter (`film::filter`; default gaussian)
//!
//! # thinlens only:
//! # aperture_radius = 0.05   # required (Mitsuba has no default), ≥ 0; 0 is a pinhole
//! # focus_distance = 4.0     # distance of the plane in focus along the viewing axis; default far_clip
//! near_clip = 0.01         # every sensor: Mitsuba's clip planes (depths along the viewing axis), 0 < near < far
//! far_clip = 10000          # (defaults 0.01 and 10⁴)
//! ```
//!
//! Conventions (Mitsuba's): in camera space the camera looks along +z with +y up and **+x to the left of the
//! image** (`look_at` builds the columns left, up, dir). Film coordinates are pixels with (0, 0) the
//! top-left corner of the full film and y growing downwards; the pixel (i, j) covers [i, i+1) × [j, j+1).
//! The crop window only selects which pixels are rendered; rays are those of the full film.
//!
//! The clip planes, one rule for the three (`depth_clipped`, after Mitsuba's `sample_ray` of each sensor): a
//! camera ray keeps its unclipped start (the pinhole, the lens point, the film point on the camera plane) and
//! is valid only for the `t` where its depth along the camera's viewing axis (camera-space z) lies in
//! [near_clip, far_clip] — Mitsuba shifts the origin to the near plane and shortens `maxt` instead, the same
//! points. Depth, not distance along the ray: the far plane is flat, so a corner ray reaches farther.
//!
//! The three projections ([`Projection`]), one file each with its keys (read through [`Props`] by its
//! `PLUGIN`'s constructor, as every plugin's), its checks and its rays: `perspective` (a pinhole), `thinlens`
//! (an aperture and a focal plane), `orthographic` (parallel rays from a scalable camera plane). [`PLUGINS`]
//! lists them (the scene builder and both readers' key checks); the keys every sensor takes beside its own,
//! `to_world` and `film` ([`COMMON_KEYS`]), are read by the scene builder.
//!
//! No code connects paths to the camera (photons do not hit it, no light tracing), so the sensors need
//! no importance or position pdf.

mod orthographic;
mod perspective;
mod thinlens;

use crate::film::PixelFilter;
use crate::math::{Mat3, Mat4, Ray, Rect, Vec2, Vec3};
use crate::props::{NumberOrName, PropError, Props};
use crate::sampler::Sampler;

/// A sensor type as the scene files name it: its keys and the constructor of its [`Projection`].
pub(crate) type Plugin = crate::props::Plugin<Projection>;

/// Every sensor type, Mitsuba's names.
pub(crate) const PLUGINS: &[&Plugin] = &[&perspective::PLUGIN, &thinlens::PLUGIN, &orthographic::PLUGIN];

/// The sensor type of a `[sensor]` table without `type` (Mitsuba's XML always names one; caustica's TOML
/// may leave it out).
pub(crate) const DEFAULT_TYPE: &str = perspective::PLUGIN.name;

/// The keys every sensor takes beside its own, read by the scene builder (`scene::build`).
pub(crate) const COMMON_KEYS: &[&str] = &["to_world", "film"];

/// The clip planes `near_clip`, `far_clip` every sensor reads, Mitsuba's defaults for those left out (checked
/// with the camera: [`Camera::with_projection`]).
fn clip_planes(p: &Props<'_, ()>) -> Result<(f32, f32), PropError> {
    Ok((p.float_or("near_clip", DEFAULT_NEAR_CLIP)?, p.float_or("far_clip", DEFAULT_FAR_CLIP)?))
}

/// The field of view in degrees and its axis of the sensors with a film at depth 1 (perspective, thin lens):
/// `fov` along `fov_axis` (default x, as Mitsuba), or else the 35 mm equivalent `focal_length` (Mitsuba's
/// default "50mm") across the film's diagonal ([`focal_length_fov`]); not both.
fn field_of_view(p: &Props<'_, ()>) -> Result<(f32, FovAxis), PropError> {
    let axis = match p.string("fov_axis")? {
        None => FovAxis::default(),
        Some(name) => FovAxis::from_name(name).ok_or_else(|| PropError::new("fov_axis", format!("{name:?} is not an axis (x, y, diagonal, smaller or larger)")))?,
    };
    if p.has("fov") {
        if p.has("focal_length") {
            return Err(PropError::new("focal_length", "give either fov or focal_length, not both"));
        }
        let fov = p.float_or("fov", 0.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(PropError::new("fov", CameraError::Fov(fov).to_string()));
        }
        return Ok((fov, axis));
    }
    let mm = match p.number_or_name("focal_length")? {
        None => "50mm".to_string(),
        Some(NumberOrName::Number(x)) => x.to_string(),
        Some(NumberOrName::Name(text)) => text.to_string(),
    };
    let fov = focal_length_fov(&mm).ok_or_else(|| PropError::new("focal_length", format!("{mm:?} is not a focal length (a positive number of millimetres, \"50mm\")")))?;
    Ok((fov, FovAxis::Diagonal))
}

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

/// Mitsuba's default near clip plane (`ProjectiveCamera`, src/render/sensor.cpp): thinlens and orthographic.
pub const DEFAULT_NEAR_CLIP: f32 = 1e-2;
/// Mitsuba's default far clip plane (`ProjectiveCamera`); also the thin lens's default `focus_distance`.
pub const DEFAULT_FAR_CLIP: f32 = 1e4;

/// How film points become rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Mitsuba's `perspective`: a pinhole, `fov` degrees along `fov_axis`.
    Perspective { fov_deg: f32, fov_axis: FovAxis, near_clip: f32, far_clip: f32 },
    /// Mitsuba's `thinlens`: a perspective view through a circular aperture, in focus at `focus_distance`.
    ThinLens {
        fov_deg: f32,
        fov_axis: FovAxis,
        aperture_radius: f32,
        focus_distance: f32,
        near_clip: f32,
        far_clip: f32,
    },
    /// Mitsuba's `orthographic`: parallel rays from the camera plane's [-1, 1] × [-h/w, h/w].
    Orthographic { near_clip: f32, far_clip: f32 },
}

impl Projection {
    /// Mitsuba's plugin name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Projection::Perspective { .. } => perspective::PLUGIN.name,
            Projection::ThinLens { .. } => thinlens::PLUGIN.name,
            Projection::Orthographic { .. } => orthographic::PLUGIN.name,
        }
    }

    /// The field of view and its axis (none for orthographic).
    #[must_use]
    pub fn fov(&self) -> Option<(f32, FovAxis)> {
        match *self {
            Projection::Perspective { fov_deg, fov_axis, .. } | Projection::ThinLens { fov_deg, fov_axis, .. } => Some((fov_deg, fov_axis)),
            Projection::Orthographic { .. } => None,
        }
    }

    /// The clip planes (near, far).
    #[must_use]
    pub fn clip(&self) -> (f32, f32) {
        match *self {
            Projection::Perspective { near_clip, far_clip, .. }
            | Projection::ThinLens { near_clip, far_clip, .. }
            | Projection::Orthographic { near_clip, far_clip } => (near_clip, far_clip),
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
    #[error("a thinlens camera's to_world must not scale (as in Mitsuba: rotations, translations and look_at only)")]
    Scale,
    #[error("aperture_radius must be finite and ≥ 0, got {0}")]
    ApertureRadius(f32),
    #[error("focus_distance must be finite and > 0, got {0}")]
    FocusDistance(f32),
    #[error("near_clip must be finite and > 0, got {0}")]
    NearClip(f32),
    #[error("far_clip ({far}) must be finite and greater than near_clip ({near})")]
    FarClip { near: f32, far: f32 },
}

/// The camera: a projection, its placement and the film it renders.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    camera_to_world: Mat4,
    /// Linear part of `camera_to_world` (maps camera-space directions to world space).
    basis: Mat3,
    origin: Vec3,
    projection: Projection,
    width: u32,
    height: u32,
    crop: Rect,
    /// How the film reconstructs pixels from the samples (the film's `rfilter`).
    filter: PixelFilter,
    /// Perspective and thin lens: tan of half the field of view along film x and film y (the image plane at
    /// depth 1 spans [-half.x, half.x] × [-half.y, half.y]). Orthographic: the half extent of the camera
    /// plane the film covers, (1, h/w).
    half: Vec2,
    /// Orthographic: the world direction of every ray (`basis · +z`, normalised).
    ortho_dir: Vec3,
}

impl Camera {
    /// A perspective camera with Mitsuba's default clip planes and the full film as its crop window.
    pub fn new(camera_to_world: Mat4, fov_deg: f32, fov_axis: FovAxis, width: u32, height: u32) -> Result<Camera, CameraError> {
        let projection = Projection::Perspective { fov_deg, fov_axis, near_clip: DEFAULT_NEAR_CLIP, far_clip: DEFAULT_FAR_CLIP };
        Camera::with_projection(camera_to_world, projection, width, height)
    }

    /// A camera of any projection with the full film as its crop window; its parameters checked here.
    pub fn with_projection(camera_to_world: Mat4, projection: Projection, width: u32, height: u32) -> Result<Camera, CameraError> {
        if let Some((fov_deg, _)) = projection.fov() {
            if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
                return Err(CameraError::Fov(fov_deg));
            }
        }
        if let Projection::ThinLens { aperture_radius, focus_distance, .. } = projection {
            thinlens::check(aperture_radius, focus_distance)?;
        }
        // Mitsuba's `ProjectiveCamera` constructor: 0 < near_clip < far_clip.
        let (near, far) = projection.clip();
        if !(near.is_finite() && near > 0.0) {
            return Err(CameraError::NearClip(near));
        }
        if !(far.is_finite() && far > near) {
            return Err(CameraError::FarClip { near, far });
        }
        let basis = Mat3::from_mat4(camera_to_world);
        let det = basis.determinant();
        let affine = camera_to_world.row(3) == crate::math::Vec4::W;
        if !camera_to_world.is_finite() || !affine || !det.is_finite() || det == 0.0 {
            return Err(CameraError::Transform);
        }
        if matches!(projection, Projection::ThinLens { .. }) && has_scale(basis) {
            return Err(CameraError::Scale);
        }
        let mut camera = Camera {
            camera_to_world,
            basis,
            origin: camera_to_world.w_axis.truncate(),
            projection,
            width: 1,
            height: 1,
            crop: Rect::new(0, 0, 1, 1),
            filter: PixelFilter::default(),
            half: Vec2::ONE,
            ortho_dir: (basis * Vec3::Z).normalize(),
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

    /// The projection and its parameters.
    #[must_use]
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// The field of view in degrees and its axis (none for orthographic).
    #[must_use]
    pub fn fov(&self) -> Option<(f32, FovAxis)> {
        self.projection.fov()
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
        let (w, h) = (width as f32, height as f32);
        self.half = match self.projection.fov() {
            Some((fov_deg, fov_axis)) => tan_half(fov_deg, fov_axis, w, h),
            None => orthographic::half(w, h),
        };
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

    /// The width one pixel covers at `distance` from the camera (method.md §3.2): how far apart the rays
    /// through the two edges of the film's centre pixel are there, the larger of its x and y edges (a
    /// perspective or thin-lens pixel's angle times the distance; an orthographic pixel's size), plus
    /// for a thin lens the diameter of its circle of confusion there, `2·a·|d − f|/f` (aperture radius a,
    /// focus distance f: the lens's rays through one film point cross at depth f).
    #[must_use]
    pub fn pixel_footprint(&self, distance: f32) -> f32 {
        let (cx, cy) = (0.5 * self.width as f32, 0.5 * self.height as f32);
        let spread = |a: Ray, b: Ray| a.at(distance).distance(b.at(distance));
        let x = spread(self.generate_ray(cx - 0.5, cy), self.generate_ray(cx + 0.5, cy));
        let y = spread(self.generate_ray(cx, cy - 0.5), self.generate_ray(cx, cy + 0.5));
        let blur = match self.projection {
            Projection::ThinLens { aperture_radius, focus_distance, .. } => thinlens::blur(aperture_radius, focus_distance, distance),
            _ => 0.0,
        };
        x.max(y) + blur
    }

    /// [`Camera::pixel_footprint`] at the far side of the bounding sphere of `bounds` (where the caustics
    /// of the objects in it land, seen from the camera); `None` for empty bounds.
    #[must_use]
    pub fn pixel_footprint_beyond(&self, bounds: crate::math::Aabb) -> Option<f32> {
        if bounds.is_empty() {
            return None;
        }
        let (centre, radius) = bounds.bounding_sphere();
        Some(self.pixel_footprint(centre.distance(self.origin) + radius))
    }

    /// Whether [`Camera::sample_ray`] draws a lens sample (thin lens only).
    #[must_use]
    pub fn needs_lens_sample(&self) -> bool {
        matches!(self.projection, Projection::ThinLens { .. })
    }

    /// Sample ray through film position (`film_x`, `film_y`) (pixels, as [`Camera::generate_ray`]): a thin
    /// lens draws its lens sample from `sampler` (one 2-D dimension); the other projections draw nothing,
    /// so their samples' later dimensions are those of a pinhole.
    #[must_use]
    pub fn sample_ray(&self, film_x: f32, film_y: f32, sampler: &mut Sampler) -> Ray {
        let lens = if self.needs_lens_sample() { sampler.next_2d() } else { Vec2::splat(0.5) };
        self.ray_through(film_x, film_y, lens)
    }

    /// The ray through film position (`film_x`, `film_y`) and the centre of the lens. The direction is
    /// unit length; the ray starts at the camera (or its film point) and is valid between the clip planes.
    #[must_use]
    pub fn generate_ray(&self, film_x: f32, film_y: f32) -> Ray {
        self.ray_through(film_x, film_y, Vec2::splat(0.5))
    }

    /// The ray through film position (`film_x`, `film_y`) in pixels, (0, 0) = top-left corner of the full
    /// film, and the lens point of `lens ∈ [0, 1)²` (by the concentric disk map; unused but by the thin lens;
    /// (½, ½) is the centre). The direction is unit length.
    #[must_use]
    pub fn ray_through(&self, film_x: f32, film_y: f32, lens: Vec2) -> Ray {
        // Normalised device coordinates in [-1, 1], x to the right, y downwards.
        let ndc_x = 2.0 * film_x / self.width as f32 - 1.0;
        let ndc_y = 2.0 * film_y / self.height as f32 - 1.0;
        // Camera space: +x is left and +y is up (Mitsuba), so both flip. The film point on the plane at
        // depth 1 (perspective, thin lens) or on the camera plane (orthographic).
        let film = Vec2::new(-ndc_x * self.half.x, -ndc_y * self.half.y);
        match self.projection {
            Projection::Perspective { near_clip, far_clip, .. } => perspective::ray(self, film, near_clip, far_clip),
            Projection::ThinLens { aperture_radius, focus_distance, near_clip, far_clip, .. } => {
                thinlens::ray(self, film, lens, aperture_radius, focus_distance, near_clip, far_clip)
            }
            Projection::Orthographic { near_clip, far_clip } => orthographic::ray(self, film, near_clip, far_clip),
        }
    }
}

/// The clip rule of every projection (Mitsuba's `near_clip`/`far_clip`, the `sample_ray` of
/// src/sensors/perspective.cpp, thinlens.cpp and orthographic.cpp): a camera ray keeps its unclipped start
/// (the pinhole, the lens point, the film point on the camera plane) and is valid only where its depth along
/// the camera's viewing axis (camera-space z) lies in [near_clip, far_clip] — a depth, not a distance along
/// the ray, so the far plane is flat. `v` is the ray's direction in world space, `v_depth` the camera-space
/// depth it gains per unit of `v` (the start's depth is 0); the ray's direction is `v` normalised.
fn depth_clipped(start: Vec3, v: Vec3, v_depth: f32, near_clip: f32, far_clip: f32) -> Ray {
    let per_depth = v.length() / v_depth;
    Ray::segment(start, v.normalize(), near_clip * per_depth, far_clip * per_depth)
}

/// tan of half the field of view along film x and y for a `w × h` film: `fov` on its axis, the other in
/// proportion (tan_x / tan_y = w / h): Mitsuba's `parse_fov` with the film's aspect, then
/// `perspective_projection`. The perspective camera's film, and a projector's (`emitter::projector`).
#[must_use]
pub fn tan_half(fov_deg: f32, fov_axis: FovAxis, w: f32, h: f32) -> Vec2 {
    let t = (0.5 * fov_deg.to_radians()).tan();
    let axis_is_x = match fov_axis {
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

/// Mitsuba's `Transform::has_scale` (include/mitsuba/core/transform.h): some product of two rows of the
/// linear part differs from the identity's (1 on a row with itself, 0 between two) by more than 10⁻³.
fn has_scale(m: Mat3) -> bool {
    let rows = [m.row(0), m.row(1), m.row(2)];
    (0..3).any(|i| (i..3).any(|j| (rows[i].dot(rows[j]) - if i == j { 1.0 } else { 0.0 }).abs() > 1e-3))
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

    fn thin_lens(m: Mat4, aperture_radius: f32, focus_distance: f32) -> Camera {
        let p = Projection::ThinLens {
            fov_deg: 40.0,
            fov_axis: FovAxis::X,
            aperture_radius,
            focus_distance,
            near_clip: DEFAULT_NEAR_CLIP,
            far_clip: DEFAULT_FAR_CLIP,
        };
        Camera::with_projection(m, p, 64, 48).unwrap()
    }

    /// Lens samples over [0, 1)², a grid with its corners.
    fn lens_samples() -> impl Iterator<Item = Vec2> {
        (0..7).flat_map(|i| (0..7).map(move |j| Vec2::new(i as f32 / 6.0, j as f32 / 6.0).min(Vec2::splat(0.999_999))))
    }

    #[test]
    fn a_thin_lens_without_aperture_is_the_pinhole() {
        let m = look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, 0.0), Vec3::Y).unwrap();
        let pinhole = Camera::new(m, 40.0, FovAxis::X, 64, 48).unwrap();
        let lens = thin_lens(m, 0.0, 7.0);
        for (x, y) in [(0.0, 0.0), (32.0, 24.0), (63.5, 10.25), (64.0, 48.0)] {
            let p = pinhole.generate_ray(x, y);
            for u in lens_samples() {
                let r = lens.ray_through(x, y, u);
                assert!(r.dir.abs_diff_eq(p.dir, 1e-6), "{x},{y} {u}: {} vs {}", r.dir, p.dir);
                // The same ray, clipped alike: from the near clip plane (depth 0.01 along the axis) to the far.
                assert_eq!(r.origin, p.origin);
                assert!((r.t_min / p.t_min - 1.0).abs() < 1e-5 && (r.t_max / p.t_max - 1.0).abs() < 1e-5, "{r:?} {p:?}");
                let depth = (r.at(r.t_min) - p.origin).dot(pinhole.generate_ray(32.0, 24.0).dir);
                assert!((depth - DEFAULT_NEAR_CLIP).abs() < 1e-6, "{depth}");
            }
        }
    }

    #[test]
    fn thin_lens_rays_of_a_film_point_meet_on_the_focal_plane() {
        let (o, target) = (Vec3::new(0.5, 1.0, 6.0), Vec3::new(0.0, 0.5, 0.0));
        let m = look_at(o, target, Vec3::Y).unwrap();
        let axis = (target - o).normalize();
        let focus = 4.5;
        let cam = thin_lens(m, 0.25, focus);
        for (x, y) in [(32.0, 24.0), (3.5, 40.0), (60.0, 1.0)] {
            // Where each lens sample's ray reaches depth `focus` along the viewing axis.
            let meets: Vec<Vec3> = lens_samples()
                .map(|u| {
                    let r = cam.ray_through(x, y, u);
                    let t = (focus - (r.origin - o).dot(axis)) / r.dir.dot(axis);
                    r.at(t)
                })
                .collect();
            let first = meets[0];
            assert!(meets.iter().all(|p| p.abs_diff_eq(first, 1e-4)), "{x},{y}: {meets:?}");
            // That point is on the pinhole ray of the film point.
            let pin = Camera::new(m, 40.0, FovAxis::X, 64, 48).unwrap().generate_ray(x, y);
            assert!(pin.at(pin.origin.distance(first)).abs_diff_eq(first, 1e-4));
            // The lens samples start over the aperture: spread up to its radius around the camera.
            let spread = lens_samples().map(|u| cam.ray_through(x, y, u).origin.distance(o)).fold(0.0f32, f32::max);
            assert!(spread > 0.24 && spread < 0.26, "{spread}");
        }
        // The clip planes bound the rays: depths 0.01 and 10⁴ along the axis.
        let r = cam.ray_through(0.0, 0.0, Vec2::new(0.1, 0.9));
        assert!(((r.at(r.t_min) - o).dot(axis) - DEFAULT_NEAR_CLIP).abs() < 1e-5);
        assert!(((r.at(r.t_max) - o).dot(axis) - DEFAULT_FAR_CLIP).abs() < 1.0);
    }

    #[test]
    fn orthographic_rays_are_parallel_and_span_the_scaled_film() {
        // Mitsuba's example: the sensor plane scaled to 20 × 20 units (× h/w in y), then placed by look_at.
        let (o, target) = (Vec3::new(1.0, 1.0, 1.0), Vec3::new(1.0, 2.0, 1.0));
        let place = look_at(o, target, Vec3::Z).unwrap();
        let m = place * Mat4::from_scale(Vec3::new(10.0, 10.0, 1.0));
        let p = Projection::Orthographic { near_clip: 0.5, far_clip: 100.0 };
        let cam = Camera::with_projection(m, p, 64, 48).unwrap();
        assert_eq!(cam.fov(), None);
        let dir = Vec3::Y;
        let corners = [(0.0, 0.0), (64.0, 0.0), (0.0, 48.0), (64.0, 48.0)].map(|(x, y)| cam.generate_ray(x, y));
        for r in cam_rays(&cam).iter().chain(&corners) {
            assert!(r.dir.abs_diff_eq(dir, 1e-6), "{}", r.dir);
            // Every ray starts on the camera plane and is valid from the near plane, 0.5 ahead of the
            // camera, to the far one.
            assert!((r.origin - o).dot(dir).abs() < 1e-5);
            assert!(((r.at(r.t_min) - o).dot(dir) - 0.5).abs() < 1e-5);
            assert!((r.t_max - r.t_min - 99.5).abs() < 1e-4);
        }
        // The film spans 20 units across (x of the image: the camera's left is world -x here) and 15 up
        // (z, the up vector), centred on the axis.
        let (tl, tr, bl) = (corners[0].origin, corners[1].origin, corners[2].origin);
        assert!((tr - tl).abs_diff_eq(Vec3::new(20.0, 0.0, 0.0), 1e-4), "{}", tr - tl);
        assert!((tl - bl).abs_diff_eq(Vec3::new(0.0, 0.0, 15.0), 1e-4), "{}", tl - bl);
        assert!(cam.generate_ray(32.0, 24.0).origin.abs_diff_eq(o, 1e-5));
        // Neither projection draws a lens sample but the thin lens.
        assert!(!cam.needs_lens_sample() && !Camera::new(m, 40.0, FovAxis::X, 4, 4).unwrap().needs_lens_sample());
        assert!(thin_lens(place, 0.1, 1.0).needs_lens_sample());
    }

    #[test]
    fn perspective_rays_are_clipped_by_depth_along_the_viewing_axis() {
        // perspective.cpp: near_t = near_clip / d.z and far_t = far_clip / d.z for the camera-space unit
        // direction d; caustica keeps the origin at the pinhole and bounds t instead.
        let (o, target) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, 0.0));
        let m = look_at(o, target, Vec3::Y).unwrap();
        let axis = (target - o).normalize();
        let p = Projection::Perspective { fov_deg: 60.0, fov_axis: FovAxis::X, near_clip: 0.5, far_clip: 7.0 };
        let cam = Camera::with_projection(m, p, 64, 48).unwrap();
        let pinhole = Camera::new(m, 60.0, FovAxis::X, 64, 48).unwrap();
        for (x, y) in [(0.0, 0.0), (32.0, 24.0), (63.5, 10.25), (64.0, 48.0)] {
            let (r, q) = (cam.generate_ray(x, y), pinhole.generate_ray(x, y));
            // The same origin and direction, bit for bit, as the default clip planes' ray.
            assert_eq!((r.origin, r.dir), (q.origin, q.dir));
            let cos = r.dir.dot(axis);
            assert!((r.t_min - 0.5 / cos).abs() < 1e-5 && (r.t_max - 7.0 / cos).abs() < 1e-4, "{r:?}");
            assert!(((r.at(r.t_min) - o).dot(axis) - 0.5).abs() < 1e-5);
            assert!(((r.at(r.t_max) - o).dot(axis) - 7.0).abs() < 1e-4);
        }
        // A uniform scale in to_world scales the depths (they are camera-space depths, as Mitsuba's).
        let scaled = Camera::with_projection(m * Mat4::from_scale(Vec3::splat(2.0)), p, 64, 48).unwrap();
        let r = scaled.generate_ray(32.0, 24.0);
        assert!((r.t_min - 1.0).abs() < 1e-5 && (r.t_max - 14.0).abs() < 1e-4, "{r:?}");
    }

    #[test]
    fn pixel_footprints() {
        let m = look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, 0.0), Vec3::Y).unwrap();
        // Perspective: d·2·tan(fov/2)/W, the x axis the wider one here (fov on x).
        let cam = Camera::new(m, 40.0, FovAxis::X, 640, 480).unwrap();
        let want = |d: f32| d * 2.0 * (20f32.to_radians()).tan() / 640.0;
        for d in [0.5, 10.0, 1000.0] {
            assert!((cam.pixel_footprint(d) / want(d) - 1.0).abs() < 1e-3, "{d}: {} vs {}", cam.pixel_footprint(d), want(d));
        }
        // A thin lens adds its circle of confusion 2·a·|d − f|/f: none on the focal plane.
        let lens = thin_lens(m, 0.1, 5.0);
        let pin = Camera::new(m, 40.0, FovAxis::X, 64, 48).unwrap();
        assert!((lens.pixel_footprint(5.0) - pin.pixel_footprint(5.0)).abs() < 1e-6);
        assert!((lens.pixel_footprint(15.0) - pin.pixel_footprint(15.0) - 2.0 * 0.1 * 10.0 / 5.0).abs() < 1e-3);
        // Orthographic: the pixel's size, whatever the distance (a view 20 units wide over 64 pixels).
        let ortho = Projection::Orthographic { near_clip: 0.5, far_clip: 100.0 };
        let cam = Camera::with_projection(m * Mat4::from_scale(Vec3::new(10.0, 10.0, 1.0)), ortho, 64, 48).unwrap();
        assert!((cam.pixel_footprint(1.0) - 20.0 / 64.0).abs() < 1e-5 && (cam.pixel_footprint(50.0) - 20.0 / 64.0).abs() < 1e-4);
        // Beyond a box: at the far side of its bounding sphere; nothing for an empty box.
        let cam = Camera::new(look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y).unwrap(), 40.0, FovAxis::X, 100, 100).unwrap();
        let b = crate::math::Aabb::EMPTY.grow(Vec3::splat(-1.0)).grow(Vec3::splat(1.0));
        let far = 10.0 + 3f32.sqrt();
        assert!((cam.pixel_footprint_beyond(b).unwrap() - cam.pixel_footprint(far)).abs() < 1e-6);
        assert_eq!(cam.pixel_footprint_beyond(crate::math::Aabb::EMPTY), None);
    }

    #[test]
    fn an_xml_film_crop_reaches_the_camera_and_the_film() {
        // Mitsuba's hdrfilm (src/render/film.cpp): crop_offset_x/y default to 0, crop_width/height to the
        // rest of the film, and the window must lie within the film.
        let load = |crop: &str| {
            let xml = format!(
                "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"64\"/>\
                 <integer name=\"height\" value=\"48\"/>{crop}</film></sensor><shape type=\"cube\"/></scene>"
            );
            crate::scene::Scene::from_xml_str(&xml, std::path::Path::new("."), std::path::Path::new("crop.xml"), &Default::default())
        };
        let int = |name: &str, v: u32| format!("<integer name=\"{name}\" value=\"{v}\"/>");
        let scene = load(&format!("{}{}{}", int("crop_offset_x", 8), int("crop_offset_y", 4), int("crop_width", 16))).unwrap();
        assert_eq!(scene.camera.crop(), Rect::new(8, 4, 24, 48));
        let film = crate::film::Film::for_camera(&scene.camera).unwrap();
        assert_eq!((film.width(), film.crop()), (64, Rect::new(8, 4, 24, 48)));
        assert_eq!(load(&int("crop_height", 10)).unwrap().camera.crop(), Rect::new(0, 0, 64, 10));
        assert_eq!(load("").unwrap().camera.crop(), Rect::new(0, 0, 64, 48));
        let e = load(&format!("{}{}", int("crop_offset_x", 60), int("crop_width", 8))).err().expect("outside the film");
        assert!(e.to_string().contains("crop.xml") && e.to_string().contains("crop"), "{e}");
    }

    fn cam_rays(cam: &Camera) -> Vec<Ray> {
        (0..5).flat_map(|i| (0..5).map(move |j| (i as f32 * 13.1, j as f32 * 9.7))).map(|(x, y)| cam.generate_ray(x, y)).collect()
    }

    #[test]
    fn lens_and_clip_parameters_are_checked() {
        let m = Mat4::IDENTITY;
        let lens = |a: f32, f: f32, n: f32, far: f32| Projection::ThinLens { fov_deg: 40.0, fov_axis: FovAxis::X, aperture_radius: a, focus_distance: f, near_clip: n, far_clip: far };
        assert!(Camera::with_projection(m, lens(0.1, 2.0, 0.01, 100.0), 4, 4).is_ok());
        assert_eq!(Camera::with_projection(m, lens(-0.1, 2.0, 0.01, 100.0), 4, 4), Err(CameraError::ApertureRadius(-0.1)));
        assert_eq!(Camera::with_projection(m, lens(0.1, 0.0, 0.01, 100.0), 4, 4), Err(CameraError::FocusDistance(0.0)));
        assert_eq!(Camera::with_projection(m, lens(0.1, 2.0, 0.0, 100.0), 4, 4), Err(CameraError::NearClip(0.0)));
        assert_eq!(Camera::with_projection(m, lens(0.1, 2.0, 1.0, 1.0), 4, 4), Err(CameraError::FarClip { near: 1.0, far: 1.0 }));
        // A scaled to_world: refused by the thin lens (Mitsuba's `has_scale`), taken by the orthographic camera.
        let scaled = Mat4::from_scale(Vec3::new(2.0, 2.0, 1.0));
        assert_eq!(Camera::with_projection(scaled, lens(0.1, 2.0, 0.01, 100.0), 4, 4), Err(CameraError::Scale));
        let mirrored = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        assert!(Camera::with_projection(mirrored, lens(0.1, 2.0, 0.01, 100.0), 4, 4).is_ok());
        assert!(Camera::with_projection(scaled, Projection::Orthographic { near_clip: 0.01, far_clip: 1e4 }, 4, 4).is_ok());
    }
}
