//! Mitsuba's `perspective` sensor (src/sensors/perspective.cpp): a pinhole at the camera position; its film
//! is the image plane at depth 1, `tan(fov/2)` wide on `fov_axis` ([`super::tan_half`]).
//!
//! ```toml
//! [sensor]
//! type = "perspective"
//! fov = 39.3077             # degrees, in (0, 180); or focal_length = "50mm" (Mitsuba's default)
//! fov_axis = "smaller"      # x (default) | y | diagonal | smaller | larger
//! near_clip = 0.01          # depths along the viewing axis, 0 < near_clip < far_clip (defaults 0.01, 10⁴)
//! far_clip = 10000
//! to_world = { look_at = { origin = [0, 0, 3.9], target = [0, 0, 0], up = [0, 1, 0] } }
//! ```

use super::{clip_planes, depth_clipped, field_of_view, Camera, Plugin, Projection};
use crate::math::{Ray, Vec2};
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin { name: "perspective", keys: &["fov", "fov_axis", "focal_length", "near_clip", "far_clip"], nested: &[], build };

fn build(p: Props<'_, ()>) -> Result<Projection, PropError> {
    let (fov_deg, fov_axis) = field_of_view(&p)?;
    let (near_clip, far_clip) = clip_planes(&p)?;
    Ok(Projection::Perspective { fov_deg, fov_axis, near_clip, far_clip })
}

/// The ray through `film`, a point of the image plane at depth 1 in camera space: from the pinhole, valid
/// between the clip planes (perspective.cpp `sample_ray`).
pub(super) fn ray(camera: &Camera, film: Vec2, near_clip: f32, far_clip: f32) -> Ray {
    depth_clipped(camera.origin, camera.basis * film.extend(1.0), 1.0, near_clip, far_clip)
}
