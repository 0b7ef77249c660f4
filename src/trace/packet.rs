//! Packet kd-tree traversal, written once and generic over the lanes.
//!
//! Up to 64 rays walk the tree together, front to back with a stack (Wald's packet traversal):
//! each ray keeps its own `[t_enter, t_exit]`, a bit mask says which rays are still in the
//! current cell, and a cell is entered when any ray needs it. All rays of one traversal share
//! the sign of each direction component, so near and far children are the same for all of them;
//! a packet whose rays disagree is split by octant first. In every cell a ray is active exactly
//! when the scalar traversal would enter that cell, lane for lane (see
//! [`super::single::traverse`]), so the two find the same hits.

use kdbeam_kernels::intersect::kensler_shirley;
use kdbeam_kernels::intersect::watertight::WatertightLanes;
use kdbeam_kernels::intersect::{LaneHits, LaneRays};
use kdbeam_kernels::{slab, Aabb, HitPacket, LaneF32, LaneMask, Lanes, RayPacket, MAX_PACKET_RAYS};

use super::single::{is_traceable, STACK_DEPTH};
use crate::kdtree::{KdTree, LeafTriangles};

const N: usize = MAX_PACKET_RAYS;

/// Per-ray `t` values of a packet.
pub(crate) type Column = [f32; N];

/// Work done by packet traversals, summed by callers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketCounters {
    /// Packets (after the split by octant) traced.
    pub packets: u64,
    /// Non-empty leaves entered by a packet.
    pub leaf_visits: u64,
    /// Ray–leaf visits: active rays summed over leaf visits.
    pub ray_leaf_visits: u64,
    /// Ray–triangle tests a packet would perform without culling (active rays × triangles).
    pub potential_tests: u64,
    /// Ray–triangle tests performed.
    pub tests: u64,
}

impl PacketCounters {
    /// Adds `o` to `self`.
    pub fn add(&mut self, o: &PacketCounters) {
        self.packets += o.packets;
        self.leaf_visits += o.leaf_visits;
        self.ray_leaf_visits += o.ray_leaf_visits;
        self.potential_tests += o.potential_tests;
        self.tests += o.tests;
    }
}

/// The lanes of group `g` in `mask`, as the low `L::WIDTH` bits.
#[inline(always)]
pub(crate) fn group_bits<L: Lanes>(mask: u64, g: usize) -> u32 {
    let lanes = if L::WIDTH == 64 {
        u64::MAX
    } else {
        (1u64 << L::WIDTH) - 1
    };
    ((mask >> (g * L::WIDTH)) & lanes) as u32
}

/// Groups of `L::WIDTH` lanes that cover `len` rays.
#[inline(always)]
pub(crate) fn group_count<L: Lanes>(len: usize) -> usize {
    len.div_ceil(L::WIDTH)
}

/// The rays of group `g`.
#[inline(always)]
pub(crate) fn lane_rays<L: Lanes>(l: L, p: &RayPacket, g: usize) -> LaneRays<L> {
    let b = g * L::WIDTH;
    LaneRays {
        org: [
            l.load(&p.org[0][b..]),
            l.load(&p.org[1][b..]),
            l.load(&p.org[2][b..]),
        ],
        dir: [
            l.load(&p.dir[0][b..]),
            l.load(&p.dir[1][b..]),
            l.load(&p.dir[2][b..]),
        ],
    }
}

/// What a packet entering a leaf knows.
pub(crate) struct LeafVisit<'a> {
    /// The leaf's triangles.
    pub triangles: LeafTriangles<'a>,
    /// The leaf's tight box.
    pub bounds: &'a Aabb,
    /// Rays active in this leaf.
    pub mask: u64,
    /// Where each active ray enters the cell.
    pub t_enter: &'a Column,
    /// Where each active ray leaves it.
    pub t_exit: &'a Column,
}

