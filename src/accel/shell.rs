//! Far geometry around the scene (a sky-sized sphere) in its own backend, skipped by rays that cannot
//! reach it.
//!
//! A shape that surrounds the scene at a distance, e.g. a mirror sphere of radius 4.3e9 around a unit-sized
//! scene, is small triangles far away, yet the boxes of the groups of them that a hierarchy builds (an
//! octant of the sphere is the box from the centre to the surface) contain the scene: every ray inside
//! the scene enters them and tests their children (measured on `cornell-caustics` in such a sphere: 8 BVH
//! nodes per ray instead of 2). No split of the triangles' references helps, since the triangles are
//! small; what the boxes miss is that the middle of the sphere is empty.
//!
//! So [`split`] looks for an empty ball: around a centre `c` inside the scene's detail (per axis, the
//! median centroid of the smaller half of the triangles), every triangle gets a lower bound of its
//! distance from `c` (the larger of the distances to its box and to its plane), and if some triangles'
//! bounds are at least [`MIN_RATIO`] times the distance from `c` of every vertex of the others, they are
//! *far* and `r` is their least bound: no far triangle comes closer to `c` than `r`. The near and far triangles get a backend each, and a
//! query whose segment lies within `r/2` of `c` (origin and both ends of `[t_min, t_max]` within `r/4`
//! of it, a bound that rounding cannot break) does not ask the far one: the far triangles are beyond `r`,
//! and the triangle test's error in `t` is a few ulps of the vertex depths, far below `r/2`. Closest hits
//! ask the near backend first, then the far one only up to the near hit; a tie in `t` goes to the lower
//! triangle index, as in the oracle. Scenes without such a gap are built as one backend, as before.
//!
//! Each part is re-based on its own (`rebase`, thresholds from its own triangles): the far part's triangles
//! are sky-sized, so a ray the sky reflects is traced against them in one query, and only the near part
//! traces it in segments — those that pass the near triangles' box. Measured on `scripts/bench-sky`
//! (ratio of Mrays/s with the sky to without, interleaved): 0.27× → 0.65× (Embree), 0.19× → 0.61× (BVH),
//! with the BVH's per-child depth slack (`bvh::traverse`).

use rayon::prelude::*;

use super::{Accel, Hit};
use crate::math::{Aabb, Ray, Vec3};

/// The least ratio between the far triangles' distance from the centre and the farthest reach of the near
/// ones: 256.
const MIN_RATIO: f64 = 256.0;

/// A soup split into near and far triangles ([`split`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FarSplit {
    /// Indices (ascending) of the near triangles in the soup.
    pub near: Vec<u32>,
    /// Indices (ascending) of the far triangles in the soup.
    pub far: Vec<u32>,
    /// The centre of the empty ball.
    pub centre: Vec3,
    /// No far triangle comes closer to `centre` than this.
    pub radius: f32,
    /// The box of the near triangles.
    pub near_bounds: Aabb,
}

/// Per octave of the triangles' distance bounds: the least bound and the farthest vertex.
#[derive(Clone, Copy)]
struct Octave {
    least: f64,
    reach: f64,
}

/// The octave index of a distance bound: `⌊log₂ d⌋ + 1076` (0 for 0, the subnormals and up).
fn octave(d: f64) -> usize {
    if d > 0.0 {
        (d.log2().floor() as i64 + 1076).clamp(1, 2100) as usize
    } else {
        0
    }
}

