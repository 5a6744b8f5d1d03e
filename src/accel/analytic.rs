//! Analytic primitives — Mitsuba's `sphere`, `disk` and `cylinder` as the quadrics they are, not
//! triangles: the one intersection routine every backend calls (so their hits agree bit for bit) and the
//! surface at a hit (point, normal, Mitsuba's uv and `∂p/∂u`, `∂p/∂v`), which `scene::interaction` reads.
//!
//! Each primitive is its object-space shape placed by an affine `to_world` (f64, with its inverse):
//!
//! - `sphere` (Mitsuba 3.9.1 src/shapes/sphere.cpp): the unit sphere; Mitsuba takes its world centre as
//!   `to_world·0` and its radius as `|to_world·x̂|`, and intersects *that* sphere in world space, whatever
//!   the transform: a non-uniform scale is not an ellipsoid but a sphere of the x axis's scale (Mitsuba
//!   warns; so does the scene loader, in a note). The quadratic is solved from the point of the ray's line
//!   closest to the centre (Mitsuba's `plane_t` trick, pbrt-v4 / Ray Tracing Gems ch. 7), in f64. The
//!   normal is `p − c` (outward), negated by `flip_normals` and, as Mitsuba does, by a mirroring transform.
//! - `disk` (disk.cpp): the unit disk at z = 0, intersected in object space; the normal is `to_world`'s
//!   inverse transpose applied to +z; `flip_normals` is a mirror of z folded into `to_world` (as Mitsuba).
//! - `cylinder` (cylinder.cpp): the open unit tube `x² + y² = 1`, `0 ≤ z ≤ 1`, intersected in object space
//!   (any affine map, non-uniform scale included); the normal is `∂p/∂u × ∂p/∂v`, negated by
//!   `flip_normals` and by a mirroring transform (Mitsuba's rule: the two cancel, so it faces out).
//!
//! A hit's `t` is the ray's parameter (object-space rays keep it: the direction is not renormalised), kept
//! when its f32 value lies in `[t_min, t_max]`; the nearer root first. The hit point is re-projected onto
//! the surface (Mitsuba's `compute_surface_interaction`, pbrt-v4's quadrics) in f64, so its error bound
//! (for `math::offset_ray_origin`) is a few ulps of its coordinates.

use glam::{DAffine3, DVec3};

use crate::math::{gamma, Aabb, Mat4, Ray, Vec2, Vec3};

/// Which quadric.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Sphere,
    Disk,
    Cylinder,
}

impl Kind {
    /// The Mitsuba plugin name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kind::Sphere => "sphere",
            Kind::Disk => "disk",
            Kind::Cylinder => "cylinder",
        }
    }
}

/// One analytic primitive in world space (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analytic {
    pub kind: Kind,
    to_world: DAffine3,
    to_object: DAffine3,
    /// The sphere's world centre and radius (unused by the others).
    center: DVec3,
    radius: f64,
    /// The normal is negated (module docs: `flip_normals` and the mirror rule).
    flip: bool,
}

/// The surface at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The hit re-projected onto the surface.
    pub p: Vec3,
    /// Conservative absolute error of `p` per axis.
    pub p_error: Vec3,
    /// Unit normal (geometric = shading), flipped as the module docs say.
    pub n: Vec3,
    /// Mitsuba's texture coordinates.
    pub uv: Vec2,
}

const TWO_PI: f64 = std::f64::consts::TAU;

impl Analytic {
    /// `kind` placed by `to_world` (its object space as the module docs say); `flip_normals` as the shape
    /// says. `None` when `to_world` is singular or not finite.
    #[must_use]
    pub fn new(kind: Kind, to_world: Mat4, flip_normals: bool) -> Option<Self> {
        let mut to_world = DAffine3::from_mat4(to_world.as_dmat4());
        let det = to_world.matrix3.determinant();
        if !(det.is_finite() && det != 0.0) || !to_world.translation.is_finite() {
            return None;
        }
        let flip = match kind {
            // disk.cpp: `to_world · scale(1, 1, −1)`.
            Kind::Disk => {
                if flip_normals {
                    to_world = to_world * DAffine3::from_scale(DVec3::new(1.0, 1.0, -1.0));
                }
                false
            }
            // sphere.cpp, cylinder.cpp `update()`: a transform whose polar decomposition has a negative
            // scale (a mirror: negative determinant) toggles `m_flip_normals`.
            Kind::Sphere | Kind::Cylinder => flip_normals != (det < 0.0),
        };
        let center = to_world.translation;
        let radius = to_world.matrix3.x_axis.length();
        Some(Self { kind, to_world, to_object: to_world.inverse(), center, radius, flip })
    }

