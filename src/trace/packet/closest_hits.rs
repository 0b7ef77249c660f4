//! The closest-hit visitor: each ray's nearest hit, ties to the smaller triangle id.

use kdbeam_kernels::beam::Survivors;
use kdbeam_kernels::groups::{group_bits, lane_rays, take_group};
use kdbeam_kernels::{HitPacket, LaneF32, LaneMask, Lanes, RayPacket};

use super::dense::{is_scattered, DensePacket};
use super::lane_test::LaneTest;
use super::visit::{leaf_beam, LeafVisit, PacketVisitor, SurvivorBlocks};
use super::{Column, PacketCounters};
use crate::kdtree::LeafTriangles;
use crate::trace::culling::Culling;

/// Closest hits: the running best per ray lives in the caller's [`HitPacket`], whose `t`
/// starts at each ray's `tmax` and whose triangle ids are carried through the lanes as `f32`
/// bit patterns (a blend moves bits unchanged).
pub(crate) struct ClosestHits<'h, T> {
    hits: &'h mut HitPacket,
    culling: Culling,
    /// Rays that have a hit.
    has_hit: u64,
    /// Ray–triangle tests performed.
    pub(crate) tests: u64,
    test: core::marker::PhantomData<T>,
}

impl<'h, T> ClosestHits<'h, T> {
    /// Starts `hits` for `p`: no hit, best `t` = each ray's `tmax`. Inlined into the ISA's
    /// entry point, where the fills become a few vector stores instead of calls to `memset`.
    #[inline(always)]
    pub fn new(hits: &'h mut HitPacket, p: &RayPacket, culling: Culling) -> Self {
        // In place: a fresh `HitPacket` would be built on the stack and copied in.
        hits.t.fill(f32::INFINITY);
        hits.t[..p.len()].copy_from_slice(&p.tmax[..p.len()]);
        hits.u.fill(0.0);
        hits.v.fill(0.0);
        hits.triangle.fill(u32::MAX);
        hits.tests.fill(0);
        ClosestHits {
            hits,
            culling,
            has_hit: 0,
            tests: 0,
            test: core::marker::PhantomData,
        }
    }

    /// Marks rays that hit nothing with `t = +inf`.
    #[inline(always)]
    pub fn finish(self) {
        for (t, &id) in self.hits.t.iter_mut().zip(&self.hits.triangle) {
            if id == u32::MAX {
                *t = f32::INFINITY;
            }
        }
    }
}

impl<L: Lanes, T: LaneTest<L>> PacketVisitor<L> for ClosestHits<'_, T> {
    #[inline(always)]
    fn visit(
        &mut self,
        l: L,
        p: &RayPacket,
        visit: LeafVisit<'_>,
        counters: &mut PacketCounters,
    ) -> u64 {
        // The far plane reads the hits as they stand when the beam is built: they only get
        // closer while the leaf is tested, so the plane stays conservative.
        let beam = leaf_beam(
            l,
            p,
            &visit,
            &self.culling,
            Some((&self.hits.t, self.has_hit)),
            counters,
        );
        let mut blocks = SurvivorBlocks::new(l, beam, p, &visit, &self.hits.t, counters);
        let culled = blocks.culls();
        // `next` is called directly: a `for` loop goes through `&mut I`'s forwarding `next`,
        // which is only `#[inline]` and may stay out of the ISA's entry point.
        if is_scattered::<L>(visit.mask) {
            let dense = DensePacket::gather(p, visit.mask);
            let mut found = dense.gather_hits(self.hits);
            let (rays, all) = (dense.rays(), dense.rays().full_mask());
            #[allow(clippy::while_let_on_iterator)]
            while let Some((first, survivors)) = blocks.next() {
                let tris = &visit.triangles;
                let block = (first, survivors, culled);
                test_groups::<L, T>(l, rays, all, tris, block, &mut found, counters);
            }
            self.has_hit |= dense.scatter_hits(&found, self.hits);
        } else {
            #[allow(clippy::while_let_on_iterator)]
            while let Some((first, survivors)) = blocks.next() {
                let tris = &visit.triangles;
                let block = (first, survivors, culled);
                self.has_hit |=
                    test_groups::<L, T>(l, p, visit.mask, tris, block, self.hits, counters);
            }
        }
        self.tests += blocks.finish(counters);
        0
    }

    #[inline(always)]
    fn best_t(&self) -> &Column {
        &self.hits.t
    }
}

