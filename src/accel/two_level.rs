//! Two-level acceleration for the pure-Rust backend (and any backend with the [`Accel`] interface): one
//! accelerator over the flat soup, one per prototype over its object-space triangles, and a top-level
//! binary BVH over the instances' world boxes. A ray is traced through the flat soup first, then down the
//! top level, each instance it may meet tracing the ray transformed into its object space with `t_max`
//! the closest hit so far, so `t` stays the world ray's parameter. A prototype's accelerator is built
//! once, whatever the number of its instances.
//!
//! The top level splits at the median of the instances' box centres along the largest axis of their
//! spread, down to one instance per leaf; its slab test is conservative as the BVH's (pbrt-v4's
//! `1 + 2γ(3)` on the far distance), and the instances' world boxes are padded for the rounding of the
//! transform (`Instance::world_bounds`).

use super::instance::Instance;
use super::{Accel, Hit};
use crate::math::{gamma, Aabb, Ray};

/// pbrt-v4's conservative factor for the far slab distance: `1 + 2γ(3)`.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// A top-level node: a box and either two children (`count == 0`: the node after it and `index`) or a
/// leaf of `count` entries from `index` in `order`.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Interior: the second child (the first follows the node). Leaf: the first entry in `order`.
    index: u32,
    /// 0 for an interior node, else the number of instances in the leaf.
    count: u32,
}

/// A binary BVH over boxes, answering "which boxes may the ray meet, nearest first".
#[derive(Clone, Debug, Default)]
pub struct TopLevel {
    nodes: Vec<Node>,
    /// Entries in leaf order.
    order: Vec<u32>,
}

impl TopLevel {
    /// The BVH over `boxes` (empty boxes are left out).
    #[must_use]
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut order: Vec<u32> = (0..boxes.len() as u32).filter(|&i| !boxes[i as usize].is_empty()).collect();
        let mut nodes = Vec::with_capacity(2 * order.len());
        if !order.is_empty() {
            let n = order.len();
            build_node(boxes, &mut order, 0, n, &mut nodes);
        }
        Self { nodes, order }
    }

    /// Calls `visit(entry, t_max)` for every entry whose box the ray `[t_min, t_max]` may meet, nearer
    /// boxes first; `visit` returns the new `t_max` (a closer hit) or `None`, and `Stop` to end the walk.
    #[inline]
    pub fn walk(&self, ray: &Ray, mut t_max: f32, mut visit: impl FnMut(u32, f32) -> Visit) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = ray.dir.recip();
        let entry = |b: &Aabb, t_max: f32| -> Option<f32> {
            let (mut t0, mut t1) = (ray.t_min, t_max);
            for a in 0..3 {
                let (lo, hi) = ((b.min[a] - ray.origin[a]) * inv[a], (b.max[a] - ray.origin[a]) * inv[a]);
                let (near, far) = if lo <= hi { (lo, hi * FAR_SCALE) } else { (hi, lo * FAR_SCALE) };
                // NaN (a ray in a slab plane with a zero direction component) keeps the slab entered.
                if near > t0 {
                    t0 = near;
                }
                if far < t1 {
                    t1 = far;
                }
            }
            (t0 <= t1).then_some(t0)
        };
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        if entry(&self.nodes[0].bounds, t_max).is_some() {
            stack.push(0);
        }
        while let Some(i) = stack.pop() {
            let node = self.nodes[i as usize];
            if node.count > 0 {
                for &e in &self.order[node.index as usize..(node.index + node.count) as usize] {
                    match visit(e, t_max) {
                        Visit::Closer(t) => t_max = t,
                        Visit::Stop => return,
                        Visit::Miss => {}
                    }
                }
                continue;
            }
            let (a, b) = (i + 1, node.index);
            let (ta, tb) = (entry(&self.nodes[a as usize].bounds, t_max), entry(&self.nodes[b as usize].bounds, t_max));
            match (ta, tb) {
                (Some(ta), Some(tb)) => {
                    // The nearer child is popped first.
                    if ta <= tb {
                        stack.extend([b, a]);
                    } else {
                        stack.extend([a, b]);
                    }
                }
                (Some(_), None) => stack.push(a),
                (None, Some(_)) => stack.push(b),
                (None, None) => {}
            }
        }
    }

    /// Bytes held by the nodes and the order.
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.order.as_slice())
    }
}

/// What a visited entry answers ([`TopLevel::walk`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Visit {
    Miss,
    /// A hit at this `t`: later entries are tested up to it.
    Closer(f32),
    /// End the walk (an occlusion found).
    Stop,
}