/// The near/far split of a soup (module docs), or `None` when no far triangles lie [`MIN_RATIO`] times
/// farther from the centre than every nearer one reaches (every ordinary scene). The triangles are
/// grouped by octave of their distance bound; the split is the boundary between groups with the largest
/// ratio of the next group's least bound to the farthest vertex of the groups before it.
#[must_use]
pub fn split(positions: &[Vec3], indices: &[[u32; 3]]) -> Option<FarSplit> {
    if indices.len() < 2 {
        return None;
    }
    let centre = centre(positions, indices);
    if !vertex_gap(positions, centre) {
        return None;
    }
    let bounds: Vec<(f64, f64)> = indices
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let p = t.map(|i| positions[i as usize].as_dvec3());
            let reach = p.iter().map(|q| (*q - centre).length()).fold(0.0, f64::max) * (1.0 + 1e-9);
            (distance_bound(p, centre), reach)
        })
        .collect();
    let mut octaves = vec![
        Octave {
            least: f64::INFINITY,
            reach: 0.0
        };
        2101
    ];
    for &(d, reach) in &bounds {
        let o = &mut octaves[octave(d)];
        o.least = o.least.min(d);
        o.reach = o.reach.max(reach);
    }
    let mut best: Option<(f64, usize)> = None;
    let mut reach = f64::NAN;
    for (k, o) in octaves.iter().enumerate().filter(|(_, o)| o.least.is_finite()) {
        let ratio = o.least / reach;
        if ratio >= MIN_RATIO && best.is_none_or(|(r, _)| ratio > r) {
            best = Some((ratio, k));
        }
        reach = if reach.is_nan() { o.reach } else { reach.max(o.reach) };
    }
    let (_, first_far) = best?;
    let (mut near, mut far) = (Vec::new(), Vec::new());
    let mut near_bounds = Aabb::EMPTY;
    for (i, &(d, _)) in bounds.iter().enumerate() {
        if octave(d) >= first_far {
            far.push(i as u32);
        } else {
            near.push(i as u32);
            near_bounds = indices[i].iter().fold(near_bounds, |b, &v| b.grow(positions[v as usize]));
        }
    }
    // Rounded down to f32, so that no far triangle is closer than `radius` either.
    let least = octaves[first_far].least;
    let mut radius = least as f32;
    if f64::from(radius) > least {
        radius = crate::math::next_float_down(radius);
    }
    (radius > 0.0 && radius.is_finite()).then(|| FarSplit {
        near,
        far,
        centre: centre.as_vec3(),
        radius,
        near_bounds,
    })
}

/// Triangles sampled for the centre: every `n / CENTRE_SAMPLES`-th (all of smaller soups).
const CENTRE_SAMPLES: usize = 4096;

/// Per axis, the median centroid of the sampled triangles no larger (box diagonal) than their median one:
/// inside the scene's detail, which the smaller triangles make up. A fixed stride sample keeps the cost
/// negligible on big meshes and the result deterministic.
fn centre(positions: &[Vec3], indices: &[[u32; 3]]) -> glam::DVec3 {
    let step = indices.len().div_ceil(CENTRE_SAMPLES).max(1);
    let boxes: Vec<Aabb> = indices.iter().step_by(step).map(|t| Aabb::from_points(&t.map(|i| positions[i as usize]))).collect();
    let mut sizes: Vec<f32> = boxes.iter().map(|b| b.extent().length()).collect();
    let mid = sizes.len() / 2;
    let median_size = *sizes.select_nth_unstable_by(mid, f32::total_cmp).1;
    let small: Vec<Vec3> = boxes.iter().filter(|b| b.extent().length() <= median_size).map(Aabb::center).collect();
    let axis = |k: usize| {
        let mut v: Vec<f32> = small.iter().map(|c| c[k]).collect();
        let mid = v.len() / 2;
        f64::from(*v.select_nth_unstable_by(mid, f32::total_cmp).1)
    };
    glam::DVec3::new(axis(0), axis(1), axis(2))
}

/// Whether the vertices' squared distances from `c` (in f32) leave a gap of more than 12 empty binary
/// octaves: necessary for a split (far triangles' vertices lie at least [`MIN_RATIO`] = 2⁸ times farther
/// than every near one, 16 octaves of the square, less 2 for flooring and rounding, and 2 to spare), and
/// one cheap pass over the vertices, so ordinary scenes skip the per-triangle analysis.
fn vertex_gap(positions: &[Vec3], c: glam::DVec3) -> bool {
    let c = c.as_vec3();
    let occupied = positions
        .par_iter()
        .with_min_len(16384)
        .fold(
            || [false; 256],
            |mut seen, p| {
                // The exponent field of |p − c|² (0 for 0 and subnormals, 255 for overflow).
                seen[((*p - c).length_squared().to_bits() >> 23) as usize & 0xff] = true;
                seen
            },
        )
        .reduce(|| [false; 256], |a, b| std::array::from_fn(|i| a[i] || b[i]));
    let used: Vec<usize> = (0..256).filter(|&i| occupied[i]).collect();
    used.windows(2).any(|w| w[1] - w[0] > 12)
}

