//! The analytic primitives of a scene beside its triangles: every backend (Embree, the BVH) traces the
//! triangles, then this box BVH over the primitives' world boxes (`two_level::TopLevel`) up to the
//! triangle hit, each primitive by the one routine [`Analytic::intersect`], so that every backend reports
//! the same analytic hits bit for bit. The brute-force oracle tests every primitive in order
//! ([`closest_linear`]).
//!
//! A primitive's hit carries `prim = first + k` (`first`: the number of triangles in the soup, `k` its
//! index in the geometry's list; `scene::Surface` reads it back) and `inst = FLAT`. Ties in `t` go to the
//! lower `prim` (a triangle before a primitive, as in the oracle).
//!
//! The primitives are traced on the ray as given, outside `rebase` and `shell`: their routine is f64 and
//! exact for far origins, so a sky-sized sphere needs neither. A scene without analytic primitives is
//! not wrapped at all (`build_accel`).

use super::analytic::Analytic;
use super::two_level::{TopLevel, Visit};
use super::{Accel, Hit, FLAT};
use crate::math::Ray;

/// A triangle backend and the analytic primitives.
pub struct WithAnalytic {
    inner: Box<dyn Accel>,
    shapes: Vec<Analytic>,
    /// `prim` of primitive 0.
    first: u32,
    top: TopLevel,
}

/// Whether a hit at `(t, prim)` beats `best` (nearer, or as near with a lower `prim`).
#[inline]
fn beats(t: f32, prim: u32, best: &Option<Hit>) -> bool {
    best.is_none_or(|b| t < b.t || (t == b.t && prim < b.prim))
}

/// The primitive hit of `shapes` (numbered from `first`) that beats `best`, tested in order: the oracle's.
pub fn closest_linear(shapes: &[Analytic], first: u32, ray: &Ray, best: &mut Option<Hit>) {
    for (k, s) in shapes.iter().enumerate() {
        let t_max = best.map_or(ray.t_max, |b| b.t);
        let prim = first + k as u32;
        if let Some(t) = s.intersect(&Ray { t_max, ..*ray }) {
            if beats(t, prim, best) {
                *best = Some(Hit { t, prim, u: 0.0, v: 0.0, inst: FLAT });
            }
        }
    }
}

impl WithAnalytic {
    /// `inner` answers the triangles (`first` of them); `shapes` are the primitives.
    #[must_use]
    pub fn new(inner: Box<dyn Accel>, shapes: &[Analytic], first: u32) -> Self {
        let boxes: Vec<_> = shapes.iter().map(Analytic::bounds).collect();
        Self { inner, shapes: shapes.to_vec(), first, top: TopLevel::build(&boxes) }
    }

    /// The primitive hit that beats `best`.
    #[inline]
    fn closest(&self, ray: &Ray, best: &mut Option<Hit>) {
        self.top.walk(ray, best.map_or(ray.t_max, |b| b.t), |k, t_max| {
            let prim = self.first + k;
            match self.shapes[k as usize].intersect(&Ray { t_max, ..*ray }) {
                Some(t) if beats(t, prim, best) => {
                    *best = Some(Hit { t, prim, u: 0.0, v: 0.0, inst: FLAT });
                    Visit::Closer(t)
                }
                _ => Visit::Miss,
            }
        });
    }

    fn any(&self, ray: &Ray) -> bool {
        let mut found = false;
        self.top.walk(ray, ray.t_max, |k, _| {
            found = self.shapes[k as usize].intersect(ray).is_some();
            if found { Visit::Stop } else { Visit::Miss }
        });
        found
    }
}

