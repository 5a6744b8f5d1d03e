//! Stack traversal of the BVH8: one slab test of all eight children per node (two 4-wide halves
//! after vectorisation), nearest child first for closest hits (any order for shadow rays, which
//! measured faster), and the packet form ([`super::packet`]) of the shared watertight triangle test
//! in the leaves. Ties in `t` go to the lowest triangle index, as in the brute-force oracle.
//!
//! The slab test (Kay & Kajiya 1986; Williams et al. 2005 for the inverse-direction form) is made
//! conservative as in pbrt-v4 (`Bounds3::IntersectP`, §6.8.2): the far distance is scaled by
//! `1 + 2γ(3)`, which bounds the rounding error of `(plane − o) · (1/d)`, so a ray that touches a
//! box in exact arithmetic is never culled by rounding — a culled box would lose hits the brute-force
//! oracle finds, most visibly on meshes whose faces lie on box planes. Direction components equal to
//! ±0 give `1/d = ±∞`: the slab is then all or nothing, and the `0 · ∞ = NaN` of a ray lying in a
//! slab plane is discarded by the comparisons (`max`/`min` written so that a NaN operand loses),
//! which counts that slab as entered, the conservative answer.

use super::packet::{lanes_used, PacketRay, Tri4};
use super::wide::{packets_for, Node, Slot, WIDTH};
use super::Bvh;
use crate::accel::triangle::RayPrecomp;
use crate::accel::Hit;
use crate::math::{gamma, Ray, Vec4};

/// pbrt-v4's conservative factor for the far slab distance: `1 + 2γ(3)`.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);
/// Slack added to both ends of the ray interval in the test of a child box, in units of the
/// largest depth (along the ray's dominant axis, in `t` units) of the box's points relative to the
/// origin: the watertight test computes `t` from sheared vertex depths, with an absolute error of a
/// few ulps of those depths (pbrt-v4 §6.8.4, the `δz` terms of its `δt` bound), so a triangle whose
/// computed `t` equals `t_max` may lie, exactly, just beyond it — and in a box the ray enters just
/// beyond `t_max`. Every vertex below a child lies in its box, so the box's own depth bounds the
/// error of every `t` computed below it. 64 ulps. (The slack was once one figure for the whole
/// scene box: a sky-sized shape made it ~3·10⁴ units, and every ray visited every box along its
/// line.)
const DEPTH_SLACK: f32 = 64.0 * f32::EPSILON;
/// Entries kept on the call stack; deeper traversals spill to the heap (never for SAH trees of
/// practical size).
const INLINE_STACK: usize = 64;

/// Per-ray constants of the slab test.
struct BoxRay {
    org: [f32; 3],
    inv: [f32; 3],
    /// 1 when the ray enters through the max plane along the axis (`1/d < 0`, including `d = −0`).
    neg: [usize; 3],
    /// The dominant axis of the watertight test (`RayPrecomp::kz`), along which depths are measured.
    kz: usize,
    /// [`DEPTH_SLACK`] `· |1/d_kz|`: times a box's largest `|plane − o|` along `kz`, its slack; 0 for
    /// degenerate (zero or non-finite) directions.
    slack_scale: f32,
}

impl BoxRay {
    fn new(ray: &Ray, pre: &RayPrecomp) -> Self {
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        let slack_scale = DEPTH_SLACK * pre.sz.abs();
        Self {
            org: ray.origin.to_array(),
            inv,
            neg: inv.map(|i| usize::from(i < 0.0)),
            kz: pre.kz.min(2),
            slack_scale: if slack_scale.is_finite() { slack_scale } else { 0.0 },
        }
    }
}

