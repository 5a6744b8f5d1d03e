//! Structural invariants of a built [`Bvh`], checked exhaustively (tests call this after every build).

use super::build::MAX_LEAF;
use super::packet::{LANES, NO_PRIM};
use super::wide::{packets_for, Slot, EMPTY_LANE, WIDTH};
use super::Bvh;
use crate::math::Aabb;

impl Bvh {
    /// Checks every invariant: node indices in range and every node reached exactly once from the
    /// root (a tree, no orphans); used lanes first, `valid` matching them, unused lanes empty; no
    /// interior node with fewer than two children; leaves hold `1..=MAX_LEAF` triangles in their
    /// own packets (every packet in exactly one leaf, lanes packed, unused lanes `NO_PRIM`);
    /// every input triangle appears in exactly one lane; every child box contains its subtree's
    /// triangles; the recorded depth and scene box are the real ones.
    pub fn validate(&self) -> Result<(), String> {
        if self.n_tris == 0 {
            return if self.nodes.is_empty() && self.packets.is_empty() {
                Ok(())
            } else {
                Err("empty BVH with nodes or packets".into())
            };
        }
        let mut st = Walk {
            prim_seen: vec![false; self.n_tris],
            packet_seen: vec![false; self.packets.len()],
            node_seen: vec![false; self.nodes.len()],
            max_depth: 0,
        };
        let bounds = self.check_slot(self.root, 0, &mut st)?;
        if bounds != self.bounds {
            return Err(format!("recorded scene box {:?} but the triangles span {bounds:?}", self.bounds));
        }
        if let Some(i) = st.node_seen.iter().position(|&s| !s) {
            return Err(format!("node {i} is not reachable from the root"));
        }
        if let Some(i) = st.packet_seen.iter().position(|&s| !s) {
            return Err(format!("packet {i} is in no leaf"));
        }
        if let Some(p) = st.prim_seen.iter().position(|&s| !s) {
            return Err(format!("triangle {p} is in no leaf"));
        }
        if st.max_depth != self.max_depth {
            return Err(format!("recorded depth {} but the tree is {} deep", self.max_depth, st.max_depth));
        }
        Ok(())
    }

    /// Checks the subtree at `slot` (whose parent is at `depth`) and returns the exact box of its
    /// triangles. Recursion depth is bounded by the tree depth.
    fn check_slot(&self, slot: Slot, depth: u32, st: &mut Walk) -> Result<Aabb, String> {
        if slot.count > 0 {
            return self.check_leaf(slot, st);
        }
        let i = slot.index as usize;
        if i >= self.nodes.len() {
            return Err(format!("node index {i} out of range ({} nodes)", self.nodes.len()));
        }
        if std::mem::replace(&mut st.node_seen[i], true) {
            return Err(format!("node {i} is reached twice"));
        }
        st.max_depth = st.max_depth.max(depth + 1);
        let node = &self.nodes[i];
        let used = (0..WIDTH).take_while(|&l| node.count[l] != EMPTY_LANE).count();
        if used < 2 {
            return Err(format!("node {i} has {used} children"));
        }
        if u32::from(node.valid) != (1 << used) - 1 || node.count[used..].iter().any(|&c| c != EMPTY_LANE) {
            return Err(format!(
                "node {i}: lanes not packed or valid mask {:#010b} wrong for {used} lanes",
                node.valid
            ));
        }
        let mut total = Aabb::EMPTY;
        for lane in 0..WIDTH {
            let b = node.lane_bounds(lane);
            if b.min.is_nan() || b.max.is_nan() {
                return Err(format!("node {i} lane {lane} has a NaN box"));
            }
            if lane >= used {
                if b != Aabb::EMPTY {
                    return Err(format!("node {i}: unused lane {lane} has a box"));
                }
                continue;
            }
            let exact = self.check_slot(node.lane_slot(lane), depth + 1, st)?;
            if !(b.contains(exact.min) && b.contains(exact.max)) {
                return Err(format!("node {i} lane {lane}: box {b:?} does not contain its subtree {exact:?}"));
            }
            total = total.union(exact);
        }
        Ok(total)
    }

