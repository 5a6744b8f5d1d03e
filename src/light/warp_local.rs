//! TEMPORARY local copies of the warps this module needs, written while `crate::sampling::warp` was being
//! written on another branch. LEAD: at merge, replace `use super::warp_local::*` by
//! `use crate::sampling::warp::{...}` in `area.rs`, `env.rs` and `mod.rs`, and delete this file (the names
//! and signatures are those of CONTRACTS.md / `sampling::warp`).

use crate::math::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Uniform direction on the unit sphere (pbrt-v4 `SampleUniformSphere`).
#[must_use]
pub(super) fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`square_to_uniform_sphere`]: `1/(4π)` per steradian.
#[must_use]
pub(super) fn uniform_sphere_pdf_w(_v: Vec3) -> f32 {
    1.0 / (4.0 * PI)
}

/// Uniform barycentrics `(b1, b2)` on a triangle, `p = (1 − b1 − b2)·p0 + b1·p1 + b2·p2` (square-root map).
#[must_use]
pub(super) fn square_to_uniform_triangle(u: Vec2) -> (f32, f32) {
    let t = (1.0 - u.x).max(0.0).sqrt();
    (1.0 - t, t * u.y)
}

/// Uniform point on the unit disk, concentric map (Shirley & Chiu 1997).
#[must_use]
pub(super) fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let uo = 2.0 * u - Vec2::ONE;
    if uo.x == 0.0 && uo.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if uo.x.abs() > uo.y.abs() {
        (uo.x, FRAC_PI_4 * (uo.y / uo.x))
    } else {
        (uo.y, FRAC_PI_2 - FRAC_PI_4 * (uo.x / uo.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method), density `cos θ / π`.
#[must_use]
pub(super) fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}