    /// The world box, padded by a few ulps of its coordinates for rounding to f32.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        let (lo, hi) = match self.kind {
            Kind::Sphere => (self.center - self.radius, self.center + self.radius),
            // disk.cpp `bbox()`: per axis, the centre ± the length of the rows of the x and y columns.
            Kind::Disk => {
                let (u, v) = (self.to_world.matrix3.x_axis, self.to_world.matrix3.y_axis);
                let e = (u * u + v * v).to_array().map(f64::sqrt);
                let e = DVec3::from_array(e);
                (self.center - e, self.center + e)
            }
            Kind::Cylinder => {
                let corners = (0..8).map(|k| {
                    let c = DVec3::new(if k & 1 == 0 { -1.0 } else { 1.0 }, if k & 2 == 0 { -1.0 } else { 1.0 }, if k & 4 == 0 { 0.0 } else { 1.0 });
                    self.to_world.transform_point3(c)
                });
                corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)))
            }
        };
        let pad = 4.0 * f64::from(f32::EPSILON) * lo.abs().max(hi.abs()) + f64::from(f32::MIN_POSITIVE);
        Aabb { min: (lo - pad).as_vec3(), max: (hi + pad).as_vec3() }
    }

    /// The nearest hit of `ray` with `t ∈ [t_min, t_max]` (module docs).
    #[inline]
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let within = |t: f64| {
            let t = t as f32;
            (t >= ray.t_min && t <= ray.t_max).then_some(t)
        };
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        match self.kind {
            Kind::Sphere => {
                let (near, far) = quadratic_roots(o - self.center, d, self.radius * self.radius)?;
                within(near).or_else(|| within(far))
            }
            Kind::Disk => {
                let (o, d) = (self.to_object.transform_point3(o), self.to_object.transform_vector3(d));
                let t = -o.z / d.z;
                let (x, y) = (o.x + t * d.x, o.y + t * d.y);
                if !(t.is_finite() && x * x + y * y <= 1.0) {
                    return None;
                }
                within(t)
            }
            Kind::Cylinder => {
                let (o, d) = (self.to_object.transform_point3(o), self.to_object.transform_vector3(d));
                let (near, far) = quadratic_roots(o.with_z(0.0), d.with_z(0.0), 1.0)?;
                let on_tube = |t: f64| {
                    let z = o.z + t * d.z;
                    if (0.0..=1.0).contains(&z) { within(t) } else { None }
                };
                on_tube(near).or_else(|| on_tube(far))
            }
        }
    }

    /// The surface where `ray` hits at `t` (module docs).
    #[must_use]
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfacePoint {
        let on_ray = ray.origin.as_dvec3() + f64::from(t) * ray.dir.as_dvec3();
        let m = self.to_world.matrix3;
        let (p, local, n, error_scale) = match self.kind {
            Kind::Sphere => {
                let n = (on_ray - self.center).normalize_or(DVec3::Z);
                let p = self.center + self.radius * n;
                (p, self.to_object.transform_point3(p), n, self.center.abs() + self.radius)
            }
            Kind::Disk => {
                let local = self.to_object.transform_point3(on_ray).with_z(0.0);
                let n = (self.to_object.matrix3.transpose() * DVec3::Z).normalize();
                (self.to_world.transform_point3(local), local, n, self.translation_error(local))
            }
            Kind::Cylinder => {
                let mut local = self.to_object.transform_point3(on_ray);
                let r = local.truncate().length();
                if r > 0.0 {
                    local.x /= r;
                    local.y /= r;
                }
                let n = (m * DVec3::new(-local.y, local.x, 0.0)).cross(m * DVec3::Z).normalize_or(DVec3::Z);
                (self.to_world.transform_point3(local), local, n, self.translation_error(local))
            }
        };
        let n = if self.flip { -n } else { n };
        let p_error = (f64::from(gamma(3)) * (p.abs() + error_scale)).as_vec3();
        SurfacePoint { p: p.as_vec3(), p_error, n: n.as_vec3(), uv: object_uv(self.kind, local).as_vec2() }
    }

    /// `|to_world|·|local| + |translation|`: the size of the terms the placed point sums.
    fn translation_error(&self, local: DVec3) -> DVec3 {
        let m = self.to_world.matrix3;
        let abs = glam::DMat3::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        abs * local.abs() + self.to_world.translation.abs()
    }

    /// Mitsuba's `∂p/∂u`, `∂p/∂v` at the surface point `p` (world space), from its object-space point.
    #[must_use]
    pub fn derivatives(&self, p: Vec3) -> (Vec3, Vec3) {
        let l = self.to_object.transform_point3(p.as_dvec3());
        let m = self.to_world.matrix3;
        let (du, dv) = match self.kind {
            Kind::Sphere => {
                let rd = l.truncate().length();
                let dv = if rd == 0.0 { DVec3::X } else { DVec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd) };
                (TWO_PI * DVec3::new(-l.y, l.x, 0.0), std::f64::consts::PI * dv)
            }
            Kind::Disk => {
                let r = l.truncate().length();
                let inv = if r > 0.0 { 1.0 / r } else { 0.0 };
                let (c, s) = (l.x * inv, l.y * inv);
                (DVec3::new(c, s, 0.0), TWO_PI * r * DVec3::new(-s, c, 0.0))
            }
            Kind::Cylinder => (TWO_PI * DVec3::new(-l.y, l.x, 0.0), DVec3::Z),
        };
        ((m * du).as_vec3(), (m * dv).as_vec3())
    }

    /// The placement of the object-space shape (module docs), as f64.
    #[must_use]
    pub fn to_world(&self) -> DAffine3 {
        self.to_world
    }

    /// Whether the normal is negated (module docs: `flip_normals` and the mirror rule; a disk's
    /// `flip_normals` is in its placement instead, so this is false for disks).
    #[must_use]
    pub fn flipped(&self) -> bool {
        self.flip
    }

    /// Bytes of one primitive.
    pub const BYTES: usize = size_of::<Self>();
}