fn build_node(boxes: &[Aabb], order: &mut [u32], start: usize, end: usize, nodes: &mut Vec<Node>) -> u32 {
    let here = nodes.len() as u32;
    let part = &mut order[start..end];
    let bounds = part.iter().fold(Aabb::EMPTY, |b, &i| b.union(boxes[i as usize]));
    if part.len() <= 1 {
        nodes.push(Node { bounds, index: start as u32, count: part.len() as u32 });
        return here;
    }
    let centres = part.iter().fold(Aabb::EMPTY, |b, &i| b.grow(boxes[i as usize].center()));
    let axis = centres.largest_axis();
    let mid = part.len() / 2;
    part.select_nth_unstable_by(mid, |&a, &b| boxes[a as usize].center()[axis].total_cmp(&boxes[b as usize].center()[axis]));
    nodes.push(Node { bounds, index: 0, count: 0 });
    build_node(boxes, order, start, start + mid, nodes);
    let right = build_node(boxes, order, start + mid, end, nodes);
    nodes[here as usize].index = right;
    here
}

/// A flat-soup accelerator, one per prototype, and the top level over the instances.
pub struct TwoLevel {
    flat: Box<dyn Accel>,
    prototypes: Vec<Box<dyn Accel>>,
    /// Per prototype, the soup index of its first triangle (its accelerator's triangle 0).
    first: Vec<u32>,
    instances: Vec<Instance>,
    top: TopLevel,
}

impl TwoLevel {
    /// `flat` answers the flat soup (its ids as they should be reported), `prototypes[p]` prototype `p`
    /// with ids from 0 (reported plus `first[p]`); `bounds` are the instances' world boxes.
    #[must_use]
    pub fn new(flat: Box<dyn Accel>, prototypes: Vec<Box<dyn Accel>>, first: Vec<u32>, instances: &[Instance], bounds: &[Aabb]) -> Self {
        Self { flat, prototypes, first, instances: instances.to_vec(), top: TopLevel::build(bounds) }
    }

    /// Bytes of the instances and the top level.
    #[must_use]
    pub fn top_memory_bytes(&self) -> usize {
        self.top.memory_bytes() + std::mem::size_of_val(self.instances.as_slice())
    }
}

