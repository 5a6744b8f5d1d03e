//! Mitsuba's `sphere` as an emitter's surface (src/shapes/sphere.cpp): the unit sphere at the origin
//! under `to_world`, whose centre is `to_world·0` and radius `|to_world·x̂|` (Mitsuba folds `center` and
//! `radius` into `to_world` and reads them back so; a non-uniform scale, which it warns about, still
//! gives that sphere). Texture coordinates: the point in object space `to_object·p`, `u = φ/2π` with
//! φ = atan2(y, x) in [0, 2π), `v = θ/π` with θ its angle from +z.
//!
//! NEE samples it by solid angle, as Mitsuba's `sample_direction`: from a point outside, a direction
//! uniform in the cone the sphere subtends, the point being the near intersection of that direction with
//! the sphere, density `1/(2π(1 − cos θ_max))`, `sin θ_max = r/d`; from a point inside, a point uniform by
//! area, converted to solid angle. Which rule applies is one predicate ([`SphereShape::sees_outside`]),
//! read by the sampler and by [`SphereShape::pdf_toward`] alike. A point on the surface itself counts as
//! outside when the sphere emits outward and inside when it emits inward (Mitsuba moves the radius by
//! its ray epsilon the same way), so each side takes the rule that reaches what it can see.

use super::SurfacePoint;
use crate::accel::analytic::{object_uv, Kind};
use crate::light::area::{pdf_w_from_area, pdf_w_from_parts};
use crate::math::{gamma, Frame, Vec2, Vec3};
use crate::sampling::warp::square_to_uniform_sphere;
use glam::Affine3A;
use std::f32::consts::{PI, TAU};

/// Relative margin on the radius in the inside/outside predicate (Mitsuba's `RayEpsilon` is 8.9e-5).
const SIDE_MARGIN: f32 = 1e-4;

#[derive(Clone, Debug)]
pub struct SphereShape {
    center: Vec3,
    radius: f32,
    /// Emits toward the centre.
    flip: bool,
    /// For the texture coordinates.
    to_object: Affine3A,
}

impl SphereShape {
    /// The sphere Mitsuba places by `to_world` (of its unit sphere), emitting outward or, with `flip`,
    /// inward. `None` if the radius is not positive and finite or `to_world` is not invertible.
    #[must_use]
    pub fn new(to_world: Affine3A, flip: bool) -> Option<Self> {
        let radius = to_world.matrix3.x_axis.length();
        let to_object = to_world.inverse();
        if !(radius > 0.0 && radius.is_finite()) || !to_object.is_finite() {
            return None;
        }
        Some(Self { center: Vec3::from(to_world.translation), radius, flip, to_object })
    }

    #[must_use]
    pub fn center(&self) -> Vec3 {
        self.center
    }

    #[must_use]
    pub fn radius(&self) -> f32 {
        self.radius
    }

    #[must_use]
    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    #[must_use]
    pub fn pdf_a(&self) -> f32 {
        1.0 / self.area()
    }

    /// The surface point in direction `d` (unit) from the centre.
    fn point(&self, d: Vec3) -> SurfacePoint {
        let p = self.center + self.radius * d;
        SurfacePoint {
            p,
            n: if self.flip { -d } else { d },
            uv: self.uv(p),
            pdf_a: self.pdf_a(),
            p_error: gamma(6) * (self.center.abs() + (self.radius * d).abs()),
        }
    }

    /// A point uniform by area.
    #[must_use]
    pub fn sample_area(&self, u: Vec2) -> SurfacePoint {
        self.point(square_to_uniform_sphere(u))
    }

    /// Whether NEE from `p_ref` samples the cone (outside) rather than the area (inside); see the module docs.
    #[must_use]
    pub fn sees_outside(&self, p_ref: Vec3) -> bool {
        let r = self.radius * if self.flip { 1.0 + SIDE_MARGIN } else { 1.0 - SIDE_MARGIN };
        (self.center - p_ref).length_squared() > r * r
    }