impl Accel for WithAnalytic {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = self.inner.intersect(ray);
        self.closest(ray, &mut best);
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.inner.occluded(ray) || self.any(ray)
    }

    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.inner.intersect_many(rays, out);
        for (ray, best) in rays.iter().zip(out.iter_mut()) {
            self.closest(ray, best);
        }
    }

    fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        self.inner.occluded_many(rays, out);
        for (ray, o) in rays.iter().zip(out.iter_mut()) {
            *o = *o || self.any(ray);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::analytic::Kind;
    use crate::accel::brute::BruteForce;
    use crate::accel::{build_accel, BackendKind, Geometry, Instance};
    use crate::math::{Mat4, Vec3};
    use crate::mesh::shapes;
    use glam::{Affine3A, Quat};

    /// Triangles (a cube, a tessellated sphere), two instances of a cube, and 60 spheres, disks and
    /// cylinders under rotations, non-uniform scales and mirrors.
    fn scene() -> (crate::mesh::TriangleMesh, Vec<std::ops::Range<u32>>, Vec<Instance>, Vec<Analytic>) {
        let mut mesh = shapes::cube();
        mesh.append(&shapes::sphere(Vec3::new(1.5, 0.0, -0.5), 0.6, 12, 24));
        let flat = mesh.triangle_count() as u32;
        mesh.append(&shapes::cube());
        let prototypes = vec![flat..mesh.triangle_count() as u32];
        let instances = (0..2).map(|k| Instance::new(0, Affine3A::from_scale_rotation_translation(Vec3::new(0.3, 0.5, 0.2), Quat::from_rotation_z(0.5 * k as f32), Vec3::new(-2.0, 2.0 * k as f32 - 1.0, 1.0))).unwrap()).collect();
        let mut sampler = crate::sampler::Sampler::for_key(17, 0, 0);
        let mut v = || 2.0 * sampler.next_1d() - 1.0;
        let shapes = (0..60)
            .map(|k| {
                let kind = [Kind::Sphere, Kind::Disk, Kind::Cylinder][k % 3];
                let mirror = if k % 4 == 0 { -1.0 } else { 1.0 };
                let s = if kind == Kind::Sphere { Vec3::splat(0.2 + 0.3 * v().abs()) } else { Vec3::new(0.2 + 0.5 * v().abs(), 0.1 + 0.4 * v().abs(), 0.3 + v().abs()) };
                let m = Mat4::from_scale_rotation_translation(s * Vec3::new(mirror, 1.0, 1.0), Quat::from_rotation_y(3.0 * v()) * Quat::from_rotation_x(3.0 * v()), Vec3::new(v(), v(), v()) * 3.0);
                Analytic::new(kind, m, k % 5 == 0).unwrap()
            })
            .collect();
        (mesh, prototypes, instances, shapes)
    }

    /// The BVH answers as the brute-force oracle bit for bit on scenes mixing triangles, instances and
    /// analytic primitives; Embree too on the primitives (its triangle `t` within rounding); batches as
    /// single rays.
    #[test]
    fn backends_agree_with_the_oracle_on_analytic_primitives() {
        let (mesh, prototypes, instances, shapes) = scene();
        let flat = prototypes[0].start;
        let g = Geometry { positions: &mesh.positions, indices: &mesh.indices, flat, prototypes: &prototypes, instances: &instances, analytic: &shapes };
        let first = g.first_analytic();
        let oracle = BruteForce::from_geometry(&g);
        let mut backends = vec![build_accel(BackendKind::Bvh, &g).unwrap()];
        if cfg!(feature = "embree") {
            backends.push(build_accel(BackendKind::Embree, &g).unwrap());
        }
        let mut sampler = crate::sampler::Sampler::for_key(23, 0, 0);
        let rays: Vec<Ray> = (0..6000)
            .map(|k| {
                let mut v = || 2.0 * sampler.next_1d() - 1.0;
                // Some rays start inside the scene (inside primitives), some far away.
                let o = Vec3::new(v(), v(), v()) * if k % 3 == 0 { 2.0 } else { 8.0 };
                Ray::new(o, Vec3::new(v(), v(), v()) * 3.0 - o)
            })
            .collect();
        let (mut analytic_hits, mut triangle_hits) = (0, 0);
        for ray in &rays {
            let want = oracle.intersect(ray);
            assert_eq!(want.is_some(), oracle.occluded(ray));
            match want {
                Some(w) if w.prim >= first => analytic_hits += 1,
                Some(_) => triangle_hits += 1,
                None => {}
            }
            for b in &backends {
                let got = b.intersect(ray);
                assert_eq!(b.occluded(ray), want.is_some(), "{}: {ray:?}", b.name());
                match (got, want) {
                    (Some(g), Some(w)) if b.name() == "bvh" || w.prim >= first && g.prim >= first => assert_eq!(g, w, "{}: {ray:?}", b.name()),
                    (Some(g), Some(w)) => assert!((g.t - w.t).abs() <= 1e-5 * w.t.abs().max(1.0), "{g:?} {w:?}"),
                    (g, w) => assert_eq!(g, w, "{}: {ray:?}", b.name()),
                }
            }
        }
        assert!(analytic_hits > 1500 && triangle_hits > 300, "{analytic_hits} analytic, {triangle_hits} triangle hits");
        for b in &backends {
            let mut out = vec![None; rays.len()];
            b.intersect_many(&rays, &mut out);
            let mut occluded = vec![false; rays.len()];
            b.occluded_many(&rays, &mut occluded);
            for ((ray, o), occ) in rays.iter().zip(&out).zip(&occluded) {
                assert_eq!(*o, b.intersect(ray), "{}", b.name());
                assert_eq!(*occ, o.is_some(), "{}", b.name());
            }
        }
        // Primitives alone (no triangle at all).
        let g = Geometry { positions: &[], indices: &[], flat: 0, prototypes: &[], instances: &[], analytic: &shapes };
        let oracle = BruteForce::from_geometry(&g);
        for kind in [BackendKind::Bvh].into_iter().chain(cfg!(feature = "embree").then_some(BackendKind::Embree)) {
            let b = build_accel(kind, &g).unwrap();
            for ray in &rays[..500] {
                assert_eq!(b.intersect(ray), oracle.intersect(ray), "{}", b.name());
            }
        }
    }
}
