//! Packets against one leaf, without a tree: the kernel the synthetic benchmark measures
//! (Alexander Reshetov, *Faster Ray Packets – Triangle Intersection through Vertex Culling*,
//! RT07, section 3.1: cycles per ray–triangle test).
//!
//! Each packet runs exactly what the packet traversal runs when it enters a leaf with every ray
//! active: the beam around all its rays (maskless, no hits yet, so no far plane but an
//! occluder's), the culling of the leaf's triangles in blocks of 64, and the Kensler–Shirley test
//! of the survivors against every ray, keeping each ray's closest hit.

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Aabb, HitPacket, LaneTask, Lanes, RayPacket};

use super::culling::Culling;
use super::packet::{ClosestHits, KsLanes, LeafVisit, PacketCounters, PacketVisitor};
use crate::kdtree::LeafTriangles;

/// One leaf: its triangles, its box, and a bound on every coordinate the beam sees.
#[derive(Clone, Copy, Debug)]
pub struct Leaf<'a> {
    /// The triangles.
    pub triangles: LeafTriangles<'a>,
    /// The leaf box the beam is built in.
    pub bounds: &'a Aabb,
    /// The largest absolute coordinate of any vertex or ray origin (sets the beam's margin).
    pub scene_bound: f32,
}

/// Traces every packet of `packets` against `leaf` on `dispatch`'s ISA with `culling`, closest
/// hits into `hits` (one per packet; a miss is [`kdbeam_kernels::Hit::NONE`]'s `t = +inf`,
/// `triangle = u32::MAX`). Returns the ray–triangle tests performed (rays × survivors, summed).
///
/// Only `culling`'s planes, aperture and order matter: the beam is always built around all rays
/// of a packet (`min_triangles` and `min_rays` still apply). Extra `hits` or `packets` beyond the
/// shorter of the two are ignored.
pub fn trace_leaf(
    dispatch: Dispatch,
    culling: Culling,
    leaf: Leaf<'_>,
    packets: &[RayPacket],
    hits: &mut [HitPacket],
) -> u64 {
    dispatch.run(LeafTask {
        culling,
        leaf,
        packets,
        hits,
    })
}

/// [`trace_leaf`] as a task: instantiated per ISA, everything inlined into its entry point.
struct LeafTask<'a, 'h> {
    culling: Culling,
    leaf: Leaf<'a>,
    packets: &'a [RayPacket],
    hits: &'h mut [HitPacket],
}

impl LaneTask for LeafTask<'_, '_> {
    type Output = u64;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> u64 {
        let mut counters = PacketCounters::default();
        let mut tests = 0;
        for (p, hits) in self.packets.iter().zip(self.hits.iter_mut()) {
            let mut closest = ClosestHits::<KsLanes>::new(hits, p, self.culling);
            let all = p.full_mask();
            PacketVisitor::<L>::visit(
                &mut closest,
                l,
                p,
                LeafVisit {
                    triangles: self.leaf.triangles,
                    bounds: self.leaf.bounds,
                    mask: all,
                    packet_mask: all,
                    scene_bound: self.leaf.scene_bound,
                    boxes: None,
                    shared_rays: None,
                },
                &mut counters,
            );
            tests += closest.tests;
            closest.finish();
        }
        tests
    }
}
