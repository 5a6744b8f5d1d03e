//! The flattened wide node layout (8 children, f32 boxes in structure-of-arrays form), and the
//! collapse of the builder's binary tree into it, emitting the leaf triangles as packets.
//!
//! A binary SAH tree is collapsed top-down into a BVH8 (as Embree's BVH8; Wald et al. 2008,
//! "Getting Rid of Packets"; Ernst & Greiner 2008, "Multi Bounding Volume Hierarchies"): a node
//! adopts its two children, then repeatedly opens the adopted interior child with the largest
//! surface area until it has [`WIDTH`] children or only leaves remain. Incoherent traversal is bound
//! by the latency of node loads that miss the caches; a wide node halves the depth of a binary
//! tree three times over, and its four cache lines are requested together, so the misses overlap.
//! Child boxes are stored one `[f32; WIDTH]` per plane, so the slab test of all children is a
//! handful of 4-wide operations per half that the compiler vectorises.

use super::build::{BuildNode, MAX_LEAF};
use super::packet::{Tri4, LANES};
use crate::math::{Aabb, Vec3};

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// `count` of an unused lane.
pub(super) const EMPTY_LANE: u8 = u8::MAX;

/// A reference to a subtree: an interior node (`count == 0`, `index` into the node array) or a
/// leaf (`count > 0` triangles in packets starting at packet `index`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Slot {
    pub index: u32,
    pub count: u32,
}

/// One wide node (256 bytes: four cache lines).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node {
    /// `bounds[2·axis]` is the min plane along `axis` of each child, `bounds[2·axis + 1]` the max
    /// plane. Unused lanes hold the empty box (min = +∞, max = −∞) and are masked by `valid`.
    pub bounds: [[f32; WIDTH]; 6],
    /// Per lane: the child node index, or the first packet of a leaf.
    pub child: [u32; WIDTH],
    /// Per lane: 0 for an interior child, `1..=MAX_LEAF` triangles for a leaf, [`EMPTY_LANE`] if unused.
    pub count: [u8; WIDTH],
    /// Bit `i` set when lane `i` is used (used lanes come first).
    pub valid: u8,
}

impl Node {
    const EMPTY: Node = Node {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
        count: [EMPTY_LANE; WIDTH],
        valid: 0,
    };

    /// The box of lane `lane`.
    #[must_use]
    pub fn lane_bounds(&self, lane: usize) -> Aabb {
        let b = &self.bounds;
        Aabb {
            min: Vec3::new(b[0][lane], b[2][lane], b[4][lane]),
            max: Vec3::new(b[1][lane], b[3][lane], b[5][lane]),
        }
    }

    /// The child in lane `lane`.
    #[inline(always)]
    #[must_use]
    pub fn lane_slot(&self, lane: usize) -> Slot {
        Slot {
            index: self.child[lane],
            count: u32::from(self.count[lane]),
        }
    }

    fn set_lane(&mut self, lane: usize, bounds: Aabb, slot: Slot) {
        for axis in 0..3 {
            self.bounds[2 * axis][lane] = bounds.min[axis];
            self.bounds[2 * axis + 1][lane] = bounds.max[axis];
        }
        self.child[lane] = slot.index;
        debug_assert!(slot.count as usize <= MAX_LEAF);
        self.count[lane] = slot.count as u8;
        self.valid |= 1 << lane;
    }
}

/// Packets needed for a leaf of `count` triangles.
#[inline(always)]
#[must_use]
pub(super) fn packets_for(count: u32) -> usize {
    (count as usize).div_ceil(LANES)
}

/// The collapsed tree: nodes (root first when the root is interior), the root slot, and the
/// leaf triangles in packets, in leaf order.
pub(super) struct WideTree {
    pub nodes: Vec<Node>,
    pub root: Slot,
    pub packets: Vec<Tri4>,
    /// Interior nodes on the longest root-to-leaf path (0 when the root is a leaf).
    pub max_depth: u32,
}

/// Collapses the binary tree into a BVH8 (children of every node adopted by largest area first).
/// `tris[i]` are the corners of leaf-order triangle `i` (a builder leaf's `start..start + count`)
/// and `ids[i]` its input index.
#[must_use]
pub(super) fn collapse(root: &BuildNode, tris: &[[Vec3; 3]], ids: &[u32]) -> WideTree {
    let mut out = WideTree {
        nodes: Vec::new(),
        root: Slot { index: 0, count: 0 },
        packets: Vec::with_capacity(tris.len() / 2),
        max_depth: 0,
    };
    out.root = collapse_node(root, &mut out, tris, ids, 1);
    out
}

fn collapse_node(node: &BuildNode, out: &mut WideTree, tris: &[[Vec3; 3]], ids: &[u32], depth: u32) -> Slot {
    let children = match node {
        BuildNode::Leaf { start, count, .. } => {
            let first = out.packets.len() as u32;
            let (start, end) = (*start as usize, (*start + *count) as usize);
            let lane_data: Vec<([Vec3; 3], u32)> = (start..end).map(|i| (tris[i], ids[i])).collect();
            out.packets.extend(lane_data.chunks(LANES).map(Tri4::pack));
            return Slot {
                index: first,
                count: *count,
            };
        }
        BuildNode::Interior { children, .. } => children,
    };
    out.max_depth = out.max_depth.max(depth);
    let index = out.nodes.len();
    out.nodes.push(Node::EMPTY);
    // Adopt grandchildren while there is room: open the interior child with the largest area.
    // Opening in place keeps the lanes in spatial (split) order.
    let mut kids: Vec<&BuildNode> = vec![&children[0], &children[1]];
    while kids.len() < WIDTH {
        let widest = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| matches!(k, BuildNode::Interior { .. }))
            .max_by(|(_, a), (_, b)| a.bounds().surface_area().total_cmp(&b.bounds().surface_area()))
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let BuildNode::Interior { children: grand, .. } = kids[i] else {
            break;
        };
        kids[i] = &grand[1];
        kids.insert(i, &grand[0]);
    }
    for (lane, kid) in kids.into_iter().enumerate() {
        let slot = collapse_node(kid, out, tris, ids, depth + 1);
        out.nodes[index].set_lane(lane, kid.bounds(), slot);
    }
    Slot {
        index: index as u32,
        count: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_is_four_cache_lines() {
        assert_eq!(std::mem::size_of::<Node>(), 256);
        assert_eq!(std::mem::align_of::<Node>(), 64);
    }
}
