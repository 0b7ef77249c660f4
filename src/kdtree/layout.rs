//! The depth-first output of a (sub)tree build: nodes, leaf records, leaf-ordered triangle ids,
//! the stitching of two subtrees built in parallel, and the leaves' triangle blocks.

use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, Triangle, TriangleBlock};

use super::{LeafRecord, Node, MAX_NODE_INDEX};
use crate::{Error, Result};

/// Leaf record 0 of every tree: the record all empty leaves share.
pub(super) const EMPTY_RECORD: LeafRecord = LeafRecord {
    first: 0,
    count: 0,
    bounds: Aabb::EMPTY,
};

/// A subtree in depth-first order. Leaf nodes refer to their record in `records`, whose first
/// is the empty leaves' [`EMPTY_RECORD`], as in the tree.
#[derive(Debug)]
pub(super) struct Layout {
    nodes: Vec<Node>,
    records: Vec<LeafRecord>,
    ids: Vec<u32>,
    max_depth: u32,
}

fn too_big(what: &str) -> Error {
    Error::InvalidParameter {
        name: "max_depth",
        message: format!("the tree would need more {what} than its 32-bit layout holds; lower max_depth or ci_over_ct"),
    }
}

impl Default for Layout {
    fn default() -> Self {
        Layout {
            nodes: Vec::new(),
            records: vec![EMPTY_RECORD],
            ids: Vec::new(),
            max_depth: 0,
        }
    }
}

impl Layout {
    /// Appends an empty leaf at `depth`.
    pub fn push_empty_leaf(&mut self, depth: u32) {
        self.max_depth = self.max_depth.max(depth);
        self.nodes.push(Node::leaf(0));
    }

    /// Appends a leaf at `depth` holding `ids` (in the order given) inside `bounds`.
    pub fn push_leaf(
        &mut self,
        depth: u32,
        ids: impl ExactSizeIterator<Item = u32>,
        bounds: Aabb,
    ) -> Result<()> {
        let record = u32::try_from(self.records.len())
            .ok()
            .filter(|&r| r <= MAX_NODE_INDEX)
            .ok_or_else(|| too_big("leaves"))?;
        let first = u32::try_from(self.ids.len()).map_err(|_| too_big("triangle references"))?;
        let count = u32::try_from(ids.len()).map_err(|_| too_big("triangle references"))?;
        first
            .checked_add(count)
            .ok_or_else(|| too_big("triangle references"))?;
        self.max_depth = self.max_depth.max(depth);
        self.ids.extend(ids);
        self.records.push(LeafRecord {
            first,
            count,
            bounds,
        });
        self.nodes.push(Node::leaf(record));
        Ok(())
    }

    /// Reserves the slot of an inner node whose below child follows; returns its index for
    /// [`Layout::close_inner`].
    pub fn open_inner(&mut self) -> usize {
        self.nodes.push(Node::leaf(0));
        self.nodes.len() - 1
    }

    /// Fills the inner node reserved at `at`: its above child is the next node appended.
    pub fn close_inner(&mut self, at: usize, axis: usize, split: f32) -> Result<()> {
        let above = u32::try_from(self.nodes.len())
            .ok()
            .filter(|&a| a <= MAX_NODE_INDEX)
            .ok_or_else(|| too_big("nodes"))?;
        self.nodes[at] = Node::inner(axis, split, above);
        Ok(())
    }

    /// Appends subtree `other`, shifting its node, record and triangle indices (its empty
    /// record is this one's).
    #[cfg(feature = "parallel")]
    pub fn append(&mut self, other: Layout) -> Result<()> {
        let node_offset = u32::try_from(self.nodes.len()).map_err(|_| too_big("nodes"))?;
        let record_offset = u32::try_from(self.records.len() - 1).map_err(|_| too_big("leaves"))?;
        let id_offset =
            u32::try_from(self.ids.len()).map_err(|_| too_big("triangle references"))?;
        let shift = |index: u32, offset: u32| {
            index
                .checked_add(offset)
                .filter(|&i| i <= MAX_NODE_INDEX)
                .ok_or_else(|| too_big("nodes"))
        };
        self.nodes.reserve(other.nodes.len());
        for node in other.nodes {
            self.nodes.push(if !node.is_leaf() {
                Node::inner(
                    node.axis(),
                    node.split(),
                    shift(node.above_child(), node_offset)?,
                )
            } else if node.leaf_record() == 0 {
                node
            } else {
                Node::leaf(shift(node.leaf_record(), record_offset)?)
            });
        }
        self.records.reserve(other.records.len() - 1);
        for record in other.records.into_iter().skip(1) {
            let first = record
                .first
                .checked_add(id_offset)
                .filter(|f| f.checked_add(record.count).is_some())
                .ok_or_else(|| too_big("triangle references"))?;
            self.records.push(LeafRecord { first, ..record });
        }
        self.ids.extend_from_slice(&other.ids);
        self.max_depth = self.max_depth.max(other.max_depth);
        Ok(())
    }

    /// Empties the layout, keeping its buffers.
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.records.clear();
        self.records.push(EMPTY_RECORD);
        self.ids.clear();
        self.max_depth = 0;
    }

    /// Makes room for the tree of `triangles` triangles as most meshes need it: about two
    /// nodes, two references and half a non-empty leaf per triangle (architectural scenes need
    /// more, and grow). Growing a long array would copy it into new pages,
    /// and each page's first write is a page fault. Address space only: pages are touched as
    /// used.
    pub fn reserve_for(&mut self, triangles: usize) {
        self.nodes.reserve(2 * triangles);
        self.records.reserve(triangles / 2);
        self.ids.reserve(3 * triangles);
    }

    /// Moves the final nodes and records into a tree's, swapping them (the layout keeps the
    /// tree's old buffers for its next build), and writes each leaf's triangles (`triangles`:
    /// the mesh's, by id) into `blocks`, a run of [`TriangleBlock`]s per leaf, each record's
    /// `first` becoming its first block. Returns the depth of the deepest leaf and the number
    /// of triangle references.
    pub fn finish_into(
        &mut self,
        nodes: &mut Vec<Node>,
        leaves: &mut Vec<LeafRecord>,
        blocks: &mut Vec<TriangleBlock>,
        triangles: &[Triangle],
    ) -> (u32, usize) {
        std::mem::swap(nodes, &mut self.nodes);
        std::mem::swap(leaves, &mut self.records);
        blocks.clear();
        blocks.reserve(
            leaves
                .iter()
                .map(|r| (r.count as usize).div_ceil(BLOCK))
                .sum(),
        );
        for record in leaves.iter_mut().skip(1) {
            let run = record.first as usize..(record.first + record.count) as usize;
            // Block indices fit: there are no more blocks than triangle references.
            record.first = blocks.len() as u32;
            let ids = &self.ids[run];
            let Some(&id0) = ids.first() else { continue };
            let pad = triangles[id0 as usize].v0;
            for chunk in ids.chunks(BLOCK) {
                let lanes = chunk.iter().map(|&id| (triangles[id as usize], id));
                blocks.push(TriangleBlock::new(pad, lanes));
            }
        }
        (self.max_depth, self.ids.len())
    }
}
