//! The flattened 4-wide node layout, and the collapse of the builder's binary tree into it.
//!
//! A binary SAH tree is collapsed top-down into a BVH4 (as in Embree's BVH4 and Wald et al. 2008,
//! "Getting Rid of Packets"): a node adopts its two children, then repeatedly opens the adopted
//! interior child with the largest surface area until it has four children or only leaves remain.
//! Child boxes are stored structure-of-arrays, one `[f32; 4]` per plane, so the slab test of all
//! four children is a handful of 4-wide operations that the compiler vectorises.

use super::build::BuildNode;
use crate::math::Aabb;

/// Children per node.
pub(super) const WIDTH: usize = 4;
/// `child` of an unused lane.
pub(super) const EMPTY_CHILD: u32 = u32::MAX;

/// A reference to a subtree: an interior node (`count == 0`, `index` into the node array) or a
/// leaf (`count > 0` triangles starting at `index` in leaf order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Slot {
    pub index: u32,
    pub count: u32,
}

/// One 4-wide node (128 bytes, two cache lines).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Node4 {
    /// `bounds[2·axis]` is the min plane along `axis` of each child, `bounds[2·axis + 1]` the max
    /// plane. Unused lanes hold the empty box (min = +∞, max = −∞), which no ray enters.
    pub bounds: [[f32; WIDTH]; 6],
    /// Per lane: the child node index, or the first triangle (leaf order) of a leaf.
    pub child: [u32; WIDTH],
    /// Per lane: 0 for an interior child (or an unused lane), else the leaf's triangle count.
    pub count: [u32; WIDTH],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY_CHILD; WIDTH],
        count: [0; WIDTH],
    };

    /// The box of lane `lane`.
    #[must_use]
    pub fn lane_bounds(&self, lane: usize) -> Aabb {
        let b = &self.bounds;
        Aabb { min: [b[0][lane], b[2][lane], b[4][lane]].into(), max: [b[1][lane], b[3][lane], b[5][lane]].into() }
    }

    /// Whether lane `lane` holds a child.
    #[must_use]
    pub fn lane_used(&self, lane: usize) -> bool {
        self.child[lane] != EMPTY_CHILD
    }

    /// The child in lane `lane`.
    #[must_use]
    pub fn lane_slot(&self, lane: usize) -> Slot {
        Slot { index: self.child[lane], count: self.count[lane] }
    }

    fn set_lane(&mut self, lane: usize, bounds: Aabb, slot: Slot) {
        for axis in 0..3 {
            self.bounds[2 * axis][lane] = bounds.min[axis];
            self.bounds[2 * axis + 1][lane] = bounds.max[axis];
        }
        self.child[lane] = slot.index;
        self.count[lane] = slot.count;
    }
}

/// The collapsed tree: the node array (root first when the root is interior) and the root slot.
pub(super) struct WideTree {
    pub nodes: Vec<Node4>,
    pub root: Slot,
    /// Interior nodes on the longest root-to-leaf path (0 when the root is a leaf).
    pub max_depth: u32,
}

/// Collapses the binary tree into a BVH4 (children of every node adopted by largest area first).
#[must_use]
pub(super) fn collapse(root: &BuildNode) -> WideTree {
    let mut nodes = Vec::new();
    let mut max_depth = 0;
    let root = collapse_node(root, &mut nodes, 1, &mut max_depth);
    WideTree { nodes, root, max_depth }
}

fn collapse_node(node: &BuildNode, nodes: &mut Vec<Node4>, depth: u32, max_depth: &mut u32) -> Slot {
    let children = match node {
        BuildNode::Leaf { start, count, .. } => return Slot { index: *start, count: *count },
        BuildNode::Interior { children, .. } => children,
    };
    *max_depth = (*max_depth).max(depth);
    let index = nodes.len();
    nodes.push(Node4::EMPTY);
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
        let BuildNode::Interior { children: grand, .. } = kids[i] else { break };
        kids[i] = &grand[1];
        kids.insert(i, &grand[0]);
    }
    for (lane, kid) in kids.into_iter().enumerate() {
        let slot = collapse_node(kid, nodes, depth + 1, max_depth);
        nodes[index].set_lane(lane, kid.bounds(), slot);
    }
    Slot { index: index as u32, count: 0 }
}
