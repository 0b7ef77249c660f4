//! The 8-byte kd-tree node.

/// One kd-tree node in 8 bytes.
///
/// Nodes are stored depth first: an inner node's *below* child (coordinates `< split` on its
/// axis) is the next node, its *above* child is at [`Node::above_child`]. The low two bits of the
/// first word are the axis (0, 1, 2) or 3 for a leaf; the other 30 bits hold the above child's
/// index or the leaf's record index. The second word is the split coordinate's bits (inner) or 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Node {
    word: u32,
    split_bits: u32,
}

const LEAF: u32 = 3;

/// Largest index a node can hold in its 30 bits.
pub const MAX_NODE_INDEX: u32 = (1 << 30) - 1;

impl Node {
    /// An inner node splitting `axis` at `split`; its above child is node `above_child`.
    /// Panics if `axis > 2` or `above_child > MAX_NODE_INDEX` (the builder checks first).
    #[inline]
    #[must_use]
    pub fn inner(axis: usize, split: f32, above_child: u32) -> Node {
        assert!(axis < 3 && above_child <= MAX_NODE_INDEX);
        Node {
            word: (above_child << 2) | axis as u32,
            split_bits: split.to_bits(),
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
        self.word >> 2
    }

    /// The leaf record index of a leaf.
    #[inline(always)]
    #[must_use]
    pub fn leaf_record(self) -> u32 {
        self.word >> 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_is_eight_bytes_and_round_trips() {
        assert_eq!(core::mem::size_of::<Node>(), 8);
        let n = Node::inner(2, -1.5, 12345);
        assert!(!n.is_leaf());
        assert_eq!((n.axis(), n.split(), n.above_child()), (2, -1.5, 12345));
        let l = Node::leaf(MAX_NODE_INDEX);
        assert!(l.is_leaf());
        assert_eq!(l.leaf_record(), MAX_NODE_INDEX);
    }
}
