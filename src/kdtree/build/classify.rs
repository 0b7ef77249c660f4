//! The classification of a split node's boxes (Wald & Havran §4.3): below, above, or straddling
//! and clipped into both children ("perfect splits").

use bytemuck::Zeroable;
use kdbeam_kernels::lanes::prefetch;

use super::recurse::union_of;
use super::stack::reserve_stack;
use super::{BoxNode, Context, Scratch};
use crate::kdtree::clip::split_clipped_bounds;
use crate::kdtree::events::unkey;
use crate::kdtree::refs::Ref;
use crate::kdtree::sah::Split;

/// Which sides of the plane at `p` on a split's axis a box spanning `[lo, hi]` there goes to,
/// as `(below, above)` (Wald & Havran §4.3): a flat box to its side of the plane, and in the
/// plane to the split's choice; any other box below if it ends at or before `p`, above if it
/// starts at or after it, else to neither: it straddles the plane and is clipped into both.
/// Without branches, as the sides come as good as at random: a box both ending by `p` and
/// starting from it lies in the plane (`lo ≤ hi`).
#[inline(always)]
pub(super) fn sides_of(lo: f32, hi: f32, p: f32, planar_below: bool) -> (bool, bool) {
    let (ends_by, starts_from) = (hi <= p, lo >= p);
    let below = ends_by & (!starts_from | planar_below);
    let above = starts_from & (!ends_by | !planar_below);
    (below, above)
}

/// Splits `node` at `split` (which has triangles on both sides): one-sided triangles go to
/// their side with their boxes, straddling ones are clipped to each child cell (and left out
/// of a child they do not meet). The below child's references replace the node's on
/// `scratch.refs`, and the above child's are pushed on top, so that the stack grows by the
/// above children alone on the way down; within each, the one-sided triangles come first, in
/// the node's order, then the clipped ones.
#[inline]
pub(super) fn split_boxes(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
) -> (BoxNode, BoxNode) {
    // The axis as a constant, so that coordinates along it are picked without a branch.
    match split.axis {
        0 => split_boxes_on::<0>(context, node, split, scratch),
        1 => split_boxes_on::<1>(context, node, split, scratch),
        _ => split_boxes_on::<2>(context, node, split, scratch),
    }
}

/// [`split_boxes`] on axis `AXIS` (`split.axis`).
pub(super) fn split_boxes_on<const AXIS: usize>(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
) -> (BoxNode, BoxNode) {
    let axis = AXIS;
    let p = unkey(split.pos_key);
    let (mut below_cell, mut above_cell) = (node.cell, node.cell);
    below_cell.max[axis] = p;
    above_cell.min[axis] = p;
    let Scratch {
        refs,
        top,
        straddling,
        ..
    } = scratch;
    // Each reference has at most one part on either side, and its below part is written
    // after it has been read: the below child's references take the node's place, and the
    // above child's at most `n` slots at the stack's top.
    let (first, n, above_first) = (node.refs.start, node.refs.len(), *top);
    if refs.len() < above_first + n {
        reserve_stack(refs, above_first + n);
        refs.resize(above_first + n, Ref::zeroed());
    }
    if straddling.len() < n {
        straddling.resize(n, 0);
    }
    let (refs, straddling) = (&mut refs[..], &mut straddling[..n]);
    let (mut below_end, mut above_end, mut straddlers) = (first, above_first, 0);
    // Without a branch on the sides, which come as good as at random: a reference is written
    // to the end of the child it goes to (to the below child's, unkept, when it straddles; that
    // slot's reference has been read), and its id to the straddlers' end (kept when it does).
    for i in node.refs.clone() {
        let r = refs[i];
        // From the vectors' lanes, so that the reference stays in two vector registers.
        let (lo, hi) = (r.lo()[AXIS], r.hi()[AXIS]);
        let (below, above) = sides_of(lo, hi, p, split.planar_below);
        refs[if above { above_end } else { below_end }] = r;
        below_end += usize::from(below);
        above_end += usize::from(above);
        straddling[straddlers] = r.id();
        // At most one side: a box both ending by `p` and starting from it lies in the plane.
        straddlers += 1 - usize::from(below) - usize::from(above);
    }
    let straddling = &straddling[..straddlers];
    // Triangles are random in the mesh: each is prefetched a few clips ahead.
    const AHEAD: usize = 4;
    for &id in straddling.iter().take(AHEAD) {
        prefetch(&context.triangles[id as usize]);
    }
    for (k, &id) in straddling.iter().enumerate() {
        if let Some(&next) = straddling.get(k + AHEAD) {
            prefetch(&context.triangles[next as usize]);
        }
        let tri = &context.triangles[id as usize];
        let [below_part, above_part] = split_clipped_bounds::<AXIS>(tri, &node.cell, p);
        if let Some(part) = below_part {
            refs[below_end] = Ref::new(id, &part);
            below_end += 1;
        }
        if let Some(part) = above_part {
            refs[above_end] = Ref::new(id, &part);
            above_end += 1;
        }
    }
    *top = above_end;
    // The children's unions only where they may be binned: a node's children are no larger.
    let binned = n > context.exact_max;
    (
        BoxNode {
            refs: first..below_end,
            cell: below_cell,
            union: binned.then(|| union_of(&refs[first..below_end])),
        },
        BoxNode {
            refs: above_first..above_end,
            cell: above_cell,
            union: binned.then(|| union_of(&refs[above_first..above_end])),
        },
    )
}