/// What a packet traversal does in each leaf.
pub(crate) trait PacketVisitor<L: Lanes> {
    /// Tests the leaf for the rays of `visit.mask`; returns the rays that are finished (an
    /// any-hit query that found its hit), which then leave the traversal.
    fn visit(&mut self, l: L, packet: &RayPacket, visit: LeafVisit<'_>) -> u64;
    /// Closest hit so far per ray (the ray's `tmax` without one): a cell entered after it is
    /// skipped.
    fn best_t(&self) -> &Column;
}

/// Rays of `active` that can be traced (see [`is_traceable`]).
#[inline(always)]
pub(crate) fn traceable_mask(p: &RayPacket, active: u64) -> u64 {
    let mut m = 0u64;
    for i in 0..p.len() {
        if active >> i & 1 != 0 && is_traceable(&p.ray(i)) {
            m |= 1 << i;
        }
    }
    m
}

/// The rays of `mask` sorted by the sign bits of their direction: one mask per octant.
#[inline(always)]
pub(crate) fn octant_masks(p: &RayPacket, mask: u64) -> [u64; 8] {
    let mut octants = [0u64; 8];
    for i in 0..p.len() {
        if mask >> i & 1 != 0 {
            let o = (0..3).fold(0, |o, a| o | (p.dir[a][i].is_sign_negative() as usize) << a);
            octants[o] |= 1 << i;
        }
    }
    octants
}

/// Traverses `tree` with the rays of `mask`, which must all be traceable and share the
/// direction signs `octant` (bit `a` set for a negative component on axis `a`).
#[inline(always)]
pub(crate) fn traverse_octant<L: Lanes, V: PacketVisitor<L>>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    mut mask: u64,
    octant: usize,
    visitor: &mut V,
    counters: &mut PacketCounters,
) {
    let groups = group_count::<L>(p.len());
    let used = groups * L::WIDTH;
    let mut inv = [[0f32; N]; 3];
    for a in 0..3 {
        for g in 0..groups {
            let b = g * L::WIDTH;
            l.store(l.splat(1.0) / l.load(&p.dir[a][b..]), &mut inv[a][b..]);
        }
    }
    let mut t_enter = [0f32; N];
    let mut t_exit = [0f32; N];
    let bounds = tree.bounds();
    let mut clipped = 0u64;
    for g in 0..groups {
        let bits = group_bits::<L>(mask, g);
        if bits == 0 {
            continue;
        }
        let b = g * L::WIDTH;
        let org = [
            l.load(&p.org[0][b..]),
            l.load(&p.org[1][b..]),
            l.load(&p.org[2][b..]),
        ];
        let iv = [
            l.load(&inv[0][b..]),
            l.load(&inv[1][b..]),
            l.load(&inv[2][b..]),
        ];
        let (hit, tn, tf) = slab::slab_lanes(
            l,
            &org,
            &iv,
            l.load(&p.tmin[b..]),
            l.load(&p.tmax[b..]),
            &bounds,
        );
        l.store(tn, &mut t_enter[b..]);
        l.store(tf, &mut t_exit[b..]);
        clipped |= u64::from((hit & l.mask_from_bits(bits)).bits()) << b;
    }
    mask = clipped;
    counters.packets += 1;

    let nodes = tree.nodes();
    let mut stack_node = [0u32; STACK_DEPTH];
    let mut stack_mask = [0u64; STACK_DEPTH];
    let mut stack_enter = [[0f32; N]; STACK_DEPTH];
    let mut stack_exit = [[0f32; N]; STACK_DEPTH];
    let mut top = 0;
    let mut node_index = 0u32;
    let mut done = 0u64;
    let mut near_exit = [0f32; N];
    let mut far_enter = [0f32; N];
    while mask != 0 {
        let node = nodes[node_index as usize];
        let mut descended = false;
        if !node.is_leaf() {
            let axis = node.axis();
            let split = l.splat(node.split());
            let (near, far) = if octant >> axis & 1 != 0 {
                (node.above_child(), node_index + 1)
            } else {
                (node_index + 1, node.above_child())
            };
            let (mut near_mask, mut far_mask) = (0u64, 0u64);
            for g in 0..groups {
                let bits = group_bits::<L>(mask, g);
                if bits == 0 {
                    continue;
                }
                let b = g * L::WIDTH;
                let ts = (split - l.load(&p.org[axis][b..])) * l.load(&inv[axis][b..]);
                let (tn, tf) = (l.load(&t_enter[b..]), l.load(&t_exit[b..]));
                // NaN (origin on the plane, zero direction) yields the second operand: the
                // ray keeps its whole interval on both sides.
                let ne = ts.min(tf);
                let fe = ts.max(tn);
                let act = l.mask_from_bits(bits);
                l.store(ne, &mut near_exit[b..]);
                l.store(fe, &mut far_enter[b..]);
                near_mask |= u64::from((act & tn.le(ne)).bits()) << b;
                far_mask |= u64::from((act & fe.le(tf)).bits()) << b;
            }
            if near_mask != 0 {
                if far_mask != 0 {
                    stack_node[top] = far;
                    stack_mask[top] = far_mask;
                    stack_enter[top][..used].copy_from_slice(&far_enter[..used]);
                    stack_exit[top][..used].copy_from_slice(&t_exit[..used]);
                    top += 1;
                }
                t_exit[..used].copy_from_slice(&near_exit[..used]);
                (node_index, mask) = (near, near_mask);
                descended = true;
            } else if far_mask != 0 {
                t_enter[..used].copy_from_slice(&far_enter[..used]);
                (node_index, mask) = (far, far_mask);
                descended = true;
            }
        } else {
            let leaf = &tree.leaves()[node.leaf_record() as usize];
            if leaf.count > 0 {
                counters.leaf_visits += 1;
                let rays = u64::from(mask.count_ones());
                counters.ray_leaf_visits += rays;
                counters.potential_tests += rays * u64::from(leaf.count);
                done |= visitor.visit(
                    l,
                    p,
                    LeafVisit {
                        triangles: tree.leaf_triangles(leaf),
                        bounds: &leaf.bounds,
                        mask,
                        t_enter: &t_enter,
                        t_exit: &t_exit,
                    },
                );
            }
        }
        if descended {
            continue;
        }
        // Pop the next cell that some ray still needs: one whose entry is not after its hit.
        mask = 0;
        while mask == 0 && top > 0 {
            top -= 1;
            node_index = stack_node[top];
            t_enter[..used].copy_from_slice(&stack_enter[top][..used]);
            t_exit[..used].copy_from_slice(&stack_exit[top][..used]);
            let candidates = stack_mask[top] & !done;
            let best = visitor.best_t();
            for g in 0..groups {
                let bits = group_bits::<L>(candidates, g);
                if bits == 0 {
                    continue;
                }
                let b = g * L::WIDTH;
                let keep = l.load(&t_enter[b..]).le(l.load(&best[b..]));
                mask |= u64::from((keep & l.mask_from_bits(bits)).bits()) << b;
            }
        }
    }
}

