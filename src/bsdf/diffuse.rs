//! Lambertian reflection, two-sided: `f = R/π` when `wo` and `wi` are on the same side, sampled with
//! the cosine-weighted hemisphere on `wo`'s side (pdf `|cos θi|/π`), so the sample weight is `R`.

use super::same_side;
use crate::math::{Vec2, Vec3};
use crate::sampling::warp::square_to_cosine_hemisphere;
use std::f32::consts::FRAC_1_PI;

/// `R/π` on `wo`'s side, 0 across the surface.
#[must_use]
pub(super) fn f(reflectance: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    if same_side(wo, wi) {
        reflectance * FRAC_1_PI
    } else {
        Vec3::ZERO
    }
}

/// `|cos θi|/π` on `wo`'s side.
#[must_use]
pub(super) fn pdf_w(wo: Vec3, wi: Vec3) -> f32 {
    if same_side(wo, wi) {
        wi.z.abs() * FRAC_1_PI
    } else {
        0.0
    }
}

/// A cosine-weighted direction on `wo`'s side (Malley's method).
#[must_use]
pub(super) fn sample_wi(wo: Vec3, u_dir: Vec2) -> Option<Vec3> {
    let mut wi = square_to_cosine_hemisphere(u_dir);
    if wo.z < 0.0 {
        wi.z = -wi.z;
    }
    (wi.z != 0.0).then_some(wi)
}
