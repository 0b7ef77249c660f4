//! Packet kd-tree traversal, written once and generic over the lanes.
//!
//! Up to 64 rays walk the tree together, front to back with a stack (Wald's packet traversal):
//! each ray keeps its own `[t_enter, t_exit]`, a bit mask says which rays are still in the
//! current cell, and a cell is entered when any ray needs it. All rays of one traversal share
//! the sign of each direction component, so near and far children are the same for all of them;
//! a packet whose rays disagree is split by octant first. In every cell a ray is active exactly
//! when the scalar traversal would enter that cell, lane for lane (see
//! [`super::single::traverse`]), so the two find the same hits.
//!
//! The files: [`coherence`] (which packets traverse as a whole), [`counters`] (what is counted), [`octants`] (which rays are traced, by octant),
//! [`per_ray`] (the per-ray traversal), [`interval`] (the whole-packet traversal of
//! [`super::Frustum::Packet`]), [`stack`] (its per-thread stack), [`visit`] (a packet in a leaf),
//! [`lane_test`] (the ray–triangle tests of a group of lanes), [`closest_hits`] and
//! [`any_hits`] (the two leaf visitors).

mod any_hits;
mod closest_hits;
mod coherence;
mod counters;
mod dense;
mod interval;
mod lane_test;
mod octants;
mod per_ray;
mod stack;
mod visit;

use kdbeam_kernels::raybox::BoxBlock;
use kdbeam_kernels::{HitPacket, Lanes, RayPacket, MAX_PACKET_RAYS};

use any_hits::AnyHits;
pub(crate) use closest_hits::ClosestHits;
pub(crate) use coherence::{
    spread, MAX_BEAM_DIRECTION_SPREAD, MAX_SHARED_WALK_ORIGIN_SPREAD, MIN_BEAM_RAYS,
};
pub(crate) use counters::Stamp;
pub use counters::{PacketCounters, StageCycles};
use interval::traverse_octant_interval;
pub(crate) use lane_test::{KsLanes, LaneTest, LaneTestFamily, WatertightLaneTest};
pub(crate) use octants::{octant_masks, traceable_mask};
use per_ray::traverse_octant;
pub(crate) use stack::{with_stack, Stack};
pub(crate) use visit::{LeafVisit, PacketVisitor};

use super::culling::Culling;
use crate::kdtree::KdTree;

const N: usize = MAX_PACKET_RAYS;

/// Per-ray `t` values of a packet.
pub(crate) type Column = [f32; N];

/// One packet query, as a tracer hands it to an ISA's entry point: the tree, the rays and which
/// of them to trace, the culling, and the thread's stack and counters.
pub(crate) struct Query<'a> {
    /// The tree traced.
    pub tree: &'a KdTree,
    /// The rays.
    pub packet: &'a RayPacket,
    /// The rays of `packet` to trace, one bit each.
    pub active: u64,
    /// The culling of the leaves.
    pub culling: Culling,
    /// The per-ray traversal's stack.
    pub stack: &'a mut Stack,
    /// Where the work done is added.
    pub counters: &'a mut PacketCounters,
}

/// One traversal of the rays of a packet that share an octant: what every step reads (the
/// lanes, the tree, the rays) and what it writes (the leaf visitor, the counters).
pub(crate) struct Traversal<'a, L, V> {
    /// The lanes the traversal runs on.
    pub l: L,
    /// The tree traced.
    pub tree: &'a KdTree,
    /// The rays.
    pub packet: &'a RayPacket,
    /// What happens in each leaf.
    pub visitor: &'a mut V,
    /// Where the work done is added.
    pub counters: &'a mut PacketCounters,
    /// The tree's triangle boxes, when ray-box culling is on.
    pub boxes: Option<&'a [BoxBlock]>,
}

/// Traverses `q.tree` with the traceable rays of `q.active`, one sub-packet per octant of
/// direction signs; ray by ray ([`traverse_octant`]) or, with `INTERVAL`, as one interval
/// ([`traverse_octant_interval`]).
#[inline(always)]
fn traverse_packet<L: Lanes, V: PacketVisitor<L>, const INTERVAL: bool>(
    l: L,
    q: &mut Query<'_>,
    visitor: &mut V,
) {
    let start = Stamp::now();
    let p = q.packet;
    let mut t = Traversal {
        l,
        tree: q.tree,
        packet: p,
        visitor,
        counters: &mut *q.counters,
        boxes: q.culling.raybox_packets().then(|| q.tree.triangle_boxes()),
    };
    let octants = octant_masks(l, p, traceable_mask(l, p, q.active));
    for (octant, mask) in octants.into_iter().enumerate() {
        if mask == 0 {
            continue;
        }
        let per_ray = if INTERVAL {
            traverse_octant_interval(&mut t, mask, octant, &mut q.stack.reciprocals)
        } else {
            mask
        };
        if per_ray != 0 {
            traverse_octant(&mut t, per_ray, octant, q.stack);
        }
    }
    start.add_to(&mut q.counters.cycles.traversal);
}

/// Closest hits of the rays of `q.active`, written to `hits` (misses and inactive or
/// untraceable rays get [`kdbeam_kernels::Hit::NONE`]). `INTERVAL` must be
/// `q.culling.interval_traversal()` (its frustum resolved for the packet): a type parameter, so that each entry point compiles one
/// traversal (a single entry holding every variant outgrows LLVM's inlining budget, and the
/// lane intrinsics then stop being inlined).
#[inline(always)]
pub(crate) fn closest<L: Lanes, T: LaneTest<L>, const INTERVAL: bool>(
    l: L,
    mut q: Query<'_>,
    hits: &mut HitPacket,
) {
    let mut visitor = ClosestHits::<T>::new(hits, q.packet, q.culling);
    traverse_packet::<L, _, INTERVAL>(l, &mut q, &mut visitor);
    q.counters.tests += visitor.tests;
    visitor.finish();
}

/// The rays of `q.active` that hit anything in `[tmin, tmax]`, as a bit mask (`INTERVAL` as in
/// [`closest`]).
#[inline(always)]
pub(crate) fn occluded<L: Lanes, T: LaneTest<L>, const INTERVAL: bool>(
    l: L,
    mut q: Query<'_>,
) -> u64 {
    let mut visitor = AnyHits::<T>::new(q.packet, q.culling);
    traverse_packet::<L, _, INTERVAL>(l, &mut q, &mut visitor);
    q.counters.tests += visitor.tests();
    visitor.occluded()
}