/// One packet ray–triangle test, per ISA.
pub(crate) trait LaneTest<L: Lanes> {
    /// Per-group work done once per leaf (the watertight shear).
    type Prepared;
    /// Prepares group `rays`.
    fn prepare(l: L, rays: &LaneRays<L>) -> Self::Prepared;
    /// Tests triangle `i` of `leaf` against the group, hits in `[tmin, tmax]`.
    fn test(
        l: L,
        prepared: &Self::Prepared,
        rays: &LaneRays<L>,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmin: L::F32,
        tmax: L::F32,
    ) -> LaneHits<L>;
}

/// Kensler–Shirley on packets.
pub(crate) struct KsLanes;

impl<L: Lanes> LaneTest<L> for KsLanes {
    type Prepared = ();
    #[inline(always)]
    fn prepare(_: L, _: &LaneRays<L>) {}
    #[inline(always)]
    fn test(
        l: L,
        _: &(),
        rays: &LaneRays<L>,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmin: L::F32,
        tmax: L::F32,
    ) -> LaneHits<L> {
        kensler_shirley::intersect_lanes(l, rays, &leaf.ks[i], tmin, tmax)
    }
}

/// Watertight on packets.
pub(crate) struct WatertightLaneTest;

impl<L: Lanes> LaneTest<L> for WatertightLaneTest {
    type Prepared = WatertightLanes<L>;
    #[inline(always)]
    fn prepare(l: L, rays: &LaneRays<L>) -> WatertightLanes<L> {
        WatertightLanes::new(l, rays)
    }
    #[inline(always)]
    fn test(
        l: L,
        prepared: &WatertightLanes<L>,
        _: &LaneRays<L>,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmin: L::F32,
        tmax: L::F32,
    ) -> LaneHits<L> {
        prepared.intersect(l, &leaf.triangles[i], tmin, tmax)
    }
}

/// Closest hits: the running best per ray lives in the caller's [`HitPacket`], whose `t`
/// starts at each ray's `tmax` and whose triangle ids are carried through the lanes as `f32`
/// bit patterns (a blend moves bits unchanged).
pub(crate) struct ClosestHits<'h, T> {
    pub hits: &'h mut HitPacket,
    /// Ray–triangle tests performed.
    pub tests: u64,
    pub test: core::marker::PhantomData<T>,
}

impl<'h, T> ClosestHits<'h, T> {
    /// Starts `hits` for `p`: no hit, best `t` = each ray's `tmax`.
    pub fn new(hits: &'h mut HitPacket, p: &RayPacket) -> Self {
        *hits = HitPacket::default();
        hits.t[..p.len()].copy_from_slice(&p.tmax[..p.len()]);
        ClosestHits {
            hits,
            tests: 0,
            test: core::marker::PhantomData,
        }
    }

    /// Marks rays that hit nothing with `t = +inf`.
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
    fn visit(&mut self, l: L, p: &RayPacket, visit: LeafVisit<'_>) -> u64 {
        for g in 0..group_count::<L>(p.len()) {
            let bits = group_bits::<L>(visit.mask, g);
            if bits != 0 {
                let count = visit.triangles.ids.len();
                self.tests += u64::from(bits.count_ones()) * count as u64;
                test_group::<L, T>(l, p, g, bits, &visit.triangles, 0..count, self.hits);
            }
        }
        0
    }