/// A lower bound of the distance from `c` to the triangle `p`: the larger of the distances to its box
/// and to its plane (0 for a degenerate triangle whose plane is undefined), shrunk by a relative 10⁻⁹
/// for the rounding of the f64 arithmetic.
fn distance_bound(p: [glam::DVec3; 3], c: glam::DVec3) -> f64 {
    let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
    let to_box = (lo - c).max(c - hi).max(glam::DVec3::ZERO).length();
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let n_len = n.length();
    let to_plane = if n_len > 0.0 && n_len.is_finite() { ((c - p[0]).dot(n) / n_len).abs() } else { 0.0 };
    let d = to_box.max(to_plane);
    if d.is_finite() {
        d * (1.0 - 1e-9)
    } else {
        0.0
    }
}

/// A backend over near triangles and one over far triangles ([`split`]), answering as one backend over
/// the whole soup (global triangle indices).
pub struct Shelled {
    near: Box<dyn Accel>,
    far: Box<dyn Accel>,
    near_ids: Vec<u32>,
    far_ids: Vec<u32>,
    /// Segments that miss this box (`Aabb::may_intersect`, conservative) skip the near backend: most
    /// segments of a far ray (`rebase`).
    near_bounds: Aabb,
    centre: Vec3,
    /// A quarter of the far triangles' least distance from `centre`.
    quarter: f32,
}

impl Shelled {
    /// Combines the backends built over `split.near` and `split.far` (their triangle `i` is the soup's
    /// `split.near[i]`, `split.far[i]`).
    #[must_use]
    pub fn new(near: Box<dyn Accel>, far: Box<dyn Accel>, split: FarSplit) -> Self {
        Self {
            near,
            far,
            near_ids: split.near,
            far_ids: split.far,
            near_bounds: split.near_bounds,
            centre: split.centre,
            quarter: 0.25 * split.radius,
        }
    }

    /// Whether the part `[t_min, t_end]` of `ray` lies within `r/2` of the centre (origin and the
    /// largest `|t|·|d|` within `r/4`), so no far triangle can be hit on it.
    #[inline]
    fn inside(&self, ray: &Ray, t_end: f32) -> bool {
        let reach = ray.t_min.abs().max(t_end.abs()) * ray.dir.length();
        reach <= self.quarter && (ray.origin - self.centre).length() <= self.quarter
    }
}

impl Shelled {
    /// The closest hit of `ray` given the near backend's answer `near` (in the near backend's ids): the
    /// far backend is asked only where the ray's part up to the near hit leaves the inner ball.
    fn with_far(&self, ray: &Ray, near: Option<Hit>) -> Option<Hit> {
        // Instances report their prototype's triangles already; flat hits are numbered in the near list.
        let near = near.map(|h| if h.inst == super::FLAT { Hit { prim: self.near_ids[h.prim as usize], ..h } } else { h });
        let t_end = near.map_or(ray.t_max, |h| h.t);
        if self.inside(ray, t_end) {
            return near;
        }
        let far = self.far.intersect(&Ray { t_max: t_end, ..*ray }).map(|h| Hit { prim: self.far_ids[h.prim as usize], ..h });
        match (near, far) {
            (Some(n), Some(f)) if f.t < n.t || (f.t == n.t && n.inst == super::FLAT && f.prim < n.prim) => Some(f),
            (Some(n), _) => Some(n),
            (None, f) => f,
        }
    }

    /// Occlusion of `ray` given whether the near triangles occlude it.
    fn occluded_with_far(&self, ray: &Ray, near: bool) -> bool {
        near || (!self.inside(ray, ray.t_max) && self.far.occluded(ray))
    }

    /// The near backend's closest hit (its own ids), asked only of segments that meet the near box.
    fn near_hit(&self, ray: &Ray) -> Option<Hit> {
        if self.near_bounds.may_intersect(ray) { self.near.intersect(ray) } else { None }
    }

    /// Whether the near triangles occlude `ray`, asked only of segments that meet the near box.
    fn near_occludes(&self, ray: &Ray) -> bool {
        self.near_bounds.may_intersect(ray) && self.near.occluded(ray)
    }
}