impl Accel for TwoLevel {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = self.flat.intersect(ray);
        let t_max = best.map_or(ray.t_max, |h| h.t);
        self.top.walk(ray, t_max, |i, t_max| {
            let inst = &self.instances[i as usize];
            let p = inst.prototype as usize;
            let local = Ray { t_max, ..inst.object_ray(ray) };
            match self.prototypes[p].intersect(&local) {
                Some(h) if best.is_none_or(|b| h.t < b.t) => {
                    best = Some(Hit { prim: h.prim + self.first[p], inst: i, ..h });
                    Visit::Closer(h.t)
                }
                _ => Visit::Miss,
            }
        });
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.flat.occluded(ray) {
            return true;
        }
        let mut found = false;
        self.top.walk(ray, ray.t_max, |i, _| {
            let inst = &self.instances[i as usize];
            found = self.prototypes[inst.prototype as usize].occluded(&inst.object_ray(ray));
            if found { Visit::Stop } else { Visit::Miss }
        });
        found
    }

    fn name(&self) -> &'static str {
        self.flat.name()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::accel::{build_accel, BackendKind, Geometry, FLAT};
    use crate::math::Vec3;
    use crate::mesh::shapes;
    use glam::{Affine3A, Quat};

    /// A flat cube and two prototypes (a sphere, a cube) placed by instances with rotations, non-uniform
    /// scales and mirrors; and the same triangles placed in world space (flattened).
    fn scene() -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<std::ops::Range<u32>>, Vec<Instance>, crate::mesh::TriangleMesh) {
        let mut mesh = shapes::cube();
        let flat = mesh.triangle_count() as u32;
        let sphere = shapes::sphere(Vec3::new(0.2, 0.0, -0.1), 0.7, 12, 24);
        mesh.append(&sphere);
        let a = flat..mesh.triangle_count() as u32;
        mesh.append(&shapes::cube());
        let b = a.end..mesh.triangle_count() as u32;
        let mut instances = Vec::new();
        for k in 0..40 {
            let f = k as f32;
            let scale = Vec3::new(0.3 + 0.05 * f, 0.2 + 0.03 * (f % 5.0), 0.4) * if k % 3 == 0 { Vec3::new(-1.0, 1.0, 1.0) } else { Vec3::ONE };
            let m = Affine3A::from_scale_rotation_translation(scale, Quat::from_rotation_y(0.7 * f) * Quat::from_rotation_x(0.3 * f), Vec3::new((f % 7.0) - 3.0, (f % 3.0) * 1.5 - 1.5, f * 0.2 - 4.0));
            instances.push(Instance::new(k % 2, m).unwrap());
        }
        let mut flattened = crate::mesh::TriangleMesh { positions: mesh.positions.clone(), indices: mesh.indices[..flat as usize].to_vec(), ..Default::default() };
        for inst in &instances {
            let r = if inst.prototype == 0 { &a } else { &b };
            for t in &mesh.indices[r.start as usize..r.end as usize] {
                let base = flattened.positions.len() as u32;
                flattened.positions.extend(t.map(|i| inst.to_world.transform_point3(mesh.positions[i as usize])));
                flattened.indices.push([base, base + 1, base + 2]);
            }
        }
        (mesh.positions, mesh.indices, vec![a, b], instances, flattened)
    }

    fn rays(n: usize) -> Vec<Ray> {
        let mut sampler = crate::sampler::Sampler::for_key(11, 0, 0);
        (0..n)
            .map(|_| {
                let mut v = || 2.0 * sampler.next_1d() - 1.0;
                let o = Vec3::new(v(), v(), v()) * 6.0;
                let target = Vec3::new(v(), v(), v()) * 3.0;
                Ray::new(o, target - o)
            })
            .collect()
    }

    /// The BVH's two levels answer as the brute-force oracle bit for bit, and both as the flattened
    /// scene (the same triangle, `t` within rounding), on non-uniform scales and mirrors; Embree too.
    #[test]
    fn instanced_backends_agree_with_the_oracle_and_the_flattened_scene() {
        let (positions, indices, prototypes, instances, flattened) = scene();
        let g = Geometry { positions: &positions, indices: &indices, flat: 12, prototypes: &prototypes, instances: &instances, analytic: &[] };
        let oracle = BruteForce::from_geometry(&g);
        let flat_oracle = BruteForce::new(&flattened.positions, &flattened.indices);
        // Flattened triangle index of (instance, prim).
        let mut offsets = Vec::new();
        let mut next = 12u32;
        for inst in &instances {
            offsets.push(next);
            next += prototypes[inst.prototype as usize].len() as u32;
        }
        let flattened_index = |h: &Hit| if h.inst == FLAT { h.prim } else { offsets[h.inst as usize] + h.prim - prototypes[instances[h.inst as usize].prototype as usize].start };
        let mut backends = vec![build_accel(BackendKind::Bvh, &g).unwrap()];
        if cfg!(feature = "embree") {
            backends.push(build_accel(BackendKind::Embree, &g).unwrap());
        }
        let rays = rays(4000);
        let (mut hits, mut same, mut mirrored) = (0, 0, 0);
        for ray in &rays {
            let want = oracle.intersect(ray);
            let flat = flat_oracle.intersect(ray);
            assert_eq!(want.is_some(), oracle.occluded(ray));
            if let (Some(w), Some(f)) = (want, flat) {
                hits += 1;
                same += usize::from(flattened_index(&w) == f.prim);
                assert!((w.t - f.t).abs() <= 1e-4 * w.t.abs().max(1.0), "{w:?} {f:?}");
                mirrored += usize::from(w.inst != FLAT && w.inst % 3 == 0);
            } else {
                assert_eq!(want.is_some(), flat.is_some(), "{ray:?}");
            }
            for b in &backends {
                let got = b.intersect(ray);
                assert_eq!(got.is_some(), want.is_some(), "{}: {ray:?}", b.name());
                assert_eq!(b.occluded(ray), want.is_some(), "{}: {ray:?}", b.name());
                if let (Some(g), Some(w)) = (got, want) {
                    if b.name() == "bvh" {
                        assert_eq!(g, w, "{ray:?}");
                    } else {
                        assert!((g.t - w.t).abs() <= 1e-4 * w.t.abs().max(1.0), "{g:?} {w:?}");
                        assert!(g.inst == w.inst && g.prim == w.prim || (g.t - w.t).abs() <= 1e-5 * w.t.abs().max(1.0), "{g:?} {w:?}");
                    }
                }
            }
        }
        assert!(hits > 2000 && mirrored > 100, "{hits} hits, {mirrored} on mirrored instances");
        assert!(same as f64 >= 0.999 * hits as f64, "{same} of {hits}");
        // Batches answer as single rays.
        for b in &backends {
            let mut out = vec![None; rays.len()];
            b.intersect_many(&rays, &mut out);
            for (ray, o) in rays.iter().zip(&out) {
                assert_eq!(*o, b.intersect(ray), "{}", b.name());
            }
        }
    }

    /// The walk visits every box the ray meets (against a linear scan), nearest first where it can.
    #[test]
    fn top_level_visits_every_box_the_ray_meets() {
        let mut sampler = crate::sampler::Sampler::for_key(3, 0, 0);
        let mut v = || 2.0 * sampler.next_1d() - 1.0;
        let boxes: Vec<Aabb> = (0..300).map(|_| {
            let c = Vec3::new(v(), v(), v()) * 10.0;
            let e = Vec3::new(v().abs(), v().abs(), v().abs()) * 0.5;
            Aabb { min: c - e, max: c + e }
        }).collect();
        let top = TopLevel::build(&boxes);
        for _ in 0..500 {
            let ray = Ray::new(Vec3::new(v(), v(), v()) * 12.0, Vec3::new(v(), v(), v()));
            let mut seen = Vec::new();
            top.walk(&ray, f32::INFINITY, |i, _| {
                seen.push(i);
                Visit::Miss
            });
            for (i, b) in boxes.iter().enumerate() {
                if b.may_intersect(&ray) {
                    assert!(seen.contains(&(i as u32)), "box {i} missed by {ray:?}");
                }
            }
        }
    }
}
