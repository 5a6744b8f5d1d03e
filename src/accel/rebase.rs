//! Far rays re-based near the world origin, so that a sky-sized shape does not make every ray slow.
//!
//! A ray that starts far from the world origin, e.g. one reflected by a mirror sphere of radius 4.3e9 around
//! a unit-sized scene, has origin coordinates rounded to `|o|·2⁻²⁴` (256 units at 4.3e9). Both backends
//! compute box and triangle distances from that origin, so near the scene their `t` is only known to
//! about that much: every box within that distance of the ray passes the (conservative) slab test, and the
//! ray tests every triangle of the scene. Measured on `cornell-caustics` inside such a mirror sphere: the
//! rays reflected by the sphere cost ~1 ms each (the scene's 130k triangles), 3,181 rays in 3.5 s.
//!
//! The ray's line is itself only known to that precision (its origin was rounded), so nothing is lost by
//! tracing the part of it that passes the scene from another point of the same line: the point closest
//! to the world origin, `o′ = o + t_c·d` with `t_c = −o·d / d·d`, where coordinates are small again (the
//! loader keeps every shape within 2¹⁴ of its size from the origin, `scene::precision`). A far ray is
//! traced in two parts: from `o` up to `t_c − h` (`h = |o|/(2|d|)`, so that part stays at least `|o|/2`
//! from the origin), then from `o′` over the rest, the two overlapping slightly so that rounding at the
//! seam cannot lose a hit; hits of the second part have `t′ + t_c`.
//!
//! "Far" is relative to the scene's detail: a ray is re-based when its origin's rounding exceeds 1/64 of
//! the median triangle size (`|o| > 2¹⁸·median diagonal`), which no ray of a scene without far geometry
//! reaches, so ordinary scenes are traced exactly as before.

use super::{Accel, Hit};
use crate::math::{Aabb, Ray, Vec3};

/// Rays whose origin lies farther than this many median triangle diagonals from the world origin are
/// re-based: 2¹⁸, i.e. where the origin's rounding `|o|·2⁻²⁴` passes 1/64 of a typical triangle.
const FAR_PER_DETAIL: f32 = 262_144.0;

/// A backend that re-bases far rays (module docs).
pub struct Rebased {
    inner: Box<dyn Accel>,
    /// Origins with `|o| > far` are re-based (`∞`: never).
    far: f32,
}

/// The two parts of a far ray.
struct Parts {
    /// `[t_min, a_end]` from the original origin, if not empty.
    a: Option<Ray>,
    /// The rest from `o′`, and `t_c` to add to its hits' `t`.
    b: Option<(Ray, f32)>,
}

impl Rebased {
    /// Wraps `inner`, built over the same soup.
    #[must_use]
    pub fn new(inner: Box<dyn Accel>, positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let mut sizes: Vec<f32> = indices
            .iter()
            .map(|t| Aabb::from_points(&t.map(|i| positions[i as usize])).extent().length())
            .collect();
        let far = if sizes.is_empty() {
            f32::INFINITY
        } else {
            let mid = sizes.len() / 2;
            let (_, median, _) = sizes.select_nth_unstable_by(mid, f32::total_cmp);
            let far = FAR_PER_DETAIL * *median;
            if far > 0.0 { far } else { f32::INFINITY }
        };
        Self { inner, far }
    }

    /// The parts of `ray` if it is far, `None` if it is traced as it is.
    fn split(&self, ray: &Ray) -> Option<Parts> {
        // One multiply-add chain and a compare for every ordinary ray.
        if !(ray.origin.length_squared() > self.far * self.far) {
            return None;
        }
        let o_len = ray.origin.length();
        let dd = ray.dir.length_squared();
        if !(dd > 0.0 && dd.is_finite()) {
            return None;
        }
        let t_c = -ray.origin.dot(ray.dir) / dd;
        if !(t_c > ray.t_min) {
            // Moving away from the origin: the whole ray stays far from the scene's detail.
            return None;
        }
        let h = 0.5 * o_len / dd.sqrt();
        // Overlap at the seam: a few ulps of the larger of t_c and h.
        let seam = 4.0 * f32::EPSILON * (t_c.abs() + h);
        let t_split = t_c - h;
        let a = (t_split + seam > ray.t_min).then(|| Ray::segment(ray.origin, ray.dir, ray.t_min, (t_split + seam).min(ray.t_max)));
        let b_start = (t_split - seam).max(ray.t_min);
        let b = (b_start < ray.t_max).then(|| {
            let origin = ray.origin + t_c * ray.dir;
            (Ray::segment(origin, ray.dir, b_start - t_c, ray.t_max - t_c), t_c)
        });
        Some(Parts { a, b })
    }
}

impl Accel for Rebased {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let Some(parts) = self.split(ray) else {
            return self.inner.intersect(ray);
        };
        if let Some(hit) = parts.a.and_then(|a| self.inner.intersect(&a)) {
            return Some(hit);
        }
        let (b, t_c) = parts.b?;
        self.inner.intersect(&b).map(|hit| Hit { t: hit.t + t_c, ..hit })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let Some(parts) = self.split(ray) else {
            return self.inner.occluded(ray);
        };
        parts.a.is_some_and(|a| self.inner.occluded(&a)) || parts.b.is_some_and(|(b, _)| self.inner.occluded(&b))
    }

    fn name(&self) -> &'static str {
        self.inner.name()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::mesh::shapes;

    /// A unit sphere inside a sphere of radius 1e7: far rays, re-based, hit the unit sphere where the
    /// oracle does, and near rays are not re-based.
    #[test]
    fn rebased_rays_find_the_oracles_hits() {
        let mut mesh = shapes::sphere(Vec3::ZERO, 1.0, 16, 32);
        let inner = mesh.triangle_count() as u32;
        mesh.append(&shapes::sphere(Vec3::new(0.2, 0.1, 0.0), 1e7, 4, 8));
        let brute = || Box::new(BruteForce::new(&mesh.positions, &mesh.indices)) as Box<dyn Accel>;
        let rebased = Rebased::new(brute(), &mesh.positions, &mesh.indices);
        let oracle = brute();
        assert!(rebased.far > 1e4 && rebased.far < 3e5, "{}", rebased.far);
        let mut rebased_count = 0;
        for k in 0..200 {
            let a = k as f32 * 0.61;
            let target = Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.1 * (k % 7) as f32 - 0.3);
            // 3e5 from the origin: far for this scene (2¹⁸ median diagonals ≈ 7e4), yet near enough for
            // the oracle, traced as it is, to be right to 0.02 units.
            let origin = Vec3::new(a.sin(), a.cos(), 0.5) * 3.0e5;
            let ray = Ray::segment(origin, target - origin, 1e-3, f32::INFINITY);
            rebased_count += usize::from(rebased.split(&ray).is_some());
            let (h, o) = (rebased.intersect(&ray).unwrap(), oracle.intersect(&ray).unwrap());
            assert!(h.prim < inner && o.prim < inner, "ray {k}: {h:?} {o:?}");
            assert!((h.t - o.t).abs() <= 1e-6, "ray {k}: t {} vs {}", h.t, o.t);
            assert!(rebased.occluded(&ray));
            let short = Ray::segment(origin, target - origin, 1e-3, 0.3);
            assert!(!rebased.occluded(&short) && rebased.intersect(&short).is_none());
        }
        assert_eq!(rebased_count, 200);
        let near = Ray::new(Vec3::new(0.0, 0.0, 0.5), Vec3::X);
        assert!(rebased.split(&near).is_none());
        assert_eq!(rebased.intersect(&near), oracle.intersect(&near));
    }
}
