//! Far rays re-based near the world origin, so that a sky-sized shape does not make every ray slow.
//!
//! A ray that starts far from the world origin, e.g. one reflected by a mirror sphere of radius 4.3e9 around
//! a unit-sized scene, has origin coordinates rounded to `|o|·2⁻²⁴` (256 units at 4.3e9). Both backends
//! compute box and triangle distances from that origin, so near the scene their `t` is only known to
//! about that much: every box within that distance of the ray passes the (conservative) slab test, and the
//! ray tests every triangle of the scene. Measured on `cornell-caustics` inside such a mirror sphere: the
//! rays reflected by the sphere cost ~1 ms each (the scene's 130k triangles), 3,181 rays in 3.5 s.
//!
//! The ray's line is known exactly (its rounded origin and direction), so its part that passes the scene
//! can be traced from other points of the same line, computed in f64 and rounded near the scene: the
//! point closest to the world origin is `o′ = o + t_c·d` with `t_c = −o·d / d·d`, where coordinates are
//! small again (the loader keeps every shape within 2¹⁴ of its size from the origin, `scene::precision`).
//! Every backend needs `t ≥ 0` from a ray's origin (Embree asserts it), so the part before `o′` is traced
//! forward from origins that approach `o′` geometrically: the far ray is traced in segments
//! `[t_min, t_c − h]` from `o` (`h = |o|/(2|d|)`), then `[t_c − s, t_c − s/2]` from the point at `t_c − s`
//! for `s = h, h/2, h/4, …` while `s·|d|` exceeds the far distance below, then the rest from the last such
//! point. Each segment's origin is about as far from `o′` as the segment is long, so its rounding stays
//! below the segment's length times 2⁻²⁴ and no segment's end passes the scene's detail with a large
//! error; consecutive segments overlap by a few ulps so that rounding at a seam cannot lose a hit, and the
//! first segment with a hit has the closest one. A hit's `t` is the segment's plus the segment's start.
//! A far ray of a sky-sized sphere (|o| ≈ 4e9) is about 20 segments; those that miss the soup's box (padded
//! by 10⁻³ of its extent, the line clipped to it in f64) are not traced. When far geometry surrounds the
//! scene, `accel::shell` wraps the near and the far triangles each in their own `Rebased`, so the near
//! part's box is the scene's and a far ray costs one or two near queries.
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
    /// The box of the soup, padded by 10⁻³ of its largest extent: segments of a far ray outside it are
    /// not traced.
    bounds: (glam::DVec3, glam::DVec3),
}

/// The median of `sizes` (`None` for none).
fn median(mut sizes: Vec<f32>) -> Option<f32> {
    if sizes.is_empty() {
        return None;
    }
    let mid = sizes.len() / 2;
    let (_, median, _) = sizes.select_nth_unstable_by(mid, f32::total_cmp);
    Some(*median)
}

/// The box and the detail (median triangle diagonal) of an instanced scene for [`Rebased::with_detail`]:
/// the box holds `flat` and the instances' world boxes; the diagonals are those of `flat` and of every
/// prototype triangle, scaled by its first instance's mean axis scale (module docs of `accel`).
#[must_use]
pub fn instanced_detail(g: &super::Geometry, flat: &[[u32; 3]], instance_bounds: &[Aabb]) -> (Aabb, Option<f32>) {
    let diagonal = |t: &[u32; 3]| Aabb::from_points(&t.map(|i| g.positions[i as usize]));
    let mut b = instance_bounds.iter().fold(Aabb::EMPTY, |b, &i| b.union(i));
    let mut sizes: Vec<f32> = flat
        .iter()
        .map(|t| {
            let tb = diagonal(t);
            b = b.union(tb);
            tb.extent().length()
        })
        .collect();
    for p in 0..g.prototypes.len() {
        let Some(inst) = g.instances.iter().find(|i| i.prototype as usize == p) else { continue };
        let m = inst.to_world.matrix3;
        let scale = (m.x_axis.length() + m.y_axis.length() + m.z_axis.length()) / 3.0;
        sizes.extend(g.prototype_indices(p).iter().map(|t| scale * diagonal(t).extent().length()));
    }
    (b, median(sizes))
}

/// One segment of a far ray: the ray to trace (`t ≥ 0` from its origin) and the `t` of its origin on
/// the original ray.
#[derive(Clone, Copy, Debug)]
struct Segment {
    ray: Ray,
    t_start: f32,
}

