//! The depth-first output of a (sub)tree build: nodes, leaf records, leaf-ordered triangle ids,
//! the stitching of subtrees built in parallel, and the leaves' triangle blocks.

#[cfg(feature = "parallel")]
use std::ops::Range;

use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, Triangle, TriangleBlock};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::{pages, LeafRecord, Node, MAX_NODE_INDEX};
use crate::{Error, Result};

/// Leaf record 0 of every tree: the record all empty leaves share.
pub(super) const EMPTY_RECORD: LeafRecord = LeafRecord {
    first: 0,
    count: 0,
    bounds: Aabb::EMPTY,
};

/// A subtree in depth-first order. Leaf nodes refer to their record in `records`, whose first
/// is the empty leaves' [`EMPTY_RECORD`], as in the tree.
///
/// Subtrees built by other threads are appended without being copied ([`Layout::append`]):
/// they are kept as [`Piece`]s, and the layout's indices count their nodes, records and ids
/// as if they were in place (its *virtual* arrays: its own, with the pieces between). The
/// whole tree is copied once, in parallel, when it is finished ([`Layout::finish_into`]),
/// rather than each subtree into its parent's layout at every level.
#[derive(Debug)]
pub(super) struct Layout {
    nodes: Vec<Node>,
    records: Vec<LeafRecord>,
    ids: Vec<u32>,
    max_depth: u32,
    /// The subtrees appended, in order.
    #[cfg(feature = "parallel")]
    pieces: Vec<Piece>,
    /// The pieces' nodes, records (empty record aside) and ids.
    #[cfg(feature = "parallel")]
    in_pieces: Counts,
    /// The whole tree's ids when it was built in pieces, kept for the next build.
    #[cfg(feature = "parallel")]
    finished_ids: Vec<u32>,
}

/// Lengths of, or positions in, a layout's three arrays.
#[cfg(feature = "parallel")]
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    nodes: usize,
    records: usize,
    ids: usize,
}

#[cfg(feature = "parallel")]
impl Counts {
    fn plus(self, other: Counts) -> Counts {
        Counts {
            nodes: self.nodes + other.nodes,
            records: self.records + other.records,
            ids: self.ids + other.ids,
        }
    }
}

/// A subtree appended to a layout: it goes after the layout's own first `at` nodes, records
/// and ids, and its indices shift by `offset`, the virtual arrays' lengths when it was
/// appended (records by one less: the empty record is shared).
#[cfg(feature = "parallel")]
#[derive(Debug)]
struct Piece {
    layout: Layout,
    at: Counts,
    offset: Counts,
}

