//! Mitsuba's `cylinder` as an emitter's surface (src/shapes/cylinder.cpp): in object space the open tube
//! `x² + y² = 1`, `0 ≤ z ≤ 1` (no caps; Mitsuba's `p0`, `p1` and `radius` are folded into `to_world`),
//! placed by an affine `to_world`. Mitsuba's `sample_position` takes `(φ, z) = (2π·u.y, u.x)` uniformly
//! and reports `1/A`, `A = 2π·r·ℓ` with `r = |M·x̂|`, `ℓ = |M·ẑ|`: exact when the scale across the axis
//! is uniform (the only case it supports; it warns otherwise). Here the density is exact under any affine
//! map: the area element of the parameters is `|∂p/∂φ × ∂p/∂z| = |det M|·|M⁻ᵀ·n(φ)|`,
//! `n(φ) = (cos φ, sin φ, 0)` the object-space normal, so a point uniform in `(φ, z)` has
//! `pdf_a = 1/(2π·|det M|·|M⁻ᵀ·n(φ)|)` — `1/(2π·r·ℓ)` everywhere under Mitsuba's placements, varying with
//! φ on an elliptic tube. The area is `|det M|·∫|M⁻ᵀ·n(φ)| dφ`, by the trapezoidal rule (exact to f32
//! rounding for this smooth periodic integrand). The emitting normal is Mitsuba's hit normal
//! `∂p/∂φ × ∂p/∂z = det M·M⁻ᵀ·n(φ)` normalised (outward, inward under a mirroring `to_world`), negated by
//! `flip` — Mitsuba's `m_flip_normals`, which is `flip_normals` toggled by a mirror, so the two cancel and a
//! mirrored tube still emits outward. Texture coordinates: `u = φ/2π`, `v = z`.

use super::{affine_point_error, inverse_transpose, SurfacePoint};
use crate::accel::analytic::{object_uv, Kind};
use crate::math::{Mat3, Vec2, Vec3};
use glam::Affine3A;
use std::f32::consts::TAU;

/// Trapezoidal nodes for the area of an elliptic tube (relative error far below f32's for axis ratios < 10³).
const AREA_NODES: usize = 4096;

#[derive(Clone, Debug)]
pub struct CylinderShape {
    to_world: Affine3A,
    to_object: Affine3A,
    /// `sign(det M)·M⁻ᵀ`: the object-space normal `n(φ)` to the direction of `∂p/∂φ × ∂p/∂z`.
    normal_matrix: Mat3,
    abs_det: f32,
    flip: bool,
    area: f32,
}

impl CylinderShape {
    /// The tube Mitsuba places by `to_world`, emitting along `∂p/∂φ × ∂p/∂z` or, with `flip`, against it
    /// (module docs). `None` if `to_world` is singular or its area is not positive and finite.
    #[must_use]
    pub fn new(to_world: Affine3A, flip: bool) -> Option<Self> {
        let (inverse_transpose, det) = inverse_transpose(&to_world)?;
        let normal_matrix = inverse_transpose * det.signum();
        let abs_det = det.abs();
        let step = std::f64::consts::TAU / AREA_NODES as f64;
        let integral: f64 = (0..AREA_NODES)
            .map(|i| {
                let phi = i as f64 * step;
                let n = normal_matrix.as_dmat3() * glam::DVec3::new(phi.cos(), phi.sin(), 0.0);
                n.length()
            })
            .sum::<f64>()
            * step;
        let area = (f64::from(abs_det) * integral) as f32;
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        Some(Self { to_world, to_object: to_world.inverse(), normal_matrix, abs_det, flip, area })
    }

    #[must_use]
    pub fn area(&self) -> f32 {
        self.area
    }

    /// The unnormalised world normal `sign(det M)·M⁻ᵀ·n(φ)` at the object-space point of azimuth φ.
    fn normal_at(&self, cos_phi: f32, sin_phi: f32) -> Vec3 {
        self.normal_matrix * Vec3::new(cos_phi, sin_phi, 0.0)
    }

    /// `pdf_a` from the unnormalised normal's length (module docs).
    fn pdf_a_of(&self, normal_length: f32) -> f32 {
        1.0 / (TAU * self.abs_det * normal_length)
    }

    /// A point uniform in Mitsuba's parameters `(φ, z)`.
    #[must_use]
    pub fn sample_area(&self, u: Vec2) -> SurfacePoint {
        let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
        let local = Vec3::new(cos_phi, sin_phi, u.x);
        let nn = self.normal_at(cos_phi, sin_phi);
        let len = nn.length();
        let n = nn / len;
        SurfacePoint {
            p: self.to_world.transform_point3(local),
            n: if self.flip { -n } else { n },
            uv: Vec2::new(u.y, u.x),
            pdf_a: self.pdf_a_of(len),
            p_error: affine_point_error(&self.to_world, local),
        }
    }

    /// The density per unit area with which [`CylinderShape::sample_area`] gives the surface point `p`.
    #[must_use]
    pub fn pdf_a(&self, p: Vec3) -> f32 {
        let local = self.to_object.transform_point3(p);
        let rho = Vec2::new(local.x, local.y).length();
        if !(rho > 0.0) {
            return 0.0;
        }
        self.pdf_a_of(self.normal_at(local.x / rho, local.y / rho).length())
    }

    /// The unit emitting normal at the surface point `p`.
    #[must_use]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let local = self.to_object.transform_point3(p);
        let n = self.normal_at(local.x, local.y).normalize_or_zero();
        if self.flip { -n } else { n }
    }

    /// Mitsuba's texture coordinates of the surface point `p` (module docs).
    #[must_use]
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let local = self.to_object.transform_point3(p);
        object_uv(Kind::Cylinder, local.as_dvec3()).as_vec2()
    }
}

#[cfg(test)]
impl CylinderShape {
    pub(super) fn to_world_for_tests(&self) -> Affine3A {
        self.to_world
    }
}
