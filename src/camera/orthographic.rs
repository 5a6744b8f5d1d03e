//! Mitsuba's `orthographic` sensor (src/sensors/orthographic.cpp with `orthographic_projection` of
//! include/mitsuba/render/sensor.h): the full film covers x ∈ [-1, 1] (left to right: +1 to -1) and
//! y ∈ [-h/w, h/w] of the camera plane; every ray leaves its film point along the camera's +z, normalised in
//! world space, from depth `near_clip` for a length `far_clip − near_clip` in world units (Mitsuba's `maxt`:
//! the far plane itself unless `to_world` scales z). `to_world` may scale: a scale of 10 in x and y makes the
//! view 20 units wide.
//!
//! ```toml
//! [sensor]
//! type = "orthographic"
//! near_clip = 0.5           # 0 < near_clip < far_clip (defaults 0.01, 10⁴)
//! far_clip = 7.5
//! to_world = [ { scale = [2.5, 2.5, 1] }, { look_at = { origin = [0, 3.5, 5], target = [0, 0, 0], up = [0, 1, 0] } } ]
//! ```

use super::{clip_planes, Camera, Plugin, Projection};
use crate::math::{Ray, Vec2, Vec3};
use crate::props::{PropError, Props};

pub(super) const PLUGIN: Plugin = Plugin { name: "orthographic", keys: &["near_clip", "far_clip"], nested: &[], build };

fn build(p: Props<'_, ()>) -> Result<Projection, PropError> {
    let (near_clip, far_clip) = clip_planes(&p)?;
    Ok(Projection::Orthographic { near_clip, far_clip })
}

/// The half extent of the camera plane the film covers: x spans [-1, 1], y the same scaled by h/w.
pub(super) fn half(w: f32, h: f32) -> Vec2 {
    Vec2::new(1.0, h / w)
}

/// The ray from `film`, a point of the camera plane (depth 0), along the camera's +z: valid from the near
/// plane (depth near_clip, |to_world·z| world units per unit of depth) for `far_clip − near_clip` world units
/// (orthographic.cpp `sample_ray`).
pub(super) fn ray(camera: &Camera, film: Vec2, near_clip: f32, far_clip: f32) -> Ray {
    let start = camera.camera_to_world.transform_point3(film.extend(0.0));
    let t_near = near_clip * (camera.basis * Vec3::Z).length();
    Ray::segment(start, camera.ortho_dir, t_near, t_near + (far_clip - near_clip))
}
