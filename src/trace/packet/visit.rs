//! A packet in a leaf: what it knows there, what a visitor does with it, and the blocks of
//! triangles that survive the leaf's beam.

use std::cell::Cell;

use kdbeam_kernels::beam::{Beam, BeamRays, Survivors};
use kdbeam_kernels::raybox::{overlapping_block, segment_box, BoxBlock};
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, Lanes, RayPacket, TriangleBlock, Vec3};

use super::{Column, PacketCounters, Stamp};
use crate::kdtree::LeafTriangles;
use crate::trace::culling::Culling;
use crate::trace::raybox::RAYBOX_MIN_TRIANGLES;

/// Leaf visits of at most this many active rays and no beam are culled ray-box style (when
/// [`Culling::raybox`] is on): the box around more rays' segments grows too large to cull.
pub(crate) const RAYBOX_MAX_RAYS: u32 = 4;

/// What ray-box culling reads in a leaf: the boxes of its triangles and each ray's interval in
/// its cell. Only the per-ray traversal has per-ray cell intervals, so only it culls this way.
#[derive(Clone, Copy)]
pub(crate) struct LeafBoxes<'a> {
    /// The boxes of the leaf's blocks, from [`crate::KdTree::triangle_boxes`].
    pub boxes: &'a [BoxBlock],
    /// Where each ray enters the leaf's cell.
    pub t_enter: &'a Column,
    /// Where each ray leaves it.
    pub t_exit: &'a Column,
}

/// What a packet entering a leaf knows.
pub(crate) struct LeafVisit<'a> {
    /// The leaf's triangles.
    pub triangles: LeafTriangles<'a>,
    /// The leaf's tight box.
    pub bounds: &'a Aabb,
    /// Rays active in this leaf.
    pub mask: u64,
    /// Every ray of this traversal (the maskless frustum's rays).
    pub packet_mask: u64,
    /// The largest absolute coordinate of the scene.
    pub scene_bound: f32,
    /// For ray-box culling of visits of few rays, when it is on.
    pub boxes: Option<LeafBoxes<'a>>,
    /// Where a traversal whose rays stay the same from leaf to leaf (the whole-packet
    /// traversal) keeps the [`BeamRays`] of `packet_mask`, made at its first beam: `None`
    /// inside until then, `Some(None)` when the rays have no such summary.
    pub shared_rays: Option<&'a Cell<Option<Option<BeamRays>>>>,
}

/// What a packet traversal does in each leaf.
pub(crate) trait PacketVisitor<L: Lanes> {
    /// Tests the leaf for the rays of `visit.mask`; returns the rays that are finished (an
    /// any-hit query that found its hit), which then leave the traversal.
    fn visit(
        &mut self,
        l: L,
        packet: &RayPacket,
        visit: LeafVisit<'_>,
        counters: &mut PacketCounters,
    ) -> u64;
    /// Closest hit so far per ray (the ray's `tmax` without one): a cell entered after it is
    /// skipped.
    fn best_t(&self) -> &Column;
    /// Whether the packet traversals take the children their rays enter farthest entry first
    /// rather than nearest first (the far child of a split first, per ray): for visitors that
    /// stop at any hit, where the order cannot change the answer ([`crate::trace::wide`]).
    const FARTHEST_FIRST: bool = false;
}

/// Counts a leaf visit of the rays of `visit.mask` and hands it to `visitor`; returns the rays
/// the visitor has finished.
#[inline(always)]
pub(super) fn visit_leaf<L: Lanes, V: PacketVisitor<L>>(
    l: L,
    p: &RayPacket,
    visit: LeafVisit<'_>,
    visitor: &mut V,
    counters: &mut PacketCounters,
) -> u64 {
    counters.leaf_visits += 1;
    let rays = u64::from(visit.mask.count_ones());
    counters.ray_leaf_visits += rays;
    counters.potential_tests += rays * visit.triangles.len() as u64;
    #[cfg(feature = "stats")]
    {
        counters.single_ray_visits += u64::from(rays == 1);
    }
    let start = Stamp::now();
    let finished = visitor.visit(l, p, visit, counters);
    start.add_to(&mut counters.cycles.leaves);
    finished
}

/// The beam for this leaf visit, or `None` when the visit is tested unculled (culling off, too
/// few triangles or rays for a beam to pay, or no prevalent axis).
#[inline(always)]
pub(super) fn leaf_beam<L: Lanes>(
    l: L,
    p: &RayPacket,
    visit: &LeafVisit<'_>,
    culling: &Culling,
    best: Option<(&Column, u64)>,
    counters: &mut PacketCounters,
) -> Option<Beam<L>> {
    let start = Stamp::now();
    // A `match`, not `Option::and_then`: its closure could stay out of the ISA's entry point.
    let beam = match culling.beam_rays(visit.triangles.len(), visit.mask, visit.packet_mask) {
        None => None,
        Some(used) => {
            let shared = match visit.shared_rays {
                Some(cell) if used == visit.packet_mask => shared_rays(l, p, used, cell),
                _ => None,
            };
            let (stages, bound) = (culling.stages(), visit.scene_bound);
            // Two calls, each inlined with its own constant: the per-ray traversal, which never
            // has a summary, compiles only the second.
            match shared {
                Some(rays) => Beam::new(l, p, used, Some(&rays), visit.bounds, best, stages, bound),
                None => Beam::new(l, p, used, None, visit.bounds, best, stages, bound),
            }
        }
    };
    start.add_to(&mut counters.cycles.beams);
    beam
}