/// The roots `t₀ ≤ t₁` of `|o + t·d|² = r²` (`None` without real roots), solved from the point of the line
/// closest to the origin, `q = o + t_c·d`: `t = t_c ∓ √((r² − |q|²)/|d|²)`, which keeps the precision a
/// far origin's `|o|²` would cancel.
#[inline]
fn quadratic_roots(o: DVec3, d: DVec3, r2: f64) -> Option<(f64, f64)> {
    let dd = d.length_squared();
    if !(dd > 0.0) {
        return None;
    }
    let tc = -o.dot(d) / dd;
    let q = o + tc * d;
    let h2 = r2 - q.length_squared();
    if !(h2 >= 0.0) {
        return None;
    }
    let dt = (h2 / dd).sqrt();
    Some((tc - dt, tc + dt))
}

/// Mitsuba's texture coordinates at the object-space point `l`: sphere `(φ/2π, θ/π)` with `φ =
/// atan2(l.y, l.x)` in [0, 2π) and `θ` Mitsuba's `unit_angle_z` of the point as it is (not renormalised:
/// under a non-uniform scale it is not a unit vector, and Mitsuba's answer is this formula's); disk `(r,
/// φ/2π)`; cylinder `(φ/2π, z)`. The one rule of the three shapes' uv: the intersector's surface and the
/// area lights on these shapes (`light::shapes`) both read it.
#[must_use]
pub fn object_uv(kind: Kind, l: DVec3) -> glam::DVec2 {
    let mut phi = l.y.atan2(l.x);
    if phi < 0.0 {
        phi += TWO_PI;
    }
    match kind {
        Kind::Sphere => glam::DVec2::new(phi / TWO_PI, unit_angle_z(l) / std::f64::consts::PI),
        Kind::Disk => glam::DVec2::new(l.truncate().length(), phi / TWO_PI),
        Kind::Cylinder => glam::DVec2::new(phi / TWO_PI, l.z),
    }
}

/// Dr.Jit's `unit_angle_z` (Mitsuba's `dir_to_sph`, include/mitsuba/core/vector.h): the angle between a unit vector and +z,
/// `2·asin(|v − ẑ|/2)` (or `π − 2·asin(|v + ẑ|/2)` below the equator), accurate where `acos(v.z)` is not.
fn unit_angle_z(v: DVec3) -> f64 {
    let half_chord = |z: f64| (0.5 * (v.x * v.x + v.y * v.y + z * z).sqrt()).min(1.0).asin();
    if v.z >= 0.0 { 2.0 * half_chord(v.z - 1.0) } else { std::f64::consts::PI - 2.0 * half_chord(v.z + 1.0) }
}

#[cfg(test)]
#[path = "analytic_tests.rs"]
mod tests;
