//! Mitsuba's `disk` as an emitter's surface (src/shapes/disk.cpp): the unit disk at z = 0 facing +z in
//! object space, under an affine `to_world` (a non-uniform scale or a shear makes it an ellipse). An
//! affine map has a constant Jacobian, so a point uniform on the unit disk (the concentric map, as
//! Mitsuba's `sample_position`) is uniform on the ellipse: `pdf_a = 1/A`, `A = π·|M·x̂ × M·ŷ|` =
//! `π·|det M|·|M⁻ᵀ·ẑ|` (M the linear part). The emitting normal is `M⁻ᵀ·ẑ` normalised (Mitsuba's frame
//! normal), negated by `flip_normals`. Texture coordinates: with `(x, y)` the object-space point,
//! `u = √(x² + y²)`, `v = atan2(y, x)/2π` in [0, 1).

use super::{affine_point_error, inverse_transpose, SurfacePoint};
use crate::accel::analytic::{object_uv, Kind};
use crate::math::{Vec2, Vec3};
use crate::sampling::warp::square_to_uniform_disk_concentric;
use glam::Affine3A;
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub struct DiskShape {
    to_world: Affine3A,
    to_object: Affine3A,
    /// Unit emitting normal.
    n: Vec3,
    area: f32,
}

impl DiskShape {
    /// The disk Mitsuba places by `to_world`, emitting toward `M⁻ᵀ·ẑ` or, with `flip`, away from it.
    /// `None` if `to_world` is singular or its area is not positive and finite.
    #[must_use]
    pub fn new(to_world: Affine3A, flip: bool) -> Option<Self> {
        let (inverse_transpose, det) = inverse_transpose(&to_world)?;
        let nz = inverse_transpose * Vec3::Z;
        let area = PI * det.abs() * nz.length();
        let n = nz.normalize_or_zero();
        if !(area > 0.0 && area.is_finite()) || n == Vec3::ZERO {
            return None;
        }
        Some(Self { to_world, to_object: to_world.inverse(), n: if flip { -n } else { n }, area })
    }

    #[must_use]
    pub fn area(&self) -> f32 {
        self.area
    }

    #[must_use]
    pub fn pdf_a(&self) -> f32 {
        1.0 / self.area
    }

    /// A point uniform by area.
    #[must_use]
    pub fn sample_area(&self, u: Vec2) -> SurfacePoint {
        let d = square_to_uniform_disk_concentric(u);
        let local = Vec3::new(d.x, d.y, 0.0);
        SurfacePoint {
            p: self.to_world.transform_point3(local),
            n: self.n,
            uv: object_uv(Kind::Disk, d.extend(0.0).as_dvec3()).as_vec2(),
            pdf_a: self.pdf_a(),
            p_error: affine_point_error(&self.to_world, local),
        }
    }

    /// The unit emitting normal (the same everywhere).
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        self.n
    }

    /// Mitsuba's texture coordinates of the surface point `p` (module docs).
    #[must_use]
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let local = self.to_object.transform_point3(p);
        object_uv(Kind::Disk, local.as_dvec3()).as_vec2()
    }
}

#[cfg(test)]
impl DiskShape {
    pub(super) fn to_world_for_tests(&self) -> Affine3A {
        self.to_world
    }
}
