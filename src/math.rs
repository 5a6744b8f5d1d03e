//! Geometry primitives shared by every module: rays, boxes, orthonormal frames, and the one
//! ray-origin offset rule that both intersection backends and the integrator use.
//!
//! Concrete `f32` types from glam throughout (no generic `Float`), as glam itself decided.

pub use glam::{Mat3, Mat4, Vec2, Vec3, Vec3A, Vec4};

/// A ray `origin + t·dir` valid for `t ∈ [t_min, t_max]` (inclusive, Embree's convention).
/// `dir` need not be normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    /// An unbounded ray (`t ∈ [0, ∞)`).
    #[must_use]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir, t_min: 0.0, t_max: f32::INFINITY }
    }

    /// A ray restricted to `t ∈ [t_min, t_max]`.
    #[must_use]
    pub fn segment(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Self { origin, dir, t_min, t_max }
    }

    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// Axis-aligned bounding box. The empty box has `min = +∞`, `max = −∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    #[must_use]
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    #[must_use]
    pub fn grow(self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    #[must_use]
    pub fn union(self, o: Aabb) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    #[must_use]
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    #[must_use]
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area (0 for the empty box).
    #[must_use]
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Index (0, 1, 2) of the longest axis.
    #[must_use]
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    #[must_use]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Whether the ray's segment `[t_min, t_max]` may touch the box: a slab test on the box grown by
    /// 1e-4 of its extent (plus a 1e-30 floor), so that float rounding never rejects a ray that
    /// touches a surface inside. Conservative: `false` means the ray certainly misses the box.
    #[must_use]
    pub fn may_intersect(&self, ray: &Ray) -> bool {
        if self.is_empty() {
            return false;
        }
        let pad = Vec3::splat(1e-4 * self.extent().max_element() + 1e-30);
        let (lo, hi) = (self.min - pad, self.max + pad);
        let mut t0 = ray.t_min;
        let mut t1 = ray.t_max;
        for a in 0..3 {
            let (o, d) = (ray.origin[a], ray.dir[a]);
            if d == 0.0 {
                if o < lo[a] || o > hi[a] {
                    return false;
                }
                continue;
            }
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo[a] - o) * inv, (hi[a] - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            // Widen by a few ulps: (lo − o)·inv is rounded.
            t0 = t0.max(ta - 4.0 * f32::EPSILON * ta.abs());
            t1 = t1.min(tb + 4.0 * f32::EPSILON * tb.abs());
            if t0 > t1 {
                return false;
            }
        }
        true
    }

    /// Centre and radius of a sphere enclosing the box (the scene's bounding sphere).
    #[must_use]
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        if self.is_empty() {
            (Vec3::ZERO, 0.0)
        } else {
            (self.center(), 0.5 * self.extent().length())
        }
    }
}

/// An orthonormal frame (s, t, n); `to_local` / `to_world` name the direction of the change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Frame around a unit normal, branchless (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    #[must_use]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    #[must_use]
    pub fn to_local(&self, v_world: Vec3) -> Vec3 {
        Vec3::new(v_world.dot(self.s), v_world.dot(self.t), v_world.dot(self.n))
    }

    #[must_use]
    pub fn to_world(&self, v_local: Vec3) -> Vec3 {
        v_local.x * self.s + v_local.y * self.t + v_local.z * self.n
    }
}

/// `γ(n) = n·ε / (1 − n·ε)` with ε = 2⁻²⁴, the bound on relative rounding error of n f32 operations
/// (Higham; pbrt-v4 §6.8.1).
#[must_use]
pub const fn gamma(n: u32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// Conservative absolute error of a point reconstructed from barycentrics,
/// `p = b0·p0 + b1·p1 + b2·p2`: `γ(7)·(|b0·p0| + |b1·p1| + |b2·p2|)` per axis (pbrt-v4 eq. 6.31).
/// Both backends return barycentrics and the hit point is always rebuilt this way, so one bound
/// serves both.
#[inline]
#[must_use]
pub fn barycentric_point_error(b: [f32; 3], p: [Vec3; 3]) -> Vec3 {
    gamma(7) * ((b[0] * p[0]).abs() + (b[1] * p[1]).abs() + (b[2] * p[2]).abs())
}

/// The one ray-origin offset rule, used for every spawned ray by both backends and the integrator.
///
/// Moves `p` along the geometric normal `ng`, to the side `dir` points into, by the projection of its
/// error box `p_error` onto the normal, then one more ULP outward per axis (pbrt-v4 `OffsetRayOrigin`,
/// §6.8.6). The offset scales with the magnitude of the triangle's coordinates, so scenes at 1e-3 and
/// 1e4 units both work without a global epsilon.
#[inline(always)]
#[must_use]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    let d = ng.abs().dot(p_error);
    let mut offset = d * ng;
    if dir.dot(ng) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_float_down(po[i]);
        }
    }
    po
}

