//! The recursion: a node's split search, its empty-space cuts, its split or its leaf, and its
//! children, depth first (in parallel for large nodes).

use kdbeam_kernels::Aabb;

use super::classify::split_boxes;
use super::empty_space::{close_cuts, cut_off_empty_space};
#[cfg(feature = "parallel")]
use super::parallel::{bins_in_parallel, push_root_refs, split_boxes_apart, PARALLEL_NODE_MIN};
use super::stack::{reserve_stack, STACK_PER_TRIANGLE};
#[cfg(feature = "parallel")]
use super::PARALLEL_MIN_TRIANGLES;
use super::{BoxNode, Context, Scratch};
use crate::kdtree::events::{push_box_events, unkey, Event};
use crate::kdtree::layout::Layout;
use crate::kdtree::refs::{Bounds, Ref};
use crate::kdtree::sah::{Bins, ExactPlanes, Split};
use crate::Result;

/// Fills `planes` with those of a small node with references `refs` in `cell` by Wald &
/// Havran's sweep: the boxes' events, sorted per axis in `events`, swept.
#[inline]
pub(super) fn sweep_planes(
    events: &mut [Vec<Event>; 3],
    planes: &mut ExactPlanes,
    refs: &[Ref],
    cell: &Aabb,
) {
    for list in events.iter_mut() {
        list.clear();
    }
    for r in refs {
        push_box_events(events, &r.aabb());
    }
    for list in events.iter_mut() {
        list.sort_unstable();
    }
    planes.sweep(events, refs.len(), cell);
}

/// The root: every triangle with its vertex box, the only references on `scratch`'s stack; its
/// cell is the boxes' union, the mesh's bounds (those of the vertices its triangles use).
pub(super) fn root_node(context: &Context<'_>, scratch: &mut Scratch) -> BoxNode {
    // A build that failed may have left cuts open.
    scratch.open_cuts.clear();
    let refs = &mut scratch.refs;
    refs.clear();
    reserve_stack(refs, STACK_PER_TRIANGLE * context.triangles.len());
    let union = root_refs(context, refs);
    scratch.top = refs.len();
    BoxNode {
        refs: 0..scratch.top,
        cell: union,
        union: Some(union),
    }
}

/// Pushes the references of every triangle (its vertex box) on the empty stack `refs`; returns
/// their union.
fn root_refs(context: &Context<'_>, refs: &mut Vec<Ref>) -> Aabb {
    #[cfg(feature = "parallel")]
    if context.parallel && context.triangles.len() > PARALLEL_NODE_MIN {
        return push_root_refs(context.triangles, refs);
    }
    let mut union = Bounds::EMPTY;
    refs.extend(context.triangles.iter().zip(0..).map(|(t, id)| {
        let r = Ref::new(id, &Aabb::from_points([t.v0, t.v1, t.v2]));
        union.add(&r);
        r
    }));
    union.aabb()
}

/// Builds `node` at `depth` and everything below it into `out`, depth first; pops the
/// references its children pushed.
pub(super) fn build_subtree(
    context: &Context<'_>,
    mut node: BoxNode,
    mut depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let n = node.refs.len();
    let open_mark = scratch.open_cuts.len();
    // Large nodes are searched by binning, small ones exactly; the search runs only while the
    // node may be split, so neither is prepared otherwise.
    let searched = may_split(context, n, depth);
    let refs = &scratch.refs[node.refs.clone()];
    let bins = (searched && n > context.exact_max)
        .then(|| bins_of(context, refs, node.union.unwrap_or_else(|| union_of(refs))));
    if searched && n <= context.exact_max {
        let Scratch { events, planes, .. } = scratch;
        if n <= context.count_max {
            planes.count(context.dispatch, refs, &node.cell);
        } else {
            sweep_planes(events, planes, refs, &node.cell);
        }
    }
    let planes = &scratch.planes;
    let split = cut_off_empty_space(
        context,
        n,
        &mut node.cell,
        &mut depth,
        out,
        &mut scratch.open_cuts,
        |cell| match &bins {
            Some(bins) => context
                .costs
                .best_binned_split(context.dispatch, bins, cell),
            None => context.costs.best_split(context.dispatch, planes, cell),
        },
    )?;
    match split {
        None => make_leaf(&node, scratch, depth, out)?,
        Some(split) => {
            let mark = scratch.top;
            build_children(context, &node, &split, depth, scratch, out)?;
            scratch.top = mark;
        }
    }
    close_cuts(out, &mut scratch.open_cuts, open_mark)
}