    /// `1 − cos θ_max` of the cone the sphere subtends from `p_ref` at squared distance `dc2` from the
    /// centre, and `sin² θ_max` (≤ 1): `sin²/(1 + cos)` keeps narrow cones exact.
    fn cone(&self, dc2: f32) -> (f32, f32) {
        let sin2_max = (self.radius * self.radius / dc2).min(1.0);
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        (sin2_max / (1.0 + cos_max), sin2_max)
    }

    /// NEE from `p_ref`: the point and its solid-angle density (module docs); `None` when the point's
    /// emitting side faces away (a sphere emitting inward seen from outside) or the density is degenerate.
    #[must_use]
    pub fn sample_toward(&self, p_ref: Vec3, u: Vec2) -> Option<(SurfacePoint, f32)> {
        if !self.sees_outside(p_ref) {
            let s = self.sample_area(u);
            let d = s.p - p_ref;
            let dist2 = d.length_squared();
            let pdf_w = pdf_w_from_parts(s.pdf_a, dist2, -s.n.dot(d) / dist2.sqrt());
            return (pdf_w > 0.0 && pdf_w.is_finite()).then_some((s, pdf_w));
        }
        let to_center = self.center - p_ref;
        let dc2 = to_center.length_squared();
        let dc = dc2.sqrt();
        let (one_minus_cos_max, sin2_max) = self.cone(dc2);
        // The direction's angle θ to the axis: cos θ uniform in [cos θ_max, 1], via 1 − cos θ.
        let one_minus_cos = u.x * one_minus_cos_max;
        let cos_theta = 1.0 - one_minus_cos;
        let sin2_theta = one_minus_cos * (2.0 - one_minus_cos);
        // The near intersection seen from the centre: its angle α to the axis back toward p_ref, from
        // the triangle (p_ref, centre, point) with sides d_c, r: cos α = (d_c/r)·sin²θ + cos θ·√(1 − (d_c/r)²·sin²θ).
        let sin_max = sin2_max.sqrt();
        let cos_alpha = (sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt()).min(1.0);
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = TAU * u.y;
        let frame = Frame::from_normal(-to_center / dc);
        let d = frame.to_world(Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha)).normalize();
        let s = self.point(d);
        let pdf_w = self.cone_pdf(p_ref, s.p, s.n, one_minus_cos_max);
        (pdf_w > 0.0 && pdf_w.is_finite()).then_some((s, pdf_w))
    }

    /// The cone's density, 0 where the point's emitting side faces away from `p_ref`.
    fn cone_pdf(&self, p_ref: Vec3, p: Vec3, n: Vec3, one_minus_cos_max: f32) -> f32 {
        if !(n.dot(p_ref - p) > 0.0 && one_minus_cos_max > 0.0) {
            return 0.0;
        }
        1.0 / (TAU * one_minus_cos_max)
    }

    /// The solid-angle density with which [`SphereShape::sample_toward`] from `p_ref` gives the point `p`
    /// (emitting normal `n`), `p` being the first point of the sphere along its direction.
    #[must_use]
    pub fn pdf_toward(&self, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        if self.sees_outside(p_ref) {
            self.cone_pdf(p_ref, p, n, self.cone((self.center - p_ref).length_squared()).0)
        } else {
            pdf_w_from_area(self.pdf_a(), p_ref, p, n)
        }
    }

    /// The unit emitting normal at the surface point `p`.
    #[must_use]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let d = (p - self.center).normalize_or_zero();
        if self.flip { -d } else { d }
    }

    /// Mitsuba's texture coordinates of the surface point `p` (module docs).
    #[must_use]
    pub fn uv(&self, p: Vec3) -> Vec2 {
        object_uv(Kind::Sphere, self.to_object.transform_point3(p).as_dvec3()).as_vec2()
    }
}