/// The near end of a spawned ray's interval: `4·max(p_error) / |dir|`.
///
/// The origin offset keeps the origin on the right side of the surface's plane, but the triangle test's
/// own rounding error in `t` grows with the size of the triangle's coordinates, so a ray leaving a large
/// triangle can still report it at `t ≈ 0` (seen on a 20-unit floor). Hits closer than a few times the
/// hit point's error bound are ignored — the same scale-aware bound, so nothing global is assumed.
#[inline]
#[must_use]
pub fn spawn_t_min(p_error: Vec3, dir: Vec3) -> f32 {
    let len = dir.length();
    if len > 0.0 {
        4.0 * p_error.max_element() / len
    } else {
        0.0
    }
}

/// The linear part of an affine transform and its determinant, if the transform can place geometry: not
/// singular (the determinant against the product of the column lengths, which is 1 for a rotation, above
/// 10⁻¹²) and not overflowing f32. The message says which.
pub fn invertible_linear_part(m: Mat4) -> Result<(Mat3, f32), String> {
    let linear = Mat3::from_mat4(m);
    let det = linear.determinant();
    let scale = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
    if det.is_infinite() || !scale.is_finite() {
        let [a, b, c] = [linear.x_axis, linear.y_axis, linear.z_axis].map(Vec3::length);
        return Err(format!("the transform's scale overflows f32 (determinant {det}): its columns are {a:e}, {b:e} and {c:e} long"));
    }
    if !det.is_finite() || det == 0.0 || det.abs() <= 1e-12 * scale {
        return Err(format!("the transform is singular (determinant {det}); a zero scale flattens the shape"));
    }
    Ok((linear, det))
}

/// `v / |v|` for any finite non-zero `v`, even where `|v|²` over- or underflows f32 (`v` is first divided
/// by its largest component); `None` for zero or non-finite `v`.
#[must_use]
pub fn normalize_any(v: Vec3) -> Option<Vec3> {
    length_and_direction(v).map(|(_, d)| d)
}

/// `(|v|, v/|v|)` for any finite non-zero `v`: directly when `|v|²` is a normal f32 (the common case,
/// bit-identical to glam's `length`/`normalize`), else after dividing `v` by its largest component, so that
/// a vector of length 10⁻²⁴ (the cross product of a 10⁻¹²-sized triangle's edges, whose square is below
/// f32's range) keeps its exact direction and length. `None` for zero or non-finite `v`.
#[must_use]
pub fn length_and_direction(v: Vec3) -> Option<(f32, Vec3)> {
    let l2 = v.length_squared();
    if (f32::MIN_POSITIVE..f32::MAX).contains(&l2) {
        let l = l2.sqrt();
        return Some((l, v * l.recip()));
    }
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let (l, d) = ((v / m).length(), (v / m).normalize());
    let l = l * m;
    l.is_finite().then_some((l, d))
}

/// A triangle's unit geometric normal `(p₁−p₀)×(p₂−p₀)/|…|` and its area `|…|/2`, at any scale f32 holds
/// ([`length_and_direction`]); `None` for a zero-area (or non-finite) triangle. The one rule for both,
/// used by the interaction, the area lights and the vertex normals: a light of side 10⁻¹² was dropped as
/// zero-area, and its hit points got the ray's direction as normal, when `|…|²` underflowed.
#[must_use]
pub fn triangle_normal_area(p: [Vec3; 3]) -> Option<(Vec3, f32)> {
    length_and_direction((p[1] - p[0]).cross(p[2] - p[0])).map(|(l, n)| (n, 0.5 * l))
}

/// Smallest f32 greater than `v` (∞ stays ∞; −0 is treated as +0).
#[inline(always)]
#[must_use]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// Largest f32 smaller than `v`.
#[inline(always)]
#[must_use]
pub fn next_float_down(v: f32) -> f32 {
    -next_float_up(-v)
}

/// A pixel rectangle `[x0, x1) × [y0, y1)` in film coordinates (row 0 = top): the one type of crop
/// windows, tiles and (named, in `report::metrics::Region`) error regions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

/// `x0,y0,x1,y1`: as `--crop` takes it, and as every message shows a window.
impl std::fmt::Display for Rect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

impl Rect {
    #[must_use]
    pub fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Self {
        Self { x0, y0, x1, y1 }
    }