impl Accel for Shelled {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.with_far(ray, self.near_hit(ray))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with_far(ray, self.near_occludes(ray))
    }

    /// The near backend's batch where every ray may meet the near triangles (the common case: the
    /// camera and the paths are inside the scene), else [`Shelled::intersect`]'s test ray by ray; then
    /// the far backend for the rays that leave the inner ball.
    fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        let may_meet_near = |ray: &Ray| self.near_bounds.may_intersect(ray);
        super::batch_if_all(rays, out, may_meet_near, |r, o| self.near.intersect_many(r, o), |ray| self.near_hit(ray));
        out.iter_mut().zip(rays).for_each(|(o, ray)| *o = self.with_far(ray, *o));
    }

    fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        let may_meet_near = |ray: &Ray| self.near_bounds.may_intersect(ray);
        super::batch_if_all(rays, out, may_meet_near, |r, o| self.near.occluded_many(r, o), |ray| self.near_occludes(ray));
        out.iter_mut().zip(rays).for_each(|(o, ray)| *o = self.occluded_with_far(ray, *o));
    }

    fn name(&self) -> &'static str {
        self.near.name()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::mesh::shapes;

    /// The split finds a sky-sized sphere (and only it) around small geometry, none in an ordinary scene,
    /// and the combined backend answers as the oracle over the whole soup.
    #[test]
    fn sky_sphere_is_far_and_answers_agree() {
        let mut scene = shapes::sphere(Vec3::new(0.3, -0.2, 0.1), 0.8, 16, 32);
        scene.append(&shapes::cube());
        assert_eq!(split(&scene.positions, &scene.indices), None, "no far geometry in an ordinary scene");
        let inner = scene.triangle_count();
        scene.append(&shapes::sphere(Vec3::new(0.2, 0.1, 0.0), 4.3e9, 8, 16));
        let s = split(&scene.positions, &scene.indices).expect("the sky sphere is far");
        assert_eq!(s.near, (0..inner as u32).collect::<Vec<_>>());
        assert_eq!(s.far.len(), scene.triangle_count() - inner);
        assert!(s.radius > 3e9 && s.radius < 4.3e9, "{}", s.radius);
        let sub = |ids: &[u32]| -> Box<dyn Accel> {
            let tris: Vec<[u32; 3]> = ids.iter().map(|&i| scene.indices[i as usize]).collect();
            Box::new(BruteForce::new(&scene.positions, &tris))
        };
        let shelled = Shelled::new(sub(&s.near), sub(&s.far), s);
        let oracle = BruteForce::new(&scene.positions, &scene.indices);
        let mut sampler = crate::sampler::Sampler::for_key(5, 0, 0);
        let mut far_hits = 0;
        let mut all = Vec::new();
        for _ in 0..2000 {
            let mut v = || 2.0 * sampler.next_1d() - 1.0;
            let origin = Vec3::new(v(), v(), v()) * 1.5;
            let dir = Vec3::new(v(), v(), v());
            for ray in [Ray::new(origin, dir), Ray::segment(origin, dir, 0.0, 0.5), Ray::segment(origin * 1e9, dir, 0.0, 1e10)] {
                let want = oracle.intersect(&ray);
                assert_eq!(shelled.intersect(&ray), want, "{ray:?}");
                assert_eq!(shelled.occluded(&ray), oracle.occluded(&ray), "{ray:?}");
                far_hits += usize::from(want.is_some_and(|h| h.prim as usize >= inner));
                all.push(ray);
            }
        }
        assert!(far_hits > 1000, "{far_hits}");
        // The batches: rays from inside only (the near backend's batch), and mixed with far origins.
        let inside: Vec<Ray> = all.iter().step_by(3).copied().collect();
        for rays in [&inside[..], &all[..]] {
            let mut hits = vec![None; rays.len()];
            shelled.intersect_many(rays, &mut hits);
            let mut occluded = vec![false; rays.len()];
            shelled.occluded_many(rays, &mut occluded);
            for ((ray, hit), occ) in rays.iter().zip(&hits).zip(&occluded) {
                assert_eq!(*hit, oracle.intersect(ray), "{ray:?}");
                assert_eq!(*occ, oracle.occluded(ray), "{ray:?}");
            }
        }
    }
}
