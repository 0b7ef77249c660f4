//! The 8-byte kd-tree node.

use super::LeafRecord;

/// One kd-tree node in 8 bytes.
///
/// Nodes are stored depth first: an inner node's *below* child (coordinates `< split` on its
/// axis) is the next node, its *above* child is at [`Node::above_child`]. The low two bits of the
/// first word are the axis (0, 1, 2) or 3 for a leaf. A leaf's other 30 bits hold its record
/// index. An inner node's bits 2 and 3 say that its below or above child is an empty leaf
/// ([`Node::with_empty_children`]), so that a traversal need not step into it, and its top 28
/// bits hold the above child's index. The second word is the split coordinate's bits (inner) or 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Node {
    word: u32,
    split_bits: u32,
}

const LEAF: u32 = 3;
const BELOW_EMPTY: u32 = 1 << 2;
const ABOVE_EMPTY: u32 = 1 << 3;
const INDEX_SHIFT: u32 = 4;

/// Largest node or leaf record index a node can hold (28 bits).
pub const MAX_NODE_INDEX: u32 = (1 << 28) - 1;

impl Node {
    /// An inner node splitting `axis` at `split`; its above child is node `above_child`, and
    /// neither child is marked empty. Panics if `axis > 2` or `above_child > MAX_NODE_INDEX`
    /// (the builder checks first).
    #[inline]
    #[must_use]
    pub fn inner(axis: usize, split: f32, above_child: u32) -> Node {
        assert!(axis < 3 && above_child <= MAX_NODE_INDEX);
        Node {
            word: (above_child << INDEX_SHIFT) | axis as u32,
            split_bits: split.to_bits(),
        }
    }

    /// This inner node with its children marked empty (or not) as `below` and `above` say: a
    /// marked child is an empty leaf, which no traversal needs to enter.
    #[inline]
    #[must_use]
    pub fn with_empty_children(self, below: bool, above: bool) -> Node {
        debug_assert!(!self.is_leaf());
        let flags = (u32::from(below) * BELOW_EMPTY) | (u32::from(above) * ABOVE_EMPTY);
        Node {
            word: (self.word & !(BELOW_EMPTY | ABOVE_EMPTY)) | flags,
            ..self
        }
    }

    /// A leaf whose triangles are described by leaf record `record`.
    #[inline]
    #[must_use]
    pub fn leaf(record: u32) -> Node {
        assert!(record <= MAX_NODE_INDEX);
        Node {
            word: (record << 2) | LEAF,
            split_bits: 0,
        }
    }

    /// Is this a leaf?
    #[inline(always)]
    #[must_use]
    pub fn is_leaf(self) -> bool {
        self.word & 3 == LEAF
    }

    /// The split axis of an inner node (3 for a leaf).
    #[inline(always)]
    #[must_use]
    pub fn axis(self) -> usize {
        (self.word & 3) as usize
    }

    /// The split coordinate of an inner node.
    #[inline(always)]
    #[must_use]
    pub fn split(self) -> f32 {
        f32::from_bits(self.split_bits)
    }

    /// The index of an inner node's above child (its below child is the next node).
    #[inline(always)]
    #[must_use]
    pub fn above_child(self) -> u32 {
        self.word >> INDEX_SHIFT
    }

    /// Whether an inner node's (below, above) children are marked as empty leaves: `false` for
    /// a child not marked, even if it is one.
    #[inline(always)]
    #[must_use]
    pub fn empty_children(self) -> (bool, bool) {
        (self.word & BELOW_EMPTY != 0, self.word & ABOVE_EMPTY != 0)
    }

    /// An inner node's children, nearer first for rays whose direction on its axis is negative
    /// (`above_first`) or not: each as its index (this node being `index`) and whether it is
    /// marked as an empty leaf ([`Node::empty_children`]).
    #[inline(always)]
    #[must_use]
    pub fn children_in_order(self, index: u32, above_first: bool) -> [(u32, bool); 2] {
        let (below_empty, above_empty) = self.empty_children();
        let (below, above) = ((index + 1, below_empty), (self.above_child(), above_empty));
        if above_first {
            [above, below]
        } else {
            [below, above]
        }
    }

    /// The leaf record index of a leaf.
    #[inline(always)]
    #[must_use]
    pub fn leaf_record(self) -> u32 {
        self.word >> 2
    }
}

/// Marks every inner node's children that are empty leaves ([`Node::with_empty_children`]).
///
/// The SAH cuts empty space off in leaves of their own, most of a tree's leaves; a traversal
/// that knows them from the parent skips the step into each and the pop after it.
pub(crate) fn mark_empty_children(nodes: &mut [Node], leaves: &[LeafRecord]) {
    let is_empty = |node: Node| node.is_leaf() && leaves[node.leaf_record() as usize].count == 0;
    for i in 0..nodes.len() {
        let node = nodes[i];
        if !node.is_leaf() {
            let (below, above) = (nodes[i + 1], nodes[node.above_child() as usize]);
            nodes[i] = node.with_empty_children(is_empty(below), is_empty(above));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_is_eight_bytes_and_round_trips() {
        assert_eq!(core::mem::size_of::<Node>(), 8);
        let n = Node::inner(2, -1.5, MAX_NODE_INDEX);
        assert!(!n.is_leaf());
        assert_eq!(
            (n.axis(), n.split(), n.above_child()),
            (2, -1.5, MAX_NODE_INDEX)
        );
        assert_eq!(n.empty_children(), (false, false));
        for (below, above) in [(true, false), (false, true), (true, true)] {
            let m = n.with_empty_children(below, above);
            assert_eq!(m.empty_children(), (below, above));
            assert_eq!(
                (m.axis(), m.split(), m.above_child()),
                (2, -1.5, MAX_NODE_INDEX)
            );
            assert_eq!(m.with_empty_children(false, false), n);
            assert_eq!(
                m.children_in_order(7, true),
                [(MAX_NODE_INDEX, above), (8, below)]
            );
            assert_eq!(
                m.children_in_order(7, false),
                [(8, below), (MAX_NODE_INDEX, above)]
            );
        }
        let l = Node::leaf(MAX_NODE_INDEX);
        assert!(l.is_leaf());
        assert_eq!(l.leaf_record(), MAX_NODE_INDEX);
    }

    #[test]
    fn empty_children_are_marked_from_their_leaf_records() {
        use crate::kdtree::Aabb;
        let record = |count| LeafRecord {
            first: 0,
            count,
            bounds: Aabb::EMPTY,
        };
        // Root splits at 0.5; its below child splits again into an empty and a full leaf; its
        // above child is empty.
        let mut nodes = [
            Node::inner(0, 0.5, 4),
            Node::inner(1, 0.5, 3),
            Node::leaf(0),
            Node::leaf(1),
            Node::leaf(0),
        ];
        mark_empty_children(&mut nodes, &[record(0), record(3)]);
        assert_eq!(nodes[0].empty_children(), (false, true));
        assert_eq!(nodes[1].empty_children(), (true, false));
        assert_eq!(nodes[0].above_child(), 4);
        assert_eq!(nodes[1].above_child(), 3);
    }
}