impl Rebased {
    /// Wraps `inner`, built over the same soup.
    #[must_use]
    pub fn new(inner: Box<dyn Accel>, positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let mut b = Aabb::EMPTY;
        let sizes: Vec<f32> = indices
            .iter()
            .map(|t| {
                let tb = Aabb::from_points(&t.map(|i| positions[i as usize]));
                b = b.union(tb);
                tb.extent().length()
            })
            .collect();
        Self::with_detail(inner, b, median(sizes))
    }

    /// Wraps `inner`, whose geometry lies in `bounds` with a median triangle diagonal `detail` (`None`:
    /// no triangles, no ray is re-based).
    #[must_use]
    pub fn with_detail(inner: Box<dyn Accel>, b: Aabb, detail: Option<f32>) -> Self {
        let far = match detail {
            None => f32::INFINITY,
            Some(median) => {
                let far = FAR_PER_DETAIL * median;
                if far > 0.0 { far } else { f32::INFINITY }
            }
        };
        let pad = glam::DVec3::splat(1e-3 * f64::from(b.extent().max_element()) + 1e-30);
        Self {
            inner,
            far,
            bounds: (b.min.as_dvec3() - pad, b.max.as_dvec3() + pad),
        }
    }

    /// The part `[t0, t1]` of the line `o + t·d` (f64, exact for f32 input up to rounding far below the
    /// padding) inside the padded box of the soup, or `None` if the line misses it.
    fn line_in_bounds(&self, o: glam::DVec3, d: glam::DVec3) -> Option<(f64, f64)> {
        let (lo, hi) = self.bounds;
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < lo[a] || o[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1).then_some((t0, t1))
    }

    /// Whether `ray` is traced as it is: its origin is not far. One multiply-add chain and a compare,
    /// inlined into every query (a call to [`Rebased::split`] for every ray was 2 % of a `pt` sample).
    #[inline(always)]
    fn is_near(&self, ray: &Ray) -> bool {
        !(ray.origin.length_squared() > self.far * self.far)
    }

    /// The segments of `ray` in order along it if it is far (module docs), `None` if it is traced as it is.
    /// Made lazily: a hit in the first segments ends the search without computing the others.
    #[cold]
    fn split(&self, ray: &Ray) -> Option<Segments> {
        if self.is_near(ray) {
            return None;
        }
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let dd = d.length_squared();
        if !(dd > 0.0 && dd.is_finite()) {
            return None;
        }
        let t_c = -o.dot(d) / dd;
        let (t_min, t_max) = (f64::from(ray.t_min), f64::from(ray.t_max));
        if !(t_c > t_min) {
            // Moving away from the origin: the whole ray stays far from the scene's detail.
            return None;
        }
        let d_len = dd.sqrt();
        // A line that misses the soup's box has no segment to trace (`clip` empty).
        let clip = self.line_in_bounds(o, d).unwrap_or((f64::INFINITY, f64::NEG_INFINITY));
        Some(Segments {
            clip,
            o,
            d,
            dir: ray.dir,
            t_min,
            t_max,
            t_c,
            // Overlap at a seam: a few ulps (of f32, the precision of the backends' t) of the largest t.
            seam: 4.0 * f64::from(f32::EPSILON) * (t_c.abs() + o.length() / d_len),
            s: 0.5 * o.length() / d_len,
            near: f64::from(self.far) / d_len,
            stage: Stage::First,
        })
    }
}

/// Where [`Segments`] is: `[0, t_c − s]`, then the halving pieces `[t_c − s, t_c − s/2]` while `s` is
/// above the near distance, then `[t_c − s, ∞)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    First,
    Halving,
    Last,
    Done,
}

/// The segments of one far ray, approaching the closest point to the world origin `t_c` in pieces of
/// halving length (each traced from an f64 origin on the ray, so its rounding shrinks with its distance).
struct Segments {
    /// The part of the line inside the soup's padded box: pieces outside it are skipped.
    clip: (f64, f64),
    o: glam::DVec3,
    d: glam::DVec3,
    dir: Vec3,
    t_min: f64,
    t_max: f64,
    t_c: f64,
    seam: f64,
    s: f64,
    near: f64,
    stage: Stage,
}

