//! The any-hit visitor: a ray leaves the traversal at its first hit (shadow rays).

use kdbeam_kernels::groups::{group_bits, lane_rays, take_group};
use kdbeam_kernels::{LaneF32, LaneMask, Lanes, RayPacket};

use super::lane_test::LaneTest;
use super::visit::{leaf_beam, LeafVisit, PacketVisitor, SurvivorBlocks};
use super::{Column, PacketCounters};
use crate::trace::culling::Culling;

/// Any hit: a ray leaves the traversal at its first hit in `[tmin, tmax]`.
pub(crate) struct AnyHits<T> {
    tmax: Column,
    culling: Culling,
    /// Ray–triangle tests performed.
    tests: u64,
    occluded: u64,
    test: core::marker::PhantomData<T>,
}

impl<T> AnyHits<T> {
    /// No ray of `p` occluded yet; every ray tested up to its `tmax`.
    #[inline(always)]
    pub(crate) fn new(p: &RayPacket, culling: Culling) -> Self {
        AnyHits {
            tmax: p.tmax,
            culling,
            tests: 0,
            occluded: 0,
            test: core::marker::PhantomData,
        }
    }

    /// Ray–triangle tests performed.
    pub(crate) fn tests(&self) -> u64 {
        self.tests
    }

    /// The rays found occluded, as a bit mask.
    pub(crate) fn occluded(&self) -> u64 {
        self.occluded
    }
}

impl<L: Lanes, T: LaneTest<L>> PacketVisitor<L> for AnyHits<T> {
    const FARTHEST_FIRST: bool = true;
    #[inline(always)]
    fn visit(
        &mut self,
        l: L,
        p: &RayPacket,
        visit: LeafVisit<'_>,
        counters: &mut PacketCounters,
    ) -> u64 {
        let mut open = visit.mask;
        let mut tests = 0u64;
        let beam = leaf_beam(l, p, &visit, &self.culling, None, counters);
        let mut blocks = SurvivorBlocks::new(l, beam, p, &visit, &self.tmax, counters);
        #[allow(clippy::while_let_on_iterator)]
        while let Some((first, s)) = blocks.next() {
            let block = T::prepare_block(l, &visit.triangles, first);
            let mut groups = open;
            while groups != 0 {
                let g = take_group::<L>(&mut groups);
                let before = group_bits::<L>(open, g);
                let mut bits = before;
                let b = g * L::WIDTH;
                let rays = lane_rays(l, p, g);
                let prepared = T::prepare(l, &rays);
                // A lane that is closed (not in the visit, or already occluded) gets a NaN
                // interval, which no test accepts: its hits would cost the kernel's checks on
                // hits for nothing.
                let tmin = l.load(&p.tmin[b..]);
                let closed = l.splat(f32::NAN);
                let mut tmax = L::F32::select(l.mask_from_bits(bits), l.load(&p.tmax[b..]), closed);
                let mut rest = s.mask;
                while rest != 0 && bits != 0 {
                    let j = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    tests += u64::from(bits.count_ones());
                    let inside = s.inside >> j & 1 != 0;
                    let leaf = (&visit.triangles, &block);
                    let h = T::test(l, &prepared, &rays, leaf, first + j, (tmin, tmax), inside);
                    bits &= !h.mask.bits();
                    tmax = L::F32::select(h.mask, closed, tmax);
                }
                open &= !(u64::from(before & !bits) << b);
            }
        }
        blocks.finish(counters);
        self.tests += tests;
        let found = visit.mask & !open;
        self.occluded |= found;
        found
    }

    #[inline(always)]
    fn best_t(&self) -> &Column {
        &self.tmax
    }
}