    #[must_use]
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    #[must_use]
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Number of pixels.
    #[must_use]
    pub fn area(&self) -> u64 {
        u64::from(self.width()) * u64::from(self.height())
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    #[must_use]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    /// `true` if `other` lies entirely inside `self`.
    #[must_use]
    pub fn contains_rect(&self, other: &Rect) -> bool {
        other.x0 >= self.x0 && other.y0 >= self.y0 && other.x1 <= self.x1 && other.y1 <= self.y1
    }

    /// Row-major index of `(x, y)` inside the rectangle, `None` outside.
    #[must_use]
    #[inline]
    pub(crate) fn index(&self, x: u32, y: u32) -> Option<usize> {
        self.contains(x, y)
            .then(|| (y - self.y0) as usize * self.width() as usize + (x - self.x0) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle's normal and area at the ends of f32's range: scaled by 10⁻¹⁷ (|e₁×e₂|² ≈ 10⁻⁶⁸
    /// underflows) and by 10¹⁷ (≈ 10⁶⁸ overflows) they are the unit triangle's, exactly scaled; at unit
    /// size bit-identical to glam's `length`/`normalize`; a zero-area triangle has none.
    #[test]
    fn triangle_normal_and_area_at_any_scale() {
        let unit = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.5)];
        let (n1, a1) = triangle_normal_area(unit).unwrap();
        let c = (unit[1] - unit[0]).cross(unit[2] - unit[0]);
        assert_eq!((n1, a1), (c.normalize(), 0.5 * c.length()));
        for s in [1e-17f32, 1e-12, 1e12, 1e17] {
            let (n, a) = triangle_normal_area(unit.map(|p| p * s)).unwrap_or_else(|| panic!("scale {s}: no normal"));
            assert!((n - n1).abs().max_element() < 1e-6, "scale {s}: normal {n} vs {n1}");
            assert!((f64::from(a) / (f64::from(a1) * f64::from(s) * f64::from(s)) - 1.0).abs() < 1e-5, "scale {s}: area {a}");
        }
        assert!(triangle_normal_area([Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]).is_none());
        assert!(triangle_normal_area([Vec3::ZERO, Vec3::X, Vec3::splat(f32::NAN)]).is_none());
        assert_eq!(normalize_any(Vec3::new(3e-30, 4e-30, 0.0)), Some(Vec3::new(0.6, 0.8, 0.0)));
    }

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.4, 0.866).normalize(), Vec3::new(1e-7, 0.0, -1.0).normalize()] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.2, -0.7, 0.5);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn offset_moves_to_the_side_of_dir_at_every_scale() {
        for scale in [1e-3f32, 1.0, 1e4, 1e6] {
            let tri = [Vec3::new(0.0, 0.7, -1.0), Vec3::new(1.0, 0.7, 0.0), Vec3::new(0.0, 0.7, 1.0)].map(|p| p * scale);
            let b = [0.2, 0.5, 0.3];
            let p = b[0] * tri[0] + b[1] * tri[1] + b[2] * tri[2];
            let err = barycentric_point_error(b, tri);
            let ng = Vec3::Y;
            let up = offset_ray_origin(p, err, ng, Vec3::Y);
            let down = offset_ray_origin(p, err, ng, -Vec3::Y);
            assert!(up.y > tri[0].y && down.y < tri[0].y, "scale {scale}: {up} {down}");
            // Small relative to the scene's scale.
            assert!((up - p).length() < 1e-5 * scale, "scale {scale}");
        }
    }

    /// `may_intersect` never rejects a ray that hits a triangle inside the box (checked with the
    /// watertight triangle test on random rays, many grazing the box's faces), and rejects rays that
    /// point away from it.
    #[test]
    fn may_intersect_is_conservative() {
        use crate::accel::triangle::{intersect_triangle, RayPrecomp};
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for scale in [1e-3f32, 1.0, 1e4] {
            for _ in 0..20_000 {
                let p = [0; 3].map(|_| Vec3::new(rnd(), rnd(), rnd()) * scale);
                let b = Aabb::from_points(&p);
                let origin = (Vec3::new(rnd(), rnd(), rnd()) * 4.0 - 1.5) * scale;
                let target = p[0] + (p[1] - p[0]) * rnd() * 0.999 + (p[2] - p[0]) * rnd() * 0.001;
                let ray = Ray::new(origin, target - origin);
                if intersect_triangle(&RayPrecomp::new(&ray), 0, p).is_some() {
                    hits += 1;
                    assert!(b.may_intersect(&ray), "scale {scale}: {ray:?} hits a triangle in {b:?}");
                }
                let away = Ray::new(b.max + Vec3::ONE * scale, Vec3::ONE);
                assert!(!b.may_intersect(&away));
            }
        }
        assert!(hits > 30_000, "{hits}");
        assert!(!Aabb::EMPTY.may_intersect(&Ray::new(Vec3::ZERO, Vec3::X)));
    }
}
