//! The work inside one large node, in parallel chunks of its references: the root's references,
//! a node's union and bins, and its split.
//!
//! `rayon::join` on the children parallelises a tree below its top levels only: the root's
//! binning and classification read every triangle on one thread while the others wait, and so,
//! with more threads, do the levels below it. So nodes of more than [`PARALLEL_NODE_MIN`]
//! references bin in chunks on every thread, and those that also hold more than twice a
//! thread's share of the root's references (`Context::chunked_min`) split in chunks: below
//! that, every thread is busy with a subtree of its own, and the chunked split's extra passes
//! (counting, then writing, then moving the below child's references into place) only cost.
//! Each chunk's result is put where the one-thread build puts it: the bins' counts are
//! integers summed, the unions minima and maxima, and the children's references are written in
//! the node's order, so the tree is the same with any number of threads.

use bytemuck::Zeroable;
use kdbeam_kernels::{Aabb, Triangle};
use rayon::prelude::*;

use super::classify::sides_of;
use super::recurse::union_of;
use super::stack::{reserve_stack, STACK_PER_TRIANGLE};
use super::{BoxNode, Context, Scratch};
use crate::kdtree::clip::split_clipped_bounds;
use crate::kdtree::events::unkey;
use crate::kdtree::refs::Ref;
use crate::kdtree::sah::{BinCounts, Bins, Split};

/// Nodes with more references than this bin and split them in parallel chunks.
pub(super) const PARALLEL_NODE_MIN: usize = 1 << 16;

/// References per chunk: enough to make a chunk's overhead (a task, its counts) negligible.
const CHUNK: usize = 1 << 13;

/// Appends the references of `triangles` (ids `0..`, vertex boxes) to `refs`, whose capacity
/// holds them, in parallel; returns their union.
pub(super) fn push_root_refs(triangles: &[Triangle], refs: &mut Vec<Ref>) -> Aabb {
    let first = refs.len();
    refs.par_extend(
        triangles
            .par_iter()
            .enumerate()
            .map(|(id, t)| Ref::new(id as u32, &Aabb::from_points([t.v0, t.v1, t.v2]))),
    );
    union_in_parallel(&refs[first..])
}

/// The union of the boxes of `refs`, in parallel chunks.
pub(super) fn union_in_parallel(refs: &[Ref]) -> Aabb {
    refs.par_chunks(CHUNK)
        .map(union_of)
        .reduce(|| Aabb::EMPTY, |a, b| a.union(b))
}

/// [`Bins::new`], counting the boxes in parallel chunks.
pub(super) fn bins_in_parallel(refs: &[Ref], union: Aabb) -> Bins {
    let counts = refs
        .par_chunks(CHUNK)
        .map(|chunk| BinCounts::of(chunk, &union))
        .reduce(|| BinCounts::ZERO, |a, b| a.add(&b));
    Bins::from_counts(&counts, refs.len(), union)
}

/// The sides of one chunk of a node's references: how many lie below and above only, and the
/// clipped parts of those straddling the plane.
#[derive(Default)]
struct ChunkSides {
    below: usize,
    above: usize,
    clipped_below: Vec<Ref>,
    clipped_above: Vec<Ref>,
}

/// [`split_boxes`](super::classify::split_boxes) in parallel chunks, but for where the above
/// child's references go: onto the stack `above` (emptied first), for the thread that builds
/// it (its references are `0..` there). The below child's take the node's place on
/// `scratch.refs`, and both hold the same references in the same order as with `split_boxes`.
pub(super) fn split_boxes_apart(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
    above: &mut Vec<Ref>,
) -> (BoxNode, BoxNode) {
    match split.axis {
        0 => split_apart_on::<0>(context, node, split, scratch, above),
        1 => split_apart_on::<1>(context, node, split, scratch, above),
        _ => split_apart_on::<2>(context, node, split, scratch, above),
    }
}