/// Tests a block's survivors against every group of lanes that holds a ray of `mask`, keeping
/// each ray's closest hit in `hits` and counting its tests; returns the rays whose hit improved.
/// `culled`: a culling stage chose the survivors.
#[inline(always)]
fn test_groups<L: Lanes, T: LaneTest<L>>(
    l: L,
    p: &RayPacket,
    mask: u64,
    leaf: &LeafTriangles<'_>,
    block @ (_, survivors, _): (usize, Survivors, bool),
    hits: &mut HitPacket,
    counters: &mut PacketCounters,
) -> u64 {
    let mut improved = 0u64;
    let form = T::prepare_block(l, leaf, block.0);
    let mut rest = mask;
    while rest != 0 {
        let g = take_group::<L>(&mut rest);
        let bits = group_bits::<L>(mask, g);
        let better = test_group::<L, T>(l, p, (g, bits), (leaf, &form), block, hits);
        improved |= u64::from(better) << (g * L::WIDTH);
        // Counted here, not once above the loop: kept live across `test_group` it cost the
        // AVX-512 packet paths up to a quarter of their speed (register pressure).
        let tested = survivors.mask.count_ones();
        // Every lane of the group, masked: a loop over the set lanes ends on a branch that
        // depends on how many there are.
        let b = g * L::WIDTH;
        for (i, count) in hits.tests[b..b + L::WIDTH].iter_mut().enumerate() {
            *count += tested & 0u32.wrapping_sub(bits >> i & 1);
        }
        #[cfg(feature = "stats")]
        {
            counters.hits += u64::from(better.count_ones());
        }
    }
    let _ = counters;
    improved
}

/// Tests the triangles `first + i` for each bit `i` of `survivors.mask` (a block of
/// [`SurvivorBlocks`]) against the lanes `bits` of group `g`, keeping each lane's closest hit
/// with [`kdbeam_kernels::Hit::is_beaten_by`]'s tie rule. Returns the lanes whose hit improved.
///
/// Unculled, most triangles miss every lane, and a branch past them is predicted; the
/// survivors of a culling stage (`culled`) hit some lane too often for that, so there every
/// test's hits are merged without a branch.
#[inline(always)]
fn test_group<L: Lanes, T: LaneTest<L>>(
    l: L,
    p: &RayPacket,
    (g, bits): (usize, u32),
    (leaf, form): (&LeafTriangles<'_>, &T::Block),
    (first, survivors, culled): (usize, Survivors, bool),
    hits: &mut HitPacket,
) -> u32 {
    let b = g * L::WIDTH;
    let rays = lane_rays(l, p, g);
    let prepared = T::prepare(l, &rays);
    let act = l.mask_from_bits(bits);
    let tmin = l.load(&p.tmin[b..]);
    let mut best_t = l.load(&hits.t[b..]);
    let mut best_u = l.load(&hits.u[b..]);
    let mut best_v = l.load(&hits.v[b..]);
    let mut best_id = l.load(&bytemuck::cast_slice::<u32, f32>(&hits.triangle)[b..]);
    let mut improved = 0u32;
    let mut rest = survivors.mask;
    while rest != 0 {
        let j = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let i = first + j;
        let inside = survivors.inside >> j & 1 != 0;
        let h = T::test(l, &prepared, &rays, (leaf, form), i, (tmin, best_t), inside);
        let found = h.mask & act;
        if !culled && found.none() {
            continue;
        }
        let id = leaf.id(i);
        let mut better = (found & h.t.lt(best_t)).bits();
        let ties = (found & h.t.eq(best_t)).bits();
        if ties != 0 {
            for lane in 0..L::WIDTH {
                if ties >> lane & 1 != 0 && id < best_id.extract(lane).to_bits() {
                    better |= 1 << lane;
                }
            }
        }
        improved |= better;
        let m = l.mask_from_bits(better);
        best_t = L::F32::select(m, h.t, best_t);
        best_u = L::F32::select(m, h.u, best_u);
        best_v = L::F32::select(m, h.v, best_v);
        best_id = L::F32::select(m, l.splat(f32::from_bits(id)), best_id);
    }
    l.store(best_t, &mut hits.t[b..]);
    l.store(best_u, &mut hits.u[b..]);
    l.store(best_v, &mut hits.v[b..]);
    l.store(
        best_id,
        &mut bytemuck::cast_slice_mut::<u32, f32>(&mut hits.triangle)[b..],
    );
    improved
}