impl Segments {
    /// `[start, end]` of the original ray, clipped to `[t_min, t_max]`, traced from the point at `start`;
    /// `None` when the clip leaves nothing.
    fn piece(&self, start: f64, end: f64) -> Option<Segment> {
        let (lo, hi) = (start.max(self.t_min), (end + self.seam).min(self.t_max));
        (lo < hi && lo <= self.clip.1 && hi >= self.clip.0).then(|| {
            let origin = (self.o + start * self.d).as_vec3();
            Segment { ray: Ray::segment(origin, self.dir, (lo - start) as f32, (hi - start) as f32), t_start: start as f32 }
        })
    }
}

impl Iterator for Segments {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        loop {
            let (t_c, s) = (self.t_c, self.s);
            let piece = match self.stage {
                Stage::First => {
                    self.stage = Stage::Halving;
                    self.piece(0.0, t_c - s)
                }
                Stage::Halving if s > self.near && t_c - s < self.t_max => {
                    self.s *= 0.5;
                    self.piece(t_c - s, t_c - 0.5 * s)
                }
                Stage::Halving => {
                    self.stage = Stage::Last;
                    continue;
                }
                Stage::Last => {
                    self.stage = Stage::Done;
                    if t_c - s < self.t_max {
                        self.piece(t_c - s, f64::INFINITY)
                    } else {
                        None
                    }
                }
                Stage::Done => return None,
            };
            if piece.is_some() {
                return piece;
            }
        }
    }
}

impl Accel for Rebased {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.is_near(ray) {
            return self.inner.intersect(ray);
        }
        let Some(segments) = self.split(ray) else {
            return self.inner.intersect(ray);
        };
        segments.into_iter().find_map(|seg| self.inner.intersect(&seg.ray).map(|hit| Hit { t: hit.t + seg.t_start, ..hit }))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.is_near(ray) {
            return self.inner.occluded(ray);
        }
        let Some(segments) = self.split(ray) else {
            return self.inner.occluded(ray);
        };
        segments.into_iter().any(|seg| self.inner.occluded(&seg.ray))
    }

    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// The backend's batch where every ray is near (the common case), else one ray at a time.
    fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        super::batch_if_all(rays, out, |ray| self.is_near(ray), |r, o| self.inner.intersect_many(r, o), |ray| self.intersect(ray));
    }

    fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        super::batch_if_all(rays, out, |ray| self.is_near(ray), |r, o| self.inner.occluded_many(r, o), |ray| self.occluded(ray));
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
        // A sky-sized sphere: every segment starts at t ≥ 0 from its origin (Embree asserts it), the
        // segments cover the ray in order without a gap, and the far rays find the unit sphere.
        let mut sky = shapes::sphere(Vec3::ZERO, 1.0, 16, 32);
        sky.append(&shapes::sphere(Vec3::ZERO, 4.3e9, 4, 8));
        let rebased = Rebased::new(Box::new(BruteForce::new(&sky.positions, &sky.indices)), &sky.positions, &sky.indices);
        for k in 0..50 {
            let a = k as f32 * 0.37;
            let origin = Vec3::new(a.cos(), a.sin(), 0.3) * 2.0e9; // inside the coarse 4.3e9 sphere's facets
            let target = Vec3::new(0.2 * a.sin(), 0.1, 0.2 * a.cos());
            let ray = Ray::segment(origin, target - origin, 1e-3, f32::INFINITY);
            let segments: Vec<Segment> = rebased.split(&ray).expect("far").collect();
            assert!(segments.len() > 10 && segments.len() < 40, "{}", segments.len());
            let mut covered = ray.t_min;
            for seg in &segments {
                assert!(seg.ray.t_min >= 0.0 && seg.ray.t_max > seg.ray.t_min, "ray {k}: {seg:?}");
                assert!(seg.t_start + seg.ray.t_min <= covered * (1.0 + 1e-6), "ray {k}: gap before {seg:?} (covered to {covered})");
                covered = covered.max(seg.t_start + seg.ray.t_max);
            }
            assert_eq!(covered, f32::INFINITY);
            let hit = rebased.intersect(&ray).expect("the unit sphere");
            assert!(hit.prim < inner && (ray.at(hit.t) - target).length() < 1.5, "ray {k}: {hit:?}");
            assert!(rebased.occluded(&ray));
        }
        let near = Ray::new(Vec3::new(0.0, 0.0, 0.5), Vec3::X);
        assert!(rebased.split(&near).is_none());
        assert_eq!(rebased.intersect(&near), oracle.intersect(&near));
    }
}