/// A run of one layout's own nodes, records and ids, in the finished tree at `to`, its
/// indices shifted by `shift`.
#[cfg(feature = "parallel")]
struct Run<'a> {
    layout: &'a Layout,
    nodes: Range<usize>,
    records: Range<usize>,
    ids: Range<usize>,
    shift: Counts,
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
            #[cfg(feature = "parallel")]
            pieces: Vec::new(),
            #[cfg(feature = "parallel")]
            in_pieces: Counts::default(),
            #[cfg(feature = "parallel")]
            finished_ids: Vec::new(),
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
        let record = u32::try_from(self.virtual_records())
            .ok()
            .filter(|&r| r <= MAX_NODE_INDEX)
            .ok_or_else(|| too_big("leaves"))?;
        let first =
            u32::try_from(self.virtual_ids()).map_err(|_| too_big("triangle references"))?;
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

    /// The length of the virtual node array (own nodes and pieces').
    #[inline]
    fn virtual_nodes(&self) -> usize {
        #[cfg(feature = "parallel")]
        return self.nodes.len() + self.in_pieces.nodes;
        #[cfg(not(feature = "parallel"))]
        self.nodes.len()
    }

    /// The length of the virtual record array (own records, the empty one, and pieces').
    #[inline]
    fn virtual_records(&self) -> usize {
        #[cfg(feature = "parallel")]
        return self.records.len() + self.in_pieces.records;
        #[cfg(not(feature = "parallel"))]
        self.records.len()
    }

    /// The length of the virtual id array (own ids and pieces').
    #[inline]
    fn virtual_ids(&self) -> usize {
        #[cfg(feature = "parallel")]
        return self.ids.len() + self.in_pieces.ids;
        #[cfg(not(feature = "parallel"))]
        self.ids.len()
    }

    /// Reserves the slot of an inner node whose below child follows; returns its index among
    /// this layout's own nodes, for [`Layout::close_inner`].
    pub fn open_inner(&mut self) -> usize {
        self.nodes.push(Node::leaf(0));
        self.nodes.len() - 1
    }

    /// Fills the inner node reserved at `at`: its above child is the next node appended.
    pub fn close_inner(&mut self, at: usize, axis: usize, split: f32) -> Result<()> {
        let above = u32::try_from(self.virtual_nodes())
            .ok()
            .filter(|&a| a <= MAX_NODE_INDEX)
            .ok_or_else(|| too_big("nodes"))?;
        self.nodes[at] = Node::inner(axis, split, above);
        Ok(())
    }

    /// Appends subtree `other` as a piece, to be copied in, its node, record and triangle
    /// indices shifted, when the tree is finished (its empty record is this one's).
    #[cfg(feature = "parallel")]
    pub fn append(&mut self, other: Layout) -> Result<()> {
        let offset = Counts {
            nodes: self.virtual_nodes(),
            records: self.virtual_records() - 1,
            ids: self.virtual_ids(),
        };
        let size = Counts {
            nodes: other.virtual_nodes(),
            records: other.virtual_records() - 1,
            ids: other.virtual_ids(),
        };
        // Every index in `other` is below its lengths, so these bound the shifted ones.
        let end = offset.plus(size);
        if end.nodes > MAX_NODE_INDEX as usize + 1 {
            return Err(too_big("nodes"));
        }
        if end.records > MAX_NODE_INDEX as usize {
            return Err(too_big("leaves"));
        }
        if u32::try_from(end.ids).is_err() {
            return Err(too_big("triangle references"));
        }
        self.max_depth = self.max_depth.max(other.max_depth);
        let at = Counts {
            nodes: self.nodes.len(),
            records: self.records.len(),
            ids: self.ids.len(),
        };
        self.in_pieces = self.in_pieces.plus(size);
        self.pieces.push(Piece {
            layout: other,
            at,
            offset,
        });
        Ok(())
    }

    /// Lists the runs of this layout's own arrays and, between them, its pieces', in the
    /// finished tree's order, for a layout whose indices shift by `shift` there.
    #[cfg(feature = "parallel")]
    fn runs<'a>(&'a self, shift: Counts, out: &mut Vec<Run<'a>>) {
        // Own records from 1: the empty record is the tree's first.
        let mut from = Counts {
            records: 1,
            ..Counts::default()
        };
        let own_run = |from: Counts, to: Counts, out: &mut Vec<Run<'a>>| {
            out.push(Run {
                layout: self,
                nodes: from.nodes..to.nodes,
                records: from.records..to.records,
                ids: from.ids..to.ids,
                shift,
            });
        };
        for piece in &self.pieces {
            own_run(from, piece.at, out);
            piece.layout.runs(shift.plus(piece.offset), out);
            from = piece.at;
        }
        let end = Counts {
            nodes: self.nodes.len(),
            records: self.records.len(),
            ids: self.ids.len(),
        };
        own_run(from, end, out);
    }

    /// Empties the layout, keeping its buffers.
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.records.clear();
        self.records.push(EMPTY_RECORD);
        self.ids.clear();
        self.max_depth = 0;
        #[cfg(feature = "parallel")]
        {
            self.pieces.clear();
            self.in_pieces = Counts::default();
        }
    }

    /// Makes room for the tree of `triangles` triangles as most meshes need it: about two
    /// nodes, two references and half a non-empty leaf per triangle (architectural scenes need
    /// more, and grow). Growing a long array would copy it into new pages,
    /// and each page's first write is a page fault. Address space only: pages (huge ones where
    /// the kernel gives them, [`pages`]) are touched as used.
    pub fn reserve_for(&mut self, triangles: usize) {
        pages::reserve(&mut self.nodes, 2 * triangles);
        pages::reserve(&mut self.records, triangles / 2);
        pages::reserve(&mut self.ids, 3 * triangles);
    }

    /// Moves the final nodes and records into a tree's, swapping them (the layout keeps the
    /// tree's old buffers for its next build), or, when subtrees were appended, copies the
    /// layout and its pieces into them, in parallel; then writes each leaf's triangles
    /// (`triangles`: the mesh's, by id) into `blocks`, a run of [`TriangleBlock`]s per leaf,
    /// each record's `first` becoming its first block. Returns the depth of the deepest leaf
    /// and the number of triangle references.
    pub fn finish_into(
        &mut self,
        nodes: &mut Vec<Node>,
        leaves: &mut Vec<LeafRecord>,
        blocks: &mut Vec<TriangleBlock>,
        triangles: &[Triangle],
    ) -> (u32, usize) {
        #[cfg(feature = "parallel")]
        if !self.pieces.is_empty() {
            let mut ids = std::mem::take(&mut self.finished_ids);
            self.copy_into(nodes, leaves, &mut ids);
            write_blocks(leaves, &ids, blocks, triangles);
            let refs = ids.len();
            self.finished_ids = ids;
            return (self.max_depth, refs);
        }
        std::mem::swap(nodes, &mut self.nodes);
        std::mem::swap(leaves, &mut self.records);
        write_blocks(leaves, &self.ids, blocks, triangles);
        (self.max_depth, self.ids.len())
    }

    /// Copies the whole virtual arrays into `nodes`, `leaves` and `ids`, their runs in
    /// parallel, each index shifted to its place.
    #[cfg(feature = "parallel")]
    fn copy_into(&self, nodes: &mut Vec<Node>, leaves: &mut Vec<LeafRecord>, ids: &mut Vec<u32>) {
        let mut runs = Vec::new();
        self.runs(Counts::default(), &mut runs);
        // Written twice (zeroed, then copied), so that the pages are faulted in by every
        // thread, not just this one.
        pages::zeroed(nodes, self.virtual_nodes(), Node::leaf(0));
        pages::zeroed(leaves, self.virtual_records(), EMPTY_RECORD);
        pages::zeroed(ids, self.virtual_ids(), 0);
        let mut places = Vec::with_capacity(runs.len());
        let (mut nodes_left, mut leaves_left, mut ids_left) =
            (&mut nodes[..], &mut leaves[1..], &mut ids[..]);
        for run in &runs {
            let (n, rest) = std::mem::take(&mut nodes_left).split_at_mut(run.nodes.len());
            nodes_left = rest;
            let (r, rest) = std::mem::take(&mut leaves_left).split_at_mut(run.records.len());
            leaves_left = rest;
            let (i, rest) = std::mem::take(&mut ids_left).split_at_mut(run.ids.len());
            ids_left = rest;
            places.push((n, r, i));
        }
        runs.par_iter()
            .zip(places)
            .for_each(|(run, (nodes, leaves, ids))| run.copy_to(nodes, leaves, ids));
    }
}

