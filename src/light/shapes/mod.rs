//! The analytic surfaces an `area` emitter may sit on, as Mitsuba 3.9.1 samples them
//! (src/shapes/sphere.cpp, disk.cpp, cylinder.cpp: `sample_position`, `pdf_position`, `sample_direction`,
//! `pdf_direction`): the [`SphereShape`] by solid angle (a uniform cone toward it from outside, by area
//! from inside), the [`DiskShape`] and the [`CylinderShape`] by area, each under an affine `to_world`.
//!
//! Each shape is given by plain parameters (its `to_world` as an `Affine3A` of Mitsuba's object-space
//! shape, and whether its normal is negated), so the light does not depend on how the intersector stores
//! it; [`AnalyticShape::from_primitive`] reads them off `accel::analytic::Analytic`, whose hit normals the
//! light's must equal. The normal a surface point carries is its **emitting side** (Mitsuba's area emitter
//! is one-sided): Mitsuba's hit normal of the shape (each file says which), negated by `flip` (Mitsuba's
//! `m_flip_normals`). Texture coordinates are Mitsuba's at every point (`uv`).
//!
//! Densities: `pdf_a` per unit area of the world-space surface; `pdf_w` per steradian at a reference point,
//! 0 when the point's emitting side faces away from the reference point. Every sampler and its `pdf_*`
//! query share one function, so the two agree (MIS needs this).

mod cylinder;
mod disk;
mod sphere;
#[cfg(test)]
mod tests;

pub use cylinder::CylinderShape;
pub use disk::DiskShape;
pub use sphere::SphereShape;

use crate::accel::analytic::{Analytic, Kind};
use crate::math::{gamma, Mat3, Vec2, Vec3};
use glam::Affine3A;

/// A point sampled on an analytic surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit normal of the emitting side.
    pub n: Vec3,
    /// Mitsuba's texture coordinates of the point.
    pub uv: Vec2,
    /// Density of this point per unit area (the sampler's: 1/A, or the cylinder's under a non-uniform scale).
    pub pdf_a: f32,
    /// Conservative absolute error of `p` per axis, for `math::offset_ray_origin`.
    pub p_error: Vec3,
}

/// One analytic emitting surface.
#[derive(Clone, Debug)]
pub enum AnalyticShape {
    Sphere(SphereShape),
    Disk(DiskShape),
    Cylinder(CylinderShape),
}

impl AnalyticShape {
    /// The emitting surface of the intersector's primitive `a`: its placement and its normal rule (the
    /// sphere's and the tube's `flip`, `flip_normals` toggled by a mirror; the disk's `flip_normals` folded
    /// into its placement as a mirror of z). `None` when the shape has no area.
    #[must_use]
    pub fn from_primitive(a: &Analytic) -> Option<Self> {
        let to_world = a.to_world().as_affine3a();
        match a.kind {
            Kind::Sphere => SphereShape::new(to_world, a.flipped()).map(AnalyticShape::Sphere),
            Kind::Disk => DiskShape::new(to_world, a.flipped()).map(AnalyticShape::Disk),
            Kind::Cylinder => CylinderShape::new(to_world, a.flipped()).map(AnalyticShape::Cylinder),
        }
    }

    /// World-space area.
    #[must_use]
    pub fn area(&self) -> f32 {
        match self {
            AnalyticShape::Sphere(s) => s.area(),
            AnalyticShape::Disk(d) => d.area(),
            AnalyticShape::Cylinder(c) => c.area(),
        }
    }

    /// A point by area (photon emission): uniform on the sphere and the disk, uniform in Mitsuba's
    /// parameters on the cylinder.
    #[must_use]
    pub fn sample_area(&self, u: Vec2) -> SurfacePoint {
        match self {
            AnalyticShape::Sphere(s) => s.sample_area(u),
            AnalyticShape::Disk(d) => d.sample_area(u),
            AnalyticShape::Cylinder(c) => c.sample_area(u),
        }
    }