    #[inline(always)]
    fn best_t(&self) -> &Column {
        &self.hits.t
    }
}

/// Tests the triangles `range` of `leaf` against the lanes `bits` of group `g`, keeping each
/// lane's closest hit with [`kdbeam_kernels::Hit::is_beaten_by`]'s tie rule.
#[inline(always)]
pub(crate) fn test_group<L: Lanes, T: LaneTest<L>>(
    l: L,
    p: &RayPacket,
    g: usize,
    bits: u32,
    leaf: &LeafTriangles<'_>,
    range: impl Iterator<Item = usize>,
    hits: &mut HitPacket,
) {
    let b = g * L::WIDTH;
    let rays = lane_rays(l, p, g);
    let prepared = T::prepare(l, &rays);
    let act = l.mask_from_bits(bits);
    let tmin = l.load(&p.tmin[b..]);
    let mut best_t = l.load(&hits.t[b..]);
    let mut best_u = l.load(&hits.u[b..]);
    let mut best_v = l.load(&hits.v[b..]);
    let mut best_id = l.load(&bytemuck::cast_slice::<u32, f32>(&hits.triangle)[b..]);
    for i in range {
        let h = T::test(l, &prepared, &rays, leaf, i, tmin, best_t);
        let found = h.mask & act;
        if found.none() {
            continue;
        }
        let id = leaf.ids[i];
        let mut better = (found & h.t.lt(best_t)).bits();
        let ties = (found & h.t.eq(best_t)).bits();
        if ties != 0 {
            for lane in 0..L::WIDTH {
                if ties >> lane & 1 != 0 && id < best_id.extract(lane).to_bits() {
                    better |= 1 << lane;
                }
            }
        }
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
}

/// Any hit: a ray leaves the traversal at its first hit in `[tmin, tmax]`.
pub(crate) struct AnyHits<T> {
    pub tmax: Column,
    /// Ray–triangle tests performed.
    pub tests: u64,
    pub occluded: u64,
    pub test: core::marker::PhantomData<T>,
}

impl<L: Lanes, T: LaneTest<L>> PacketVisitor<L> for AnyHits<T> {
    #[inline(always)]
    fn visit(&mut self, l: L, p: &RayPacket, visit: LeafVisit<'_>) -> u64 {
        let mut found = 0u64;
        for g in 0..group_count::<L>(p.len()) {
            let bits = group_bits::<L>(visit.mask, g);
            if bits == 0 {
                continue;
            }
            let b = g * L::WIDTH;
            let rays = lane_rays(l, p, g);
            let prepared = T::prepare(l, &rays);
            let (tmin, tmax) = (l.load(&p.tmin[b..]), l.load(&p.tmax[b..]));
            let mut open = bits;
            for i in 0..visit.triangles.ids.len() {
                self.tests += u64::from(open.count_ones());
                let h = T::test(l, &prepared, &rays, &visit.triangles, i, tmin, tmax);
                open &= !(h.mask & l.mask_from_bits(open)).bits();
                if open == 0 {
                    break;
                }
            }
            found |= u64::from(bits & !open) << b;
        }
        self.occluded |= found;
        found
    }

    #[inline(always)]
    fn best_t(&self) -> &Column {
        &self.tmax
    }
}

/// Closest hits of the rays of `active` in `p`, written to `hits` (misses and inactive or
/// untraceable rays get [`kdbeam_kernels::Hit::NONE`]).
#[inline(always)]
pub(crate) fn closest<L: Lanes, T: LaneTest<L>>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    active: u64,
    hits: &mut HitPacket,
    counters: &mut PacketCounters,
) {
    let mut visitor = ClosestHits::<T>::new(hits, p);
    for (octant, mask) in octant_masks(p, traceable_mask(p, active))
        .into_iter()
        .enumerate()
    {
        if mask != 0 {
            traverse_octant(l, tree, p, mask, octant, &mut visitor, counters);
        }
    }
    counters.tests += visitor.tests;
    visitor.finish();
}

/// The rays of `active` in `p` that hit anything in `[tmin, tmax]`, as a bit mask.
#[inline(always)]
pub(crate) fn occluded<L: Lanes, T: LaneTest<L>>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    active: u64,
    counters: &mut PacketCounters,
) -> u64 {
    let mut visitor = AnyHits::<T> {
        tmax: p.tmax,
        tests: 0,
        occluded: 0,
        test: core::marker::PhantomData,
    };
    for (octant, mask) in octant_masks(p, traceable_mask(p, active))
        .into_iter()
        .enumerate()
    {
        if mask != 0 {
            traverse_octant(l, tree, p, mask, octant, &mut visitor, counters);
        }
    }
    counters.tests += visitor.tests;
    visitor.occluded
}