/// The bins of a large node's references `refs` across their union `union` (in parallel
/// chunks for the largest, when allowed).
#[inline]
fn bins_of(context: &Context<'_>, refs: &[Ref], union: Aabb) -> Bins {
    #[cfg(feature = "parallel")]
    if context.parallel && refs.len() > PARALLEL_NODE_MIN {
        return bins_in_parallel(refs, union);
    }
    #[cfg(not(feature = "parallel"))]
    let _ = context;
    Bins::new(refs, union)
}

/// The union of the boxes of `refs`.
#[inline]
pub(super) fn union_of(refs: &[Ref]) -> Aabb {
    let mut union = Bounds::EMPTY;
    for r in refs {
        union.add(r);
    }
    union.aabb()
}

/// Whether a node of `n` triangles at `depth` may be split at all.
#[inline]
pub(super) fn may_split(context: &Context<'_>, n: usize, depth: u32) -> bool {
    n > context.leaf_size && depth < context.depth_limit
}

/// Splits `node` at `depth` at `split` and builds its children and the inner node itself (in
/// parallel for large nodes when allowed).
pub(super) fn build_children(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let position = unkey(split.pos_key);
    #[cfg(feature = "parallel")]
    if context.parallel && node.refs.len() > PARALLEL_MIN_TRIANGLES {
        // The above child's references go to a stack of their own, for the other thread.
        let n = node.refs.len();
        let mut above_scratch = context.pool.take(n);
        let (below, above) = if n > PARALLEL_NODE_MIN && n >= context.chunked_min {
            split_boxes_apart(context, node, split, scratch, &mut above_scratch.refs)
        } else {
            let (below, above) = split_boxes(context, node, split, scratch);
            let stack = &mut above_scratch.refs;
            stack.clear();
            reserve_stack(stack, STACK_PER_TRIANGLE * above.refs.len());
            stack.extend_from_slice(&scratch.refs[above.refs.clone()]);
            // Popped: the below child's subtree may use their place.
            scratch.top = above.refs.start;
            let above = BoxNode {
                refs: 0..stack.len(),
                ..above
            };
            (below, above)
        };
        above_scratch.top = above.refs.end;
        let (mut below_out, mut above_out) = (Layout::default(), Layout::default());
        let (built_below, built_above) = rayon::join(
            || build_subtree(context, below, depth + 1, scratch, &mut below_out),
            || {
                build_subtree(
                    context,
                    above,
                    depth + 1,
                    &mut above_scratch,
                    &mut above_out,
                )
            },
        );
        context.pool.put(above_scratch, n);
        built_below?;
        built_above?;
        let at = out.open_inner();
        out.append(below_out)?;
        out.close_inner(at, split.axis, position)?;
        return out.append(above_out);
    }

    let (below, above) = split_boxes(context, node, split, scratch);
    let at = out.open_inner();
    build_subtree(context, below, depth + 1, scratch, out)?;
    out.close_inner(at, split.axis, position)?;
    build_subtree(context, above, depth + 1, scratch, out)
}

/// Emits `node` as a leaf: its ids in the order of its references, its box the union of its
/// triangles' clipped boxes (which lies inside the cell).
///
/// The ids are not sorted: the closest hit breaks ties in `t` by the smaller id wherever the
/// triangles lie ([`kdbeam_kernels::Hit::is_beaten_by`]), so the order changes no result and
/// sorting would cost build time for nothing.
#[inline]
pub(super) fn make_leaf(
    node: &BoxNode,
    scratch: &Scratch,
    depth: u32,
    out: &mut Layout,
) -> Result<()> {
    if node.refs.is_empty() {
        out.push_empty_leaf(depth);
        return Ok(());
    }
    let refs = &scratch.refs[node.refs.clone()];
    let union = node.union.unwrap_or_else(|| union_of(refs));
    out.push_leaf(depth, refs.iter().map(Ref::id), union)
}