/// [`split_boxes_apart`] on axis `AXIS` (`split.axis`).
fn split_apart_on<const AXIS: usize>(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
    above: &mut Vec<Ref>,
) -> (BoxNode, BoxNode) {
    let p = unkey(split.pos_key);
    let (mut below_cell, mut above_cell) = (node.cell, node.cell);
    below_cell.max[AXIS] = p;
    above_cell.min[AXIS] = p;
    let side = |r: &Ref| {
        let (lo, hi) = (r.lo()[AXIS], r.hi()[AXIS]);
        sides_of(lo, hi, p, split.planar_below)
    };
    // First the counts, so that each chunk knows where its references go, and the clipped
    // parts of the straddling triangles (few, and the costly part to compute twice).
    let chunks: Vec<ChunkSides> = scratch.refs[node.refs.clone()]
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut sides = ChunkSides::default();
            for r in chunk {
                let (below, above) = side(r);
                sides.below += usize::from(below);
                sides.above += usize::from(above);
                if !below && !above {
                    let tri = &context.triangles[r.id() as usize];
                    let [below_part, above_part] = split_clipped_bounds::<AXIS>(tri, &node.cell, p);
                    if let Some(part) = below_part {
                        sides.clipped_below.push(Ref::new(r.id(), &part));
                    }
                    if let Some(part) = above_part {
                        sides.clipped_above.push(Ref::new(r.id(), &part));
                    }
                }
            }
            sides
        })
        .collect();
    let below_len = chunks.iter().map(|c| c.below + c.clipped_below.len()).sum();
    let above_len = chunks.iter().map(|c| c.above + c.clipped_above.len()).sum();
    // The below child's references are written above the stack's top, then moved to the
    // node's place: no new array, whose pages would be faulted in afresh.
    let top = scratch.top;
    let stack = &mut scratch.refs;
    if stack.len() < top + below_len {
        reserve_stack(stack, top + below_len);
        let more = top + below_len - stack.len();
        stack.par_extend(rayon::iter::repeat_n(Ref::zeroed(), more));
    }
    above.clear();
    reserve_stack(above, STACK_PER_TRIANGLE * above_len);
    above.par_extend(rayon::iter::repeat_n(Ref::zeroed(), above_len));
    let (lower, upper) = stack.split_at_mut(top);
    let (refs, below) = (&lower[node.refs.clone()], &mut upper[..below_len]);
    // As `split_boxes` orders them: the one-sided references in the node's order, then the
    // clipped ones in the order of their triangles' references.
    let below_parts = chunk_destinations(below, &chunks, |c| (c.below, &c.clipped_below));
    let above_parts = chunk_destinations(above, &chunks, |c| (c.above, &c.clipped_above));
    refs.par_chunks(CHUNK)
        .zip(chunks.par_iter())
        .zip(below_parts.into_par_iter().zip(above_parts))
        .for_each(
            |((chunk, sides), ((below, below_clipped), (above, above_clipped)))| {
                let (mut b, mut a) = (0, 0);
                for r in chunk {
                    match side(r) {
                        (true, _) => {
                            below[b] = *r;
                            b += 1;
                        }
                        (_, true) => {
                            above[a] = *r;
                            a += 1;
                        }
                        _ => {}
                    }
                }
                below_clipped.copy_from_slice(&sides.clipped_below);
                above_clipped.copy_from_slice(&sides.clipped_above);
            },
        );
    // The below child's references take the node's place (each reference has at most one
    // part below, so they fit).
    let first = node.refs.start;
    lower[first..first + below_len]
        .par_chunks_mut(CHUNK)
        .zip(upper[..below_len].par_chunks(CHUNK))
        .for_each(|(to, from)| to.copy_from_slice(from));
    let below = &lower[first..first + below_len];
    // The children's unions only where they may be binned: a node's children are no larger.
    let binned = node.refs.len() > context.exact_max;
    let below_node = BoxNode {
        refs: first..first + below_len,
        cell: below_cell,
        union: binned.then(|| union_in_parallel(below)),
    };
    let above_node = BoxNode {
        refs: 0..above_len,
        cell: above_cell,
        union: binned.then(|| union_in_parallel(above)),
    };
    (below_node, above_node)
}

/// Cuts `out` into each chunk's places: its one-sided references' run and its clipped
/// references' run, the one-sided runs of all chunks first; `of` gives a chunk's one-sided
/// count and clipped parts on this side.
fn chunk_destinations<'a>(
    out: &'a mut [Ref],
    chunks: &[ChunkSides],
    of: impl Fn(&ChunkSides) -> (usize, &Vec<Ref>),
) -> Vec<(&'a mut [Ref], &'a mut [Ref])> {
    let one_sided = chunks.iter().map(|c| of(c).0).sum();
    let (mut sided, mut clipped) = out.split_at_mut(one_sided);
    chunks
        .iter()
        .map(|c| {
            let (count, parts) = of(c);
            let (here, rest) = std::mem::take(&mut sided).split_at_mut(count);
            sided = rest;
            let (here_clipped, rest) = std::mem::take(&mut clipped).split_at_mut(parts.len());
            clipped = rest;
            (here, here_clipped)
        })
        .collect()
}
