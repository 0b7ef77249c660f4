//! Cuts of empty space: splits with an empty side, emitted at once, without classification.

use kdbeam_kernels::Aabb;

use super::recurse::may_split;
use super::Context;
use crate::kdtree::events::unkey;
use crate::kdtree::layout::Layout;
use crate::kdtree::sah::Split;
use crate::Result;

/// An inner node cutting off empty space above: its below child, the rest of the node, is
/// being built; its above child will be an empty leaf.
pub(super) struct OpenCut {
    at: usize,
    axis: usize,
    position: f32,
    /// The empty leaf's depth.
    depth: u32,
}

/// Takes the node of `n` triangles at `depth` in `cell` down the chain of splits with an
/// empty side that `best` (its cheapest plane in a cell) chooses, and returns the split that
/// follows, if any beats a leaf. `cell` and `depth` end as those of the rest of the node.
///
/// A split with an empty side is emitted at once: an empty leaf, and on the other side the
/// node itself in the smaller cell. No classification is needed: with one side empty every
/// triangle lies on the other side (the counts are exact for such planes), so none is clipped
/// and the node's triangles and boxes, and its plane counts, carry over unchanged; only the
/// costs change with the cell. Cuts whose empty leaf comes after the rest of the node are
/// left in `open` for [`close_cuts`]. `best` is called only while the node may be split.
pub(super) fn cut_off_empty_space(
    context: &Context<'_>,
    n: usize,
    cell: &mut Aabb,
    depth: &mut u32,
    out: &mut Layout,
    open: &mut Vec<OpenCut>,
    best: impl Fn(&Aabb) -> Option<Split>,
) -> Result<Option<Split>> {
    loop {
        if !may_split(context, n, *depth) {
            return Ok(None);
        }
        let Some(split) = best(cell).filter(|s| s.cost < context.costs.leaf_cost(n)) else {
            return Ok(None);
        };
        if split.below_count != 0 && split.above_count != 0 {
            return Ok(Some(split));
        }
        let position = unkey(split.pos_key);
        let at = out.open_inner();
        if split.below_count == 0 {
            out.push_empty_leaf(*depth + 1);
            out.close_inner(at, split.axis, position)?;
            cell.min[split.axis] = position;
        } else {
            open.push(OpenCut {
                at,
                axis: split.axis,
                position,
                depth: *depth + 1,
            });
            cell.max[split.axis] = position;
        }
        *depth += 1;
    }
}

/// Closes the cuts [`cut_off_empty_space`] left open above `mark` (a node's), innermost first,
/// once the rest of the node has been built: each gets its empty above leaf.
#[inline]
pub(super) fn close_cuts(out: &mut Layout, open: &mut Vec<OpenCut>, mark: usize) -> Result<()> {
    for cut in open.drain(mark..).rev() {
        out.close_inner(cut.at, cut.axis, cut.position)?;
        out.push_empty_leaf(cut.depth);
    }
    Ok(())
}