/// The [`BeamRays`] of the rays `used` of `p`, kept in `cell` for the next leaf.
#[inline(always)]
fn shared_rays<L: Lanes>(
    l: L,
    p: &RayPacket,
    used: u64,
    cell: &Cell<Option<Option<BeamRays>>>,
) -> Option<BeamRays> {
    if let Some(known) = cell.get() {
        return known;
    }
    let rays = BeamRays::new(l, p, used);
    cell.set(Some(rays));
    rays
}

/// The box around the segments of the rays of `mask` in the leaf's cell, each up to its best
/// hit so far (`best`), for ray-box culling (Nah et al.).
///
/// Conservative as [`RayBoxCull`](crate::trace::raybox::RayBoxCull) is for one ray: a triangle
/// whose box misses every ray's segment holds no hit of these rays in this cell before their
/// best, and a hit outside the cell is found in the cell that holds it, which the per-ray
/// traversal visits (it passes a ray's cell only after the ray's closest hit).
#[inline(always)]
fn segments_box(p: &RayPacket, mut mask: u64, cells: &LeafBoxes<'_>, best: &Column) -> Aabb {
    let mut b = Aabb::EMPTY;
    while mask != 0 {
        let r = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let at = |c: &[Column; 3]| Vec3::new(c[0][r], c[1][r], c[2][r]);
        let end = cells.t_exit[r].min(best[r]);
        b = b.union(segment_box(
            at(&p.origin),
            at(&p.direction),
            cells.t_enter[r],
            end,
        ));
    }
    b
}

/// The blocks of up to [`BLOCK`] triangles of a leaf that hold triangles to test, culled by a
/// beam when there is one, else by ray-box culling when it is on and the visit has few rays:
/// `(first triangle, survivors)`. An iterator rather than a callback, so
/// that everything stays inlined into the ISA's `#[target_feature]` entry point.
pub(super) struct SurvivorBlocks<'v, L: Lanes> {
    l: L,
    beam: Option<Beam<L>>,
    /// Without a beam, the box of the rays' segments and the leaf's triangle boxes.
    raybox: Option<(Aabb, &'v [BoxBlock])>,
    triangles: LeafTriangles<'v>,
    next: usize,
    rays: u64,
    /// Tests the survivors cost (active rays × triangles).
    tests: u64,
    #[cfg(feature = "stats")]
    culled: kdbeam_kernels::beam::CullCounts,
    /// Cycles spent culling.
    cull_cycles: u64,
}

impl<'v, L: Lanes> SurvivorBlocks<'v, L> {
    #[inline(always)]
    pub(super) fn new(
        l: L,
        beam: Option<Beam<L>>,
        p: &RayPacket,
        visit: &LeafVisit<'v>,
        best: &Column,
        counters: &mut PacketCounters,
    ) -> Self {
        counters.beams += u64::from(beam.is_some());
        let rays = visit.mask.count_ones();
        let raybox = match (&beam, &visit.boxes) {
            (None, Some(cells))
                if rays <= RAYBOX_MAX_RAYS && visit.triangles.len() >= RAYBOX_MIN_TRIANGLES =>
            {
                let start = Stamp::now();
                let segments = segments_box(p, visit.mask, cells, best);
                start.add_to(&mut counters.cycles.culling);
                Some((segments, cells.boxes))
            }
            _ => None,
        };
        SurvivorBlocks {
            l,
            beam,
            raybox,
            triangles: visit.triangles,
            next: 0,
            rays: u64::from(rays),
            tests: 0,
            #[cfg(feature = "stats")]
            culled: Default::default(),
            cull_cycles: 0,
        }
    }

    /// Whether a beam or the rays' box culls the blocks.
    #[inline(always)]
    pub(super) fn culls(&self) -> bool {
        self.beam.is_some() || self.raybox.is_some()
    }

    /// Adds what was culled to `counters` and returns the tests performed.
    #[inline(always)]
    pub(super) fn finish(self, counters: &mut PacketCounters) -> u64 {
        #[cfg(feature = "stats")]
        {
            counters.culled_planes += self.rays * u64::from(self.culled.planes);
            counters.culled_distance += self.rays * u64::from(self.culled.distance);
            counters.culled_aperture += self.rays * u64::from(self.culled.aperture);
        }
        counters.cycles.culling += self.cull_cycles;
        self.tests
    }
}

impl<L: Lanes> Iterator for SurvivorBlocks<'_, L> {
    type Item = (usize, Survivors);

    #[inline(always)]
    fn next(&mut self) -> Option<(usize, Survivors)> {
        while self.next < self.triangles.len() {
            let first = self.next;
            let count = (self.triangles.len() - first).min(BLOCK);
            self.next = first + BLOCK;
            let block = &self.triangles.blocks[first / BLOCK];
            let s = match &mut self.beam {
                Some(beam) => {
                    let start = Stamp::now();
                    let s = beam.cull(block, count);
                    start.add_to(&mut self.cull_cycles);
                    s
                }
                None => {
                    let mut mask = TriangleBlock::valid_bits(count);
                    if let Some((segments, boxes)) = &self.raybox {
                        let start = Stamp::now();
                        mask &= overlapping_block(self.l, segments, &boxes[first / BLOCK], count);
                        start.add_to(&mut self.cull_cycles);
                    }
                    Survivors {
                        mask: u64::from(mask),
                        ..Survivors::default()
                    }
                }
            };
            #[cfg(feature = "stats")]
            {
                self.culled.planes += s.culled.planes;
                self.culled.distance += s.culled.distance;
                self.culled.aperture += s.culled.aperture;
            }
            self.tests += self.rays * u64::from(s.mask.count_ones());
            if s.mask != 0 {
                return Some((first, s));
            }
        }
        None
    }
}