#[cfg(feature = "parallel")]
impl Run<'_> {
    /// Copies the run into its places in the finished arrays, shifting its indices.
    fn copy_to(&self, nodes: &mut [Node], leaves: &mut [LeafRecord], ids: &mut [u32]) {
        // The shifts fit: [`Layout::append`] checked the pieces' ends.
        let (node_shift, record_shift, id_shift) = (
            self.shift.nodes as u32,
            self.shift.records as u32,
            self.shift.ids as u32,
        );
        let layout = self.layout;
        for (to, &node) in nodes.iter_mut().zip(&layout.nodes[self.nodes.clone()]) {
            *to = if !node.is_leaf() {
                Node::inner(node.axis(), node.split(), node.above_child() + node_shift)
            } else if node.leaf_record() == 0 {
                node
            } else {
                Node::leaf(node.leaf_record() + record_shift)
            };
        }
        for (to, record) in leaves.iter_mut().zip(&layout.records[self.records.clone()]) {
            *to = LeafRecord {
                first: record.first + id_shift,
                ..*record
            };
        }
        ids.copy_from_slice(&layout.ids[self.ids.clone()]);
    }
}

/// Writes the triangles of every leaf of `leaves` (record 0 is the empty leaves') into `blocks`,
/// a run of [`TriangleBlock`]s per leaf, from the leaf-ordered mesh ids `ids` that each record's
/// `first` indexes; `first` becomes the leaf's first block. The blocks are written in parallel
/// (with the `parallel` feature): they are most of a tree's bytes, and on one thread their
/// writing and page faults are a serial tail of a parallel build.
fn write_blocks(
    leaves: &mut [LeafRecord],
    ids: &[u32],
    blocks: &mut Vec<TriangleBlock>,
    triangles: &[Triangle],
) {
    // Each block's ids (a run of `ids`) and its leaf's first id, whose triangle's first vertex
    // pads it.
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    for record in leaves.iter_mut().skip(1) {
        let (first, end) = (record.first, record.first + record.count);
        // Block indices fit: there are no more blocks than triangle references.
        record.first = runs.len() as u32;
        let mut start = first;
        while start < end {
            let len = (end - start).min(BLOCK as u32);
            runs.push((first, start, len));
            start += len;
        }
    }
    let block = |&(leaf_first, start, len): &(u32, u32, u32)| {
        let pad = triangles[ids[leaf_first as usize] as usize].v0;
        let run = &ids[start as usize..(start + len) as usize];
        TriangleBlock::new(pad, run.iter().map(|&id| (triangles[id as usize], id)))
    };
    blocks.clear();
    pages::reserve(blocks, runs.len());
    #[cfg(feature = "parallel")]
    blocks.par_extend(runs.par_iter().map(block));
    #[cfg(not(feature = "parallel"))]
    blocks.extend(runs.iter().map(block));
}