    /// The density per unit area with which [`AnalyticShape::sample_area`] gives the surface point `p`.
    #[must_use]
    pub fn pdf_a(&self, p: Vec3) -> f32 {
        match self {
            AnalyticShape::Sphere(s) => s.pdf_a(),
            AnalyticShape::Disk(d) => d.pdf_a(),
            AnalyticShape::Cylinder(c) => c.pdf_a(p),
        }
    }

    /// NEE: a point seen from `p_ref` and its solid-angle density; `None` if its emitting side faces away
    /// from `p_ref` or the density is not a positive finite number.
    #[must_use]
    pub fn sample_toward(&self, p_ref: Vec3, u: Vec2) -> Option<(SurfacePoint, f32)> {
        match self {
            AnalyticShape::Sphere(s) => s.sample_toward(p_ref, u),
            AnalyticShape::Disk(d) => by_area(p_ref, d.sample_area(u)),
            AnalyticShape::Cylinder(c) => by_area(p_ref, c.sample_area(u)),
        }
    }

    /// The solid-angle density with which [`AnalyticShape::sample_toward`] from `p_ref` gives the surface
    /// point `p` of emitting normal `n` (what a BSDF-sampled ray that found `p` needs for its MIS weight).
    #[must_use]
    pub fn pdf_toward(&self, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        match self {
            AnalyticShape::Sphere(s) => s.pdf_toward(p_ref, p, n),
            AnalyticShape::Disk(d) => super::area::pdf_w_from_area(d.pdf_a(), p_ref, p, n),
            AnalyticShape::Cylinder(c) => super::area::pdf_w_from_area(c.pdf_a(p), p_ref, p, n),
        }
    }

    /// The unit emitting normal at the surface point `p` (the normal its samples carry).
    #[must_use]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        match self {
            AnalyticShape::Sphere(s) => s.normal(p),
            AnalyticShape::Disk(d) => d.normal(),
            AnalyticShape::Cylinder(c) => c.normal(p),
        }
    }

    /// Mitsuba's texture coordinates of the surface point `p`.
    #[must_use]
    pub fn uv(&self, p: Vec3) -> Vec2 {
        match self {
            AnalyticShape::Sphere(s) => s.uv(p),
            AnalyticShape::Disk(d) => d.uv(p),
            AnalyticShape::Cylinder(c) => c.uv(p),
        }
    }
}

/// A point sampled by area, seen from `p_ref`: its solid-angle density `pdf_a·d²/cos θ_l`.
fn by_area(p_ref: Vec3, s: SurfacePoint) -> Option<(SurfacePoint, f32)> {
    let pdf_w = super::area::pdf_w_from_area(s.pdf_a, p_ref, s.p, s.n);
    (pdf_w > 0.0 && pdf_w.is_finite()).then_some((s, pdf_w))
}

/// The linear part of `t` as a `Mat3`.
fn linear(t: &Affine3A) -> Mat3 {
    Mat3::from(t.matrix3)
}

/// `(M⁻ᵀ, det M)` of `t`'s linear part `M` (normals map by `M⁻ᵀ`), or `None` when `M` is singular or its
/// determinant not finite: the check every shape placed by an affine map opens with.
fn inverse_transpose(t: &Affine3A) -> Option<(Mat3, f32)> {
    let m = linear(t);
    let det = m.determinant();
    (det != 0.0 && det.is_finite()).then(|| (m.inverse().transpose(), det))
}

/// Conservative absolute error of `t·local` per axis when `local` itself carries a few ulps of relative
/// error (sines and cosines): `γ(6)·(|M|·|local| + |translation|)` (pbrt-v4 §6.8.5 for the transform, three
/// more roundings for `local`).
fn affine_point_error(t: &Affine3A, local: Vec3) -> Vec3 {
    let m = linear(t);
    let abs = Mat3::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
    gamma(6) * (abs * local.abs() + Vec3::from(t.translation).abs())
}
