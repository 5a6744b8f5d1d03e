//! Structural invariants of a built [`Bvh`], checked exhaustively (tests call this after every build).

use super::build::MAX_LEAF;
use super::wide::{Slot, EMPTY_CHILD, WIDTH};
use super::Bvh;
use crate::math::Aabb;

impl Bvh {
    /// Checks every invariant: node indices in range and every node reached exactly once from the
    /// root (a tree, no orphans); used lanes first, unused lanes empty; no interior node with fewer
    /// than two children; leaves hold `1..=MAX_LEAF` triangles; leaf ranges cover the leaf-ordered
    /// triangles exactly once and `prims` is a permutation of the input triangle indices; every
    /// child box contains its child's boxes or its triangles' corners; no NaN in any box; the
    /// recorded depth is the real one.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.prims.len();
        if self.tris.len() != n {
            return Err(format!("{} triangles but {} prim indices", self.tris.len(), n));
        }
        let mut seen_prim = vec![false; n];
        for (i, &p) in self.prims.iter().enumerate() {
            let p = p as usize;
            if p >= n || std::mem::replace(&mut seen_prim[p], true) {
                return Err(format!("prims[{i}] = {p} is out of range or repeated"));
            }
        }
        if n == 0 {
            return if self.nodes.is_empty() { Ok(()) } else { Err("empty BVH with nodes".into()) };
        }
        let mut covered = vec![false; n];
        let mut node_seen = vec![false; self.nodes.len()];
        let mut max_depth = 0u32;
        // (slot, box the parent stores for it, depth of the node holding that box)
        let mut todo: Vec<(Slot, Option<Aabb>, u32)> = vec![(self.root, None, 0)];
        while let Some((slot, parent_box, depth)) = todo.pop() {
            if slot.count > 0 {
                self.check_leaf(slot, parent_box, &mut covered)?;
                continue;
            }
            let i = slot.index as usize;
            if i >= self.nodes.len() {
                return Err(format!("node index {i} out of range ({} nodes)", self.nodes.len()));
            }
            if std::mem::replace(&mut node_seen[i], true) {
                return Err(format!("node {i} is reached twice"));
            }
            max_depth = max_depth.max(depth + 1);
            let node = &self.nodes[i];
            let used = (0..WIDTH).take_while(|&l| node.lane_used(l)).count();
            if used < 2 {
                return Err(format!("node {i} has {used} children"));
            }
            for lane in 0..WIDTH {
                let b = node.lane_bounds(lane);
                if b.min.is_nan() || b.max.is_nan() {
                    return Err(format!("node {i} lane {lane} has a NaN box"));
                }
                if lane >= used {
                    if node.lane_used(lane) || node.count[lane] != 0 || b != Aabb::EMPTY {
                        return Err(format!("node {i}: unused lane {lane} is not empty (lanes must be packed)"));
                    }
                    continue;
                }
                if let Some(pb) = parent_box {
                    if !(pb.contains(b.min) && pb.contains(b.max)) {
                        return Err(format!("node {i} lane {lane} box {b:?} escapes its parent's box {pb:?}"));
                    }
                }
                todo.push((node.lane_slot(lane), Some(b), depth + 1));
            }
        }
        if let Some(i) = node_seen.iter().position(|&s| !s) {
            return Err(format!("node {i} is not reachable from the root"));
        }
        if let Some(i) = covered.iter().position(|&c| !c) {
            return Err(format!("leaf-order triangle {i} (prim {}) is in no leaf", self.prims[i]));
        }
        if max_depth != self.max_depth {
            return Err(format!("recorded depth {} but the tree is {max_depth} deep", self.max_depth));
        }
        Ok(())
    }

    fn check_leaf(&self, slot: Slot, parent_box: Option<Aabb>, covered: &mut [bool]) -> Result<(), String> {
        let (start, count) = (slot.index as usize, slot.count as usize);
        if slot.index == EMPTY_CHILD || count > MAX_LEAF || start + count > self.tris.len() {
            return Err(format!("leaf [{start}, +{count}) is invalid (max {MAX_LEAF}, {} triangles)", self.tris.len()));
        }
        for k in start..start + count {
            if std::mem::replace(&mut covered[k], true) {
                return Err(format!("leaf-order triangle {k} is in two leaves"));
            }
            if let Some(pb) = parent_box {
                if !self.tris[k].iter().all(|&p| pb.contains(p)) {
                    return Err(format!("triangle {} {:?} escapes its leaf box {pb:?}", self.prims[k], self.tris[k]));
                }
            }
        }
        Ok(())
    }
}
