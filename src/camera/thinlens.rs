//! Mitsuba's `thinlens` sensor (src/sensors/thinlens.cpp, `sample_ray`): the perspective film seen through
//! a circular aperture of radius `aperture_radius` in the camera's z = 0 plane. A lens sample (the concentric
//! disk map of one 2-D dimension of the sample, drawn right after the pixel position) picks a point on the
//! aperture; the ray goes from it to where the pinhole ray of the film point meets the plane
//! z = `focus_distance`, so every lens sample of a film point meets there (that plane is in focus). Mitsuba
//! refuses a `to_world` with a scale (its `has_scale`: any product of two rows of the linear part off the
//! identity's by > 10⁻³); so does caustica.
//!
//! ```toml
//! [sensor]
//! type = "thinlens"
//! fov = 45                  # as perspective: fov or focal_length, fov_axis, near_clip, far_clip
//! aperture_radius = 0.05    # required (Mitsuba has no default), ≥ 0; 0 is a pinhole
//! focus_distance = 4.0      # depth of the plane in focus along the viewing axis; default far_clip
//! to_world = { look_at = { origin = [0, 1.5, 4], target = [0, 0.3, 0], up = [0, 1, 0] } }
//! ```

use super::{clip_planes, depth_clipped, field_of_view, Camera, CameraError, Plugin, Projection};
use crate::math::{Ray, Vec2};
use crate::props::{PropError, Props};
use crate::sampling::warp::square_to_uniform_disk_concentric;

pub(super) const PLUGIN: Plugin = Plugin {
    name: "thinlens",
    keys: &["fov", "fov_axis", "focal_length", "near_clip", "far_clip", "aperture_radius", "focus_distance"],
    nested: &[],
    build,
};

/// thinlens.cpp reads `aperture_radius` without a default; the focal plane defaults to the far clip plane
/// (`ProjectiveCamera`).
fn build(p: Props<'_, ()>) -> Result<Projection, PropError> {
    let (fov_deg, fov_axis) = field_of_view(&p)?;
    let (near_clip, far_clip) = clip_planes(&p)?;
    if !p.has("aperture_radius") {
        return Err(PropError::new("", "a thinlens sensor needs aperture_radius"));
    }
    let aperture_radius = p.float_or("aperture_radius", 0.0)?;
    let focus_distance = p.float_or("focus_distance", far_clip)?;
    Ok(Projection::ThinLens { fov_deg, fov_axis, aperture_radius, focus_distance, near_clip, far_clip })
}

/// Its own parameters' checks: a finite aperture radius ≥ 0 and a finite focus distance > 0.
pub(super) fn check(aperture_radius: f32, focus_distance: f32) -> Result<(), CameraError> {
    if !(aperture_radius.is_finite() && aperture_radius >= 0.0) {
        return Err(CameraError::ApertureRadius(aperture_radius));
    }
    if !(focus_distance.is_finite() && focus_distance > 0.0) {
        return Err(CameraError::FocusDistance(focus_distance));
    }
    Ok(())
}

/// The ray through `film` (the image plane at depth 1, camera space) and the lens point of `lens ∈ [0, 1)²`:
/// from the aperture point toward where the pinhole ray meets the focal plane, valid between the clip planes.
pub(super) fn ray(camera: &Camera, film: Vec2, lens: Vec2, aperture_radius: f32, focus_distance: f32, near_clip: f32, far_clip: f32) -> Ray {
    let aperture = (aperture_radius * square_to_uniform_disk_concentric(lens)).extend(0.0);
    let focus = film.extend(1.0) * focus_distance;
    let start = camera.camera_to_world.transform_point3(aperture);
    depth_clipped(start, camera.basis * (focus - aperture), focus_distance, near_clip, far_clip)
}

/// The diameter of the circle of confusion at depth `distance`: the lens's rays through one film point
/// cross at depth f and spread `2·a·|d − f|/f` apart at depth d (method.md §3.2).
pub(super) fn blur(aperture_radius: f32, focus_distance: f32, distance: f32) -> f32 {
    2.0 * aperture_radius * (distance - focus_distance).abs() / focus_distance
}