    fn check_leaf(&self, slot: Slot, st: &mut Walk) -> Result<Aabb, String> {
        let (first, count) = (slot.index as usize, slot.count as usize);
        let n_packets = packets_for(slot.count);
        if count > MAX_LEAF || first + n_packets > self.packets.len() {
            return Err(format!(
                "leaf at packet {first} with {count} triangles is invalid (max {MAX_LEAF}, {} packets)",
                self.packets.len()
            ));
        }
        let mut b = Aabb::EMPTY;
        for k in 0..n_packets {
            if std::mem::replace(&mut st.packet_seen[first + k], true) {
                return Err(format!("packet {} is in two leaves", first + k));
            }
            let packet = &self.packets[first + k];
            let lanes_used = (count - k * LANES).min(LANES);
            for lane in 0..LANES {
                let prim = packet.prim[lane];
                if lane >= lanes_used {
                    if prim != NO_PRIM || !packet.corners(lane).iter().all(|c| c.is_nan()) {
                        return Err(format!("packet {} lane {lane} should be unused", first + k));
                    }
                    continue;
                }
                if prim as usize >= self.n_tris || std::mem::replace(&mut st.prim_seen[prim as usize], true) {
                    return Err(format!("triangle {prim} is out of range or in two lanes"));
                }
                b = packet.corners(lane).iter().fold(b, |b, &p| b.grow(p));
            }
        }
        Ok(b)
    }
}

/// What the validation walk accumulates.
struct Walk {
    prim_seen: Vec<bool>,
    packet_seen: Vec<bool>,
    node_seen: Vec<bool>,
    max_depth: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::shapes::sphere;

    /// `validate` accepts a real build and rejects each kind of corruption.
    #[test]
    fn validate_detects_corruption() {
        let mesh = sphere(Vec3::ZERO, 1.0, 20, 30);
        let good = Bvh::build(&mesh.positions, &mesh.indices);
        good.validate().expect("a real build is valid");
        let root = good.root.index as usize;
        let leaf_lane = |b: &Bvh| {
            b.nodes
                .iter()
                .enumerate()
                .find_map(|(i, n)| (0..WIDTH).find(|&l| n.count[l] > 0 && n.count[l] != EMPTY_LANE).map(|l| (i, l)))
        };
        type Corruption = Box<dyn Fn(&mut Bvh)>;
        let corruptions: Vec<(&str, Corruption)> = vec![
            ("shrunk child box", Box::new(move |b| b.nodes[root].bounds[1][0] -= 0.25)),
            (
                "child index out of range",
                Box::new(move |b| b.nodes[root].child[0] = u32::MAX >> 1),
            ),
            ("lane mask", Box::new(move |b| b.nodes[root].valid &= !1)),
            ("depth", Box::new(|b| b.max_depth += 1)),
            ("scene box", Box::new(|b| b.bounds.max.x += 1.0)),
            (
                "leaf too large",
                Box::new(move |b| {
                    let (i, l) = leaf_lane(b).expect("a leaf");
                    b.nodes[i].count[l] = MAX_LEAF as u8 + 1;
                }),
            ),
            (
                "triangle twice",
                Box::new(|b| {
                    let p = b
                        .packets
                        .iter()
                        .position(|p| p.prim[1] != NO_PRIM)
                        .expect("a packet with two triangles");
                    b.packets[p].prim[1] = b.packets[p].prim[0];
                }),
            ),
            (
                "unused lane filled",
                Box::new(|b| {
                    let p = b
                        .packets
                        .iter()
                        .position(|p| p.prim[LANES - 1] == NO_PRIM)
                        .expect("a packet with a free lane");
                    b.packets[p].prim[LANES - 1] = 0;
                }),
            ),
        ];
        for (what, corrupt) in corruptions {
            let mut bad = good.clone();
            corrupt(&mut bad);
            assert!(bad.validate().is_err(), "{what} went unnoticed");
        }
    }
}
