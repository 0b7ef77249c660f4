//! Ray-box culling of single rays (J.-H. Nah, W.-C. Park, Y.-S. Kang & T.-D. Han, *Ray-Box
//! Culling for Tree Structures*, Journal of Information Science and Engineering): in a leaf,
//! the box of the ray's segment there, up to its closest hit so far, against the box of each
//! triangle clipped to the leaf.

use kdbeam_kernels::raybox::{overlapping_block, segment_box, BoxBlock};
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, Lanes, Ray};

use super::single::{LeafEntry, TriangleCull};

/// Leaves with fewer triangles are tested unculled: the paper culls in leaves of more than 2,
/// below which the box test costs about what the tests it saves do.
pub(crate) const RAYBOX_MIN_TRIANGLES: usize = 3;

/// [`TriangleCull`] by ray-box culling over a tree's [`KdTree::triangle_boxes`].
///
/// **Why it is conservative.** In a leaf entered over `[t_enter, t_exit]`, the tree holds every
/// triangle that meets the leaf's cell, each boxed by its part in the leaf's tight box. A hit
/// the unculled query would take, at `t ≤ tmax` (`tmax` the closest accepted hit so far, or the
/// ray's end), on a triangle of this leaf, lies either in this cell, at `t ∈ [t_enter,
/// min(t_exit, tmax)]` — then the segment's box holds the hit point and overlaps the
/// triangle's box — or outside it, in a cell of the same triangle that the ray enters at the
/// point's `t`: the leaf before this one when `t < t_enter` (already visited, so the hit is
/// already known), or a later one, which the traversal still visits, as it stops only past
/// the closest hit. So the culled query finds the same set of candidates that can win, and
/// with [`Hit::is_beaten_by`](kdbeam_kernels::Hit::is_beaten_by)'s order, the same hit.
/// When `tmax < t_enter` the box spans `[tmax, t_enter]`, which only keeps more. Rounding of
/// the segment, of the hit's `t` and of the clipped boxes is covered by the widening of
/// [`segment_box`] and [`BoxBlock::clipped`].
///
/// [`KdTree::triangle_boxes`]: crate::KdTree::triangle_boxes
pub(crate) struct RayBoxCull<'t> {
    boxes: &'t [BoxBlock],
    /// Does the leaf last entered have enough triangles to cull?
    on: bool,
    t_enter: f32,
    t_exit: f32,
    /// The end of the segment `segment` was made for (NaN: none yet in this leaf).
    t_end: f32,
    segment: Aabb,
    /// The leaf's first block in the tree's blocks, and its triangle count.
    leaf_first: usize,
    leaf_len: usize,
    /// The block `kept` was computed for, against `segment` (`usize::MAX`: none).
    kept_block: usize,
    /// Of the triangles of block `kept_block`, those whose box overlaps `segment`.
    kept: u32,
}

impl<'t> RayBoxCull<'t> {
    /// Culling over `boxes`, a tree's [`KdTree::triangle_boxes`](crate::KdTree::triangle_boxes).
    pub(crate) fn new(boxes: &'t [BoxBlock]) -> Self {
        RayBoxCull {
            boxes,
            on: false,
            t_enter: 0.0,
            t_exit: 0.0,
            t_end: f32::NAN,
            segment: Aabb::EMPTY,
            leaf_first: 0,
            leaf_len: 0,
            kept_block: usize::MAX,
            kept: 0,
        }
    }
}

impl TriangleCull for RayBoxCull<'_> {
    #[inline(always)]
    fn enter(&mut self, _: &Ray, leaf: &LeafEntry<'_>) -> bool {
        self.on = leaf.triangles.len() >= RAYBOX_MIN_TRIANGLES;
        (self.t_enter, self.t_exit, self.t_end) = (leaf.t_enter, leaf.t_exit, f32::NAN);
        (self.leaf_first, self.leaf_len) = (leaf.record.first as usize, leaf.triangles.len());
        self.kept_block = usize::MAX;
        true
    }

    #[inline(always)]
    fn lanes<L: Lanes>(
        &mut self,
        l: L,
        ray: &Ray,
        block: usize,
        first: usize,
        valid: u32,
        tmax: f32,
    ) -> u32 {
        if !self.on {
            return valid;
        }
        // The box changes only when a hit shortens the ray: made once per leaf and hit. A
        // block's triangles are tested against it all at once, on its first vector (on
        // scalar lanes, one call per block instead of one per triangle).
        let end = self.t_exit.min(tmax);
        if end != self.t_end {
            self.t_end = end;
            self.segment = segment_box(ray.origin, ray.direction, self.t_enter, end);
            self.kept_block = usize::MAX;
        }
        if block != self.kept_block {
            let count = (self.leaf_len - (block - self.leaf_first) * BLOCK).min(BLOCK);
            let boxes = &self.boxes[block];
            self.kept_block = block;
            self.kept = overlapping_block(l, &self.segment, boxes, count);
        }
        valid & self.kept >> first
    }
}