/// `max(a, b)` that returns `b` when `a` is NaN (maps to `maxps`).
#[inline(always)]
fn max_keep_b(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `min(a, b)` that returns `b` when `a` is NaN (maps to `minps`).
#[inline(always)]
fn min_keep_b(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// Slab test of the children of `node` against `[t_min, t_max]`, widened per child by its depth
/// slack ([`DEPTH_SLACK`]): the bit mask of the used lanes whose box the ray touches, and per lane
/// the entry distance minus the slack (scaled as the far distance), so that a later test against a
/// lowered `t_max` is `key ≤ t_max · FAR_SCALE`.
#[inline(always)]
fn slab(node: &Node, r: &BoxRay, t_min: f32, t_max: f32) -> ([f32; WIDTH], u32) {
    let b = &node.bounds;
    let (sx, sy, sz) = (r.neg[0] & 1, r.neg[1] & 1, r.neg[2] & 1);
    let (nx, fx) = (&b[sx], &b[1 - sx]);
    let (ny, fy) = (&b[2 + sy], &b[3 - sy]);
    let (nz, fz) = (&b[4 + sz], &b[5 - sz]);
    let (k, ok) = (r.kz, r.org[r.kz]);
    let (dk0, dk1) = (&b[2 * k], &b[2 * k + 1]);
    let mut key = [0.0f32; WIDTH];
    let mut t_near = [0.0f32; WIDTH];
    let mut t_far = [0.0f32; WIDTH];
    for i in 0..WIDTH {
        let x0 = (nx[i] - r.org[0]) * r.inv[0];
        let y0 = (ny[i] - r.org[1]) * r.inv[1];
        let z0 = (nz[i] - r.org[2]) * r.inv[2];
        let x1 = (fx[i] - r.org[0]) * r.inv[0];
        let y1 = (fy[i] - r.org[1]) * r.inv[1];
        let z1 = (fz[i] - r.org[2]) * r.inv[2];
        let slack = r.slack_scale * max_keep_b((dk0[i] - ok).abs(), (dk1[i] - ok).abs());
        t_near[i] = max_keep_b(x0, max_keep_b(y0, max_keep_b(z0, t_min - slack)));
        t_far[i] = min_keep_b(x1, min_keep_b(y1, min_keep_b(z1, t_max + slack))) * FAR_SCALE;
        key[i] = t_near[i] - slack * FAR_SCALE;
    }
    // `near <= far` per lane, as a bit mask (glam's compare + movemask; NaN compares false).
    let mut mask = 0u32;
    for (k, (n4, f4)) in t_near.chunks_exact(4).zip(t_far.chunks_exact(4)).enumerate() {
        mask |= Vec4::from_slice(n4).cmple(Vec4::from_slice(f4)).bitmask() << (4 * k);
    }
    (key, mask & u32::from(node.valid))
}

/// The bits of `t` as a `u32` whose unsigned order is the float order (for sort keys).
#[inline(always)]
fn ordered_bits(t: f32) -> u32 {
    let b = t.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

#[derive(Clone, Copy)]
struct Entry {
    slot: Slot,
    t_near: f32,
}

/// The traversal stack: a fixed array with a heap spill for (pathologically) deep trees.
struct Stack {
    inline: [Entry; INLINE_STACK],
    len: usize,
    spill: Vec<Entry>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            inline: [Entry {
                slot: Slot { index: 0, count: 0 },
                t_near: 0.0,
            }; INLINE_STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, e: Entry) {
        if self.len < INLINE_STACK {
            self.inline[self.len] = e;
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

/// For the children in `mask` (non-empty) with entry keys `t_near` (entry distance minus slack):
/// pushes all but the nearest, far to near, and returns the nearest.
#[inline(always)]
fn descend(node: &Node, t_near: &[f32; WIDTH], mask: u32, stack: &mut Stack) -> Slot {
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        return node.lane_slot(first);
    }
    if rest & (rest - 1) == 0 {
        // Exactly two (the common case).
        let (a, b) = (first, rest.trailing_zeros() as usize);
        let (near, far) = if t_near[b] < t_near[a] { (b, a) } else { (a, b) };
        stack.push(Entry {
            slot: node.lane_slot(far),
            t_near: t_near[far],
        });
        return node.lane_slot(near);
    }
    // Sort keys `(order-preserving bits of t) << 32 | lane` (insertion sort, ≤ 8).
    let mut keys = [0u64; WIDTH];
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        let lane = m.trailing_zeros();
        m &= m - 1;
        let key = (u64::from(ordered_bits(t_near[lane as usize])) << 32) | u64::from(lane);
        let mut j = n;
        while j > 0 && keys[j - 1] > key {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = key;
        n += 1;
    }
    for &key in keys[1..n].iter().rev() {
        let lane = (key & 0xff) as usize;
        stack.push(Entry {
            slot: node.lane_slot(lane),
            t_near: t_near[lane],
        });
    }
    node.lane_slot((keys[0] & 0xff) as usize)
}

impl Bvh {
    /// The packets of leaf `slot`.
    #[inline(always)]
    fn leaf_packets(&self, slot: Slot) -> &[Tri4] {
        let start = slot.index as usize;
        &self.packets[start..start + packets_for(slot.count)]
    }

    /// Closest hit in `[ray.t_min, ray.t_max]`. Ties in `t` resolve to the lowest triangle index,
    /// as in the brute-force oracle.
    pub(super) fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        if self.packets.is_empty() {
            return None;
        }
        let mut pre = RayPrecomp::new(ray);
        let pr = PacketRay::new(&pre);
        let r = BoxRay::new(ray, &pre);
        let mut best = Hit {
            t: f32::INFINITY,
            prim: u32::MAX,
            u: 0.0,
            v: 0.0,
            inst: crate::accel::FLAT,
        };
        let mut stack = Stack::new();
        let mut cur = self.root;
        loop {
            if cur.count == 0 {
                let node = &self.nodes[cur.index as usize];
                let (t_near, mask) = slab(node, &r, pre.t_min, pre.t_max);
                if mask != 0 {
                    cur = descend(node, &t_near, mask, &mut stack);
                    continue;
                }
            } else {
                for (k, packet) in self.leaf_packets(cur).iter().enumerate() {
                    let (mut m, t, u, v) = packet.intersect(&pr, &pre, lanes_used(cur.count, k));
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let (t, prim) = (t[lane], packet.prim[lane]);
                        // Equal `t` only replaces a higher index; `t` may exceed a `t_max`
                        // lowered by an earlier lane of the same packet.
                        if t < pre.t_max || (t == pre.t_max && prim < best.prim) {
                            best = Hit {
                                t,
                                prim,
                                u: u[lane],
                                v: v[lane],
                                inst: crate::accel::FLAT,
                            };
                            pre.t_max = t;
                        }
                    }
                }
            }
            // Pop the next subtree the ray may still reach before the current closest hit.
            loop {
                let Some(e) = stack.pop() else {
                    return (best.prim != u32::MAX).then_some(best);
                };
                if e.t_near <= pre.t_max * FAR_SCALE {
                    cur = e.slot;
                    break;
                }
            }
        }
    }

    /// Whether any triangle is hit in `[ray.t_min, ray.t_max]`.
    pub(super) fn any_hit(&self, ray: &Ray) -> bool {
        if self.packets.is_empty() {
            return false;
        }
        let pre = RayPrecomp::new(ray);
        let pr = PacketRay::new(&pre);
        let r = BoxRay::new(ray, &pre);
        let mut stack = Stack::new();
        let mut cur = self.root;
        loop {
            if cur.count == 0 {
                let node = &self.nodes[cur.index as usize];
                let (_, mask) = slab(node, &r, pre.t_min, pre.t_max);
                if mask != 0 {
                    // Any order will do (sorting by distance measured slower for shadow rays).
                    let mut m = mask & (mask - 1);
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        stack.push(Entry {
                            slot: node.lane_slot(lane),
                            t_near: 0.0,
                        });
                        m &= m - 1;
                    }
                    cur = node.lane_slot(mask.trailing_zeros() as usize);
                    continue;
                }
            } else if self
                .leaf_packets(cur)
                .iter()
                .enumerate()
                .any(|(k, p)| p.intersect(&pr, &pre, lanes_used(cur.count, k)).0 != 0)
            {
                return true;
            }
            match stack.pop() {
                Some(e) => cur = e.slot,
                None => return false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_spills_and_pops_in_lifo_order() {
        let mut stack = Stack::new();
        for i in 0..3 * INLINE_STACK as u32 {
            stack.push(Entry {
                slot: Slot { index: i, count: 0 },
                t_near: i as f32,
            });
        }
        for i in (0..3 * INLINE_STACK as u32).rev() {
            assert_eq!(stack.pop().map(|e| e.slot.index), Some(i));
        }
        assert!(stack.pop().is_none());
    }

    #[test]
    fn ordered_bits_preserve_float_order() {
        let xs = [
            f32::NEG_INFINITY,
            -1e30,
            -1.0,
            -1e-40,
            -0.0,
            0.0,
            1e-40,
            0.5,
            1.0,
            3e38,
            f32::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(ordered_bits(w[0]) <= ordered_bits(w[1]), "{} {}", w[0], w[1]);
        }
    }
}
