//! Packet kd-tree traversal, written once and generic over the lanes.
//!
//! Up to 64 rays walk the tree together, front to back with a stack (Wald's packet traversal):
//! each ray keeps its own `[t_enter, t_exit]`, a bit mask says which rays are still in the
//! current cell, and a cell is entered when any ray needs it. All rays of one traversal share
//! the sign of each direction component, so near and far children are the same for all of them;
//! a packet whose rays disagree is split by octant first. In every cell a ray is active exactly
//! when the scalar traversal would enter that cell, lane for lane (see
//! [`super::single::traverse`]), so the two find the same hits.

use kdbeam_kernels::beam::{Beam, Survivors};
use kdbeam_kernels::intersect::kensler_shirley;
use kdbeam_kernels::intersect::watertight::WatertightLanes;
use kdbeam_kernels::intersect::{LaneHits, LaneRays};
use kdbeam_kernels::{slab, Aabb, HitPacket, LaneF32, LaneMask, Lanes, RayPacket, MAX_PACKET_RAYS};

use super::culling::Culling;
#[cfg(doc)]
use super::culling::Frustum;
use super::single::{root_bounds, split_intervals, INTERVAL_EPS, STACK_DEPTH};
use crate::kdtree::{KdTree, LeafTriangles};

const N: usize = MAX_PACKET_RAYS;

/// Per-ray `t` values of a packet.
pub(crate) type Column = [f32; N];

/// Work done by packet traversals, summed by callers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PacketCounters {
    /// Packets (after the split by octant) traced.
    pub packets: u64,
    /// Inner nodes entered by a packet.
    pub inner_visits: u64,
    /// Non-empty leaves entered by a packet.
    pub leaf_visits: u64,
    /// Ray–leaf visits: active rays summed over leaf visits.
    pub ray_leaf_visits: u64,
    /// Ray–triangle tests a packet would perform without culling (active rays × triangles).
    pub potential_tests: u64,
    /// Ray–triangle tests performed.
    pub tests: u64,
    /// Leaf visits where a beam was built.
    pub beams: u64,
    /// Tests culled by the side planes (counted with the `stats` feature).
    pub culled_planes: u64,
    /// Tests culled by the near and far planes (counted with the `stats` feature).
    pub culled_distance: u64,
    /// Tests culled by the aperture test (counted with the `stats` feature).
    pub culled_aperture: u64,
    /// Hits found (a ray's closest hit improving; counted with the `stats` feature).
    pub hits: u64,
    /// Leaf visits by number of active rays, 0 to 64 (counted with the `stats` feature).
    pub active_rays: [u64; MAX_PACKET_RAYS + 1],
}

impl Default for PacketCounters {
    fn default() -> Self {
        PacketCounters {
            packets: 0,
            inner_visits: 0,
            leaf_visits: 0,
            ray_leaf_visits: 0,
            potential_tests: 0,
            tests: 0,
            beams: 0,
            culled_planes: 0,
            culled_distance: 0,
            culled_aperture: 0,
            hits: 0,
            active_rays: [0; MAX_PACKET_RAYS + 1],
        }
    }
}

impl PacketCounters {
    /// Adds `o` to `self`.
    pub fn add(&mut self, o: &PacketCounters) {
        self.packets += o.packets;
        self.inner_visits += o.inner_visits;
        self.leaf_visits += o.leaf_visits;
        self.ray_leaf_visits += o.ray_leaf_visits;
        self.potential_tests += o.potential_tests;
        self.tests += o.tests;
        self.beams += o.beams;
        self.culled_planes += o.culled_planes;
        self.culled_distance += o.culled_distance;
        self.culled_aperture += o.culled_aperture;
        self.hits += o.hits;
        for (a, b) in self.active_rays.iter_mut().zip(&o.active_rays) {
            *a += b;
        }
    }

    /// Share of the potential ray–triangle tests that culling eliminated, in percent.
    pub fn eliminated_percent(&self) -> f64 {
        if self.potential_tests == 0 {
            return 0.0;
        }
        100.0 * (1.0 - self.tests as f64 / self.potential_tests as f64)
    }

    /// Share of leaf visits with a single active ray, in percent (with the `stats` feature).
    pub fn single_ray_visits_percent(&self) -> f64 {
        100.0 * self.active_rays[1] as f64 / self.leaf_visits.max(1) as f64
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

/// Lanes `b..b + L::WIDTH` of three per-axis columns (origins, directions or reciprocals).
#[inline(always)]
fn load_axes<L: Lanes>(l: L, columns: &[Column; 3], b: usize) -> [L::F32; 3] {
    [
        l.load(&columns[0][b..]),
        l.load(&columns[1][b..]),
        l.load(&columns[2][b..]),
    ]
}

/// The rays of group `g`.
#[inline(always)]
pub(crate) fn lane_rays<L: Lanes>(l: L, p: &RayPacket, g: usize) -> LaneRays<L> {
    let b = g * L::WIDTH;
    LaneRays {
        org: load_axes(l, &p.org, b),
        dir: load_axes(l, &p.dir, b),
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
    /// Every ray of this traversal (the maskless frustum's rays).
    pub packet_mask: u64,
    /// The largest absolute coordinate of the scene.
    pub scene_bound: f32,
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
}

/// Rays of `active` that can be traced (see [`is_traceable`](super::single::is_traceable)), a group of lanes at a time:
/// finite origin and direction (`|x| < inf`, false for NaN), a direction that is not zero on
/// every axis, and `tmin <= tmax` (false when either is NaN).
#[inline(always)]
pub(crate) fn traceable_mask<L: Lanes>(l: L, p: &RayPacket, active: u64) -> u64 {
    let (inf, zero) = (l.splat(f32::INFINITY), l.splat(0.0));
    let mut traceable = 0u64;
    for g in 0..group_count::<L>(p.len()) {
        let b = g * L::WIDTH;
        let rays = lane_rays(l, p, g);
        // No closures here: inside the ISA's `#[target_feature]` entry they are not inlined.
        let mut finite = l.load(&p.tmin[b..]).le(l.load(&p.tmax[b..]));
        let mut zero_dir = !l.mask_from_bits(0);
        for a in 0..3 {
            finite = finite & rays.org[a].abs().lt(inf) & rays.dir[a].abs().lt(inf);
            zero_dir = zero_dir & rays.dir[a].eq(zero);
        }
        traceable |= u64::from(finite.and_not(zero_dir).bits()) << b;
    }
    traceable & active & p.full_mask()
}

/// The rays of `mask` sorted by the sign bits of their direction: one mask per octant, bit `a`
/// of the octant set for a sign bit on axis `a` (`-0.0` counts as negative, as its reciprocal
/// is `-inf`).
#[inline(always)]
pub(crate) fn octant_masks<L: Lanes>(l: L, p: &RayPacket, mask: u64) -> [u64; 8] {
    let mut octants = [0u64; 8];
    for g in 0..group_count::<L>(p.len()) {
        let bits = group_bits::<L>(mask, g);
        if bits == 0 {
            continue;
        }
        let b = g * L::WIDTH;
        let signs = [
            l.load(&p.dir[0][b..]).sign_bits(),
            l.load(&p.dir[1][b..]).sign_bits(),
            l.load(&p.dir[2][b..]).sign_bits(),
        ];
        for (o, octant) in octants.iter_mut().enumerate() {
            let mut lanes = bits;
            for (a, &sign) in signs.iter().enumerate() {
                lanes &= if o >> a & 1 != 0 { sign } else { !sign };
            }
            *octant |= u64::from(lanes) << b;
        }
    }
    octants
}

/// Traverses `tree` with the rays of `mask`, which must all be traceable and share the
/// direction signs `octant` (bit `a` set for a negative component on axis `a`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn traverse_octant<L: Lanes, V: PacketVisitor<L>>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    mut mask: u64,
    octant: usize,
    visitor: &mut V,
    stack: &mut Stack,
    counters: &mut PacketCounters,
) {
    let groups = group_count::<L>(p.len());
    let used = groups * L::WIDTH;
    let mut inv = [[0f32; N]; 3];
    let mut err = [[0f32; N]; 3];
    let max = l.splat(f32::MAX);
    for a in 0..3 {
        for g in 0..groups {
            let b = g * L::WIDTH;
            let i = l.splat(1.0) / l.load(&p.dir[a][b..]);
            l.store(i, &mut inv[a][b..]);
            l.store(
                (l.load(&p.org[a][b..]) * i).abs().min(max),
                &mut err[a][b..],
            );
        }
    }
    let mut t_enter = [0f32; N];
    let mut t_exit = [0f32; N];
    let bounds = root_bounds(tree);
    let scene_bound = bounds.min.abs().max(bounds.max.abs()).max_element();
    let mut clipped = 0u64;
    for g in 0..groups {
        let bits = group_bits::<L>(mask, g);
        if bits == 0 {
            continue;
        }
        let b = g * L::WIDTH;
        let org = load_axes(l, &p.org, b);
        let iv = load_axes(l, &inv, b);
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
    let packet_mask = mask;
    counters.packets += 1;

    let nodes = tree.nodes();
    let mut stack_node = [0u32; STACK_DEPTH];
    let mut stack_mask = [0u64; STACK_DEPTH];
    let Stack {
        enter: stack_enter,
        exit: stack_exit,
    } = stack;
    let mut top = 0;
    let mut node_index = 0u32;
    let mut done = 0u64;
    let mut near_exit = [0f32; N];
    let mut far_enter = [0f32; N];
    while mask != 0 {
        let node = nodes[node_index as usize];
        let mut descended = false;
        if !node.is_leaf() {
            counters.inner_visits += 1;
            let axis = node.axis();
            let split = l.splat(node.split());
            let eps = l.splat(INTERVAL_EPS);
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
                let (ne, fe) = split_intervals(ts, tn, tf, l.load(&err[axis][b..]), eps, max);
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
                let visit = LeafVisit {
                    triangles: tree.leaf_triangles(leaf),
                    bounds: &leaf.bounds,
                    mask,
                    packet_mask,
                    scene_bound,
                };
                done |= visit_leaf(l, p, visit, visitor, counters);
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

/// Inner nodes a whole-packet traversal may visit before it hands its rays to the per-ray
/// traversal: about ten times what an 8×8 primary packet visits on the bunny (18 on average at
/// ci_over_ct 0.03), far fewer than a diverging packet can (26,951 for four rays on the
/// icosphere).
pub(crate) const INTERVAL_NODE_BUDGET: u32 = 192;

/// Traverses `tree` with the rays of `mask` (traceable, sharing the direction signs `octant`)
/// as one interval of `t`: the whole-packet traversal of [`Frustum::Packet`].
///
/// The packet carries one `[t_enter, t_exit]` that contains every ray's own interval in the
/// cell. At a split `s` on axis `a`, every ray's `t_split = (s − o)·inv` (rounded as
/// [`split_intervals`] rounds it) lies in `[lo, hi]`, the extremes of the four corner products
/// of `s − [o_min, o_max]` and `[inv_min, inv_max]`: rounding is monotonic in each operand, so
/// the extremes over the box are at its corners. Widened by the largest slack any ray gets,
/// the near child is entered when `t_enter <= hi + slack` (up to `min(t_exit, hi + slack)`)
/// and the far child when `lo − slack <= t_exit` (from `max(t_enter, lo − slack)`): a superset
/// of the cells [`traverse_octant`] would visit with any of the rays, with bounds that contain
/// theirs. A NaN product (an origin in the plane, a direction parallel to it) keeps both
/// children whole, as the per-ray traversal does. A cell is skipped once its `t_enter` lies
/// after every ray's best hit. In a leaf, the rays are those whose segment up to their best hit
/// meets the leaf's tight box ([`rays_in_box`]: one slab test per group of lanes), which may
/// include rays that do not cross the leaf's cell: such a ray can only find real hits of its
/// own, and the visitor keeps the closest (ties to the smaller id). So every test the per-ray
/// traversal makes is made here too, and a ray's hit is never farther than there; it differs
/// only where an extra test finds a closer or tie-winning hit (an edge or vertex shared with a
/// triangle of a leaf the ray's own traversal does not enter).
///
/// An incoherent packet's interval covers far more cells than its rays cross. After
/// [`INTERVAL_NODE_BUDGET`] inner nodes the traversal stops and returns the rays still
/// unfinished, for [`traverse_octant`] to trace again (hits found so far stay: they are real,
/// and the per-ray traversal only improves on them); `0` when it finished.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn traverse_octant_interval<L: Lanes, V: PacketVisitor<L>>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    mask: u64,
    octant: usize,
    visitor: &mut V,
    counters: &mut PacketCounters,
) -> u64 {
    let groups = group_count::<L>(p.len());
    let bounds = root_bounds(tree);
    let scene_bound = bounds.min.abs().max(bounds.max.abs()).max_element();
    let (inf, ninf, max) = (
        l.splat(f32::INFINITY),
        l.splat(f32::NEG_INFINITY),
        l.splat(f32::MAX),
    );
    // Over the rays inside the root box: ranges of origin and reciprocal direction, the largest
    // `|o·inv|` per axis, and the packet's interval.
    let (mut o_lo, mut o_hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let (mut inv_lo, mut inv_hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let mut err = [0f32; 3];
    let (mut t_enter, mut t_exit) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut live_mask = 0u64;
    let mut inv_columns = [[0f32; N]; 3];
    for g in 0..groups {
        let bits = group_bits::<L>(mask, g);
        if bits == 0 {
            continue;
        }
        let b = g * L::WIDTH;
        let rays = lane_rays(l, p, g);
        let inv = [
            l.splat(1.0) / rays.dir[0],
            l.splat(1.0) / rays.dir[1],
            l.splat(1.0) / rays.dir[2],
        ];
        for a in 0..3 {
            l.store(inv[a], &mut inv_columns[a][b..]);
        }
        let (hit, tn, tf) = slab::slab_lanes(
            l,
            &rays.org,
            &inv,
            l.load(&p.tmin[b..]),
            l.load(&p.tmax[b..]),
            &bounds,
        );
        let live = hit & l.mask_from_bits(bits);
        if live.none() {
            continue;
        }
        live_mask |= u64::from(live.bits()) << b;
        t_enter = t_enter.min(L::F32::select(live, tn, inf).reduce_min());
        t_exit = t_exit.max(L::F32::select(live, tf, ninf).reduce_max());
        for a in 0..3 {
            o_lo[a] = o_lo[a].min(L::F32::select(live, rays.org[a], inf).reduce_min());
            o_hi[a] = o_hi[a].max(L::F32::select(live, rays.org[a], ninf).reduce_max());
            inv_lo[a] = inv_lo[a].min(L::F32::select(live, inv[a], inf).reduce_min());
            inv_hi[a] = inv_hi[a].max(L::F32::select(live, inv[a], ninf).reduce_max());
            let e = (rays.org[a] * inv[a]).abs().min(max);
            err[a] = err[a].max(L::F32::select(live, e, l.splat(0.0)).reduce_max());
        }
    }
    if live_mask == 0 {
        return 0;
    }
    counters.packets += 1;

    let nodes = tree.nodes();
    let mut stack = [(0u32, 0f32, 0f32); STACK_DEPTH];
    let mut top = 0;
    let mut node_index = 0u32;
    let mut done = 0u64;
    let mut budget = INTERVAL_NODE_BUDGET;
    loop {
        let node = nodes[node_index as usize];
        if !node.is_leaf() {
            if budget == 0 {
                return live_mask & !done;
            }
            budget -= 1;
            counters.inner_visits += 1;
            let a = node.axis();
            let (lo, hi) = split_range(node.split(), [o_lo[a], o_hi[a]], [inv_lo[a], inv_hi[a]]);
            let slack =
                (lo.abs().max(hi.abs()).min(f32::MAX) + err[a]).min(f32::MAX) * INTERVAL_EPS;
            let (near_exit, far_enter) = ((hi + slack).min(t_exit), (lo - slack).max(t_enter));
            let (near, far) = if octant >> a & 1 != 0 {
                (node.above_child(), node_index + 1)
            } else {
                (node_index + 1, node.above_child())
            };
            let (to_near, to_far) = (t_enter <= near_exit, far_enter <= t_exit);
            if to_near {
                if to_far {
                    stack[top] = (far, far_enter, t_exit);
                    top += 1;
                }
                (node_index, t_exit) = (near, near_exit);
                continue;
            }
            if to_far {
                (node_index, t_enter) = (far, far_enter);
                continue;
            }
        } else {
            let leaf = &tree.leaves()[node.leaf_record() as usize];
            let active = if leaf.count > 0 {
                rays_in_box(
                    l,
                    p,
                    &inv_columns,
                    live_mask & !done,
                    visitor.best_t(),
                    &leaf.bounds,
                )
            } else {
                0
            };
            if active != 0 {
                let visit = LeafVisit {
                    triangles: tree.leaf_triangles(leaf),
                    bounds: &leaf.bounds,
                    mask: active,
                    packet_mask: live_mask,
                    scene_bound,
                };
                done |= visit_leaf(l, p, visit, visitor, counters);
            }
        }
        // Pop the next cell that some ray still needs: one entered before its best hit.
        let active = live_mask & !done;
        let best = visitor.best_t();
        let mut latest = f32::NEG_INFINITY;
        for g in 0..groups {
            let bits = group_bits::<L>(active, g);
            if bits != 0 {
                let b = g * L::WIDTH;
                let t = L::F32::select(l.mask_from_bits(bits), l.load(&best[b..]), ninf);
                latest = latest.max(t.reduce_max());
            }
        }
        loop {
            if top == 0 {
                return 0;
            }
            top -= 1;
            let (n, enter, exit) = stack[top];
            if enter <= latest {
                (node_index, t_enter, t_exit) = (n, enter, exit);
                break;
            }
        }
    }
}

/// The rays of `mask` whose segment `[tmin, best]` meets `bounds`: the only ones that can have
/// a hit in a leaf with that tight box. A hit point lies on a triangle's part clipped to a leaf
/// the ray crosses, inside that leaf's tight box, so whatever leaf holds it sees the ray.
///
/// Rounding is absorbed as in [`split_intervals`]: the box's entry and exit `t`, and the
/// segment's ends, are each widened by `(|t| + max |o·inv|)·INTERVAL_EPS`, far more than the
/// few ulps by which `(plane − o)·inv` (which cancels when `|o|` is large) or a reported hit
/// can be off.
#[inline(always)]
fn rays_in_box<L: Lanes>(
    l: L,
    p: &RayPacket,
    inv: &[Column; 3],
    mask: u64,
    best: &Column,
    bounds: &Aabb,
) -> u64 {
    let (max, eps) = (l.splat(f32::MAX), l.splat(INTERVAL_EPS));
    let (ninf, inf) = (l.splat(f32::NEG_INFINITY), l.splat(f32::INFINITY));
    let mut inside = 0u64;
    for g in 0..group_count::<L>(p.len()) {
        let bits = group_bits::<L>(mask, g);
        if bits == 0 {
            continue;
        }
        let b = g * L::WIDTH;
        let org = load_axes(l, &p.org, b);
        let iv = load_axes(l, inv, b);
        let err = (org[0] * iv[0])
            .abs()
            .max((org[1] * iv[1]).abs())
            .max((org[2] * iv[2]).abs())
            .min(max);
        let (_, near, far) = slab::slab_lanes(l, &org, &iv, ninf, inf, bounds);
        let (tmin, tmax) = (l.load(&p.tmin[b..]), l.load(&best[b..]));
        let lo = (near - t_slack(near, err, max, eps)).max(tmin - t_slack(tmin, err, max, eps));
        let hi = (far + t_slack(far, err, max, eps)).min(tmax + t_slack(tmax, err, max, eps));
        inside |= u64::from((lo.le(hi) & l.mask_from_bits(bits)).bits()) << b;
    }
    inside
}

/// The rounding slack of a slab `t` in [`rays_in_box`]: `(|t| + err)·eps`, finite for any `t`.
#[inline(always)]
fn t_slack<F: LaneF32>(t: F, err: F, max: F, eps: F) -> F {
    (t.abs().min(max) + err).min(max) * eps
}

/// The range of `(split − o)·inv` rounded in f32, over `o` in `[o_min, o_max]` and `inv` in
/// `[inv_min, inv_max]`: the extremes of the four corner products (f32 subtraction and
/// multiplication are monotonic in each operand). `(−inf, +inf)` when a product is NaN
/// (`0·inf`).
#[inline(always)]
fn split_range(split: f32, [o_min, o_max]: [f32; 2], [inv_min, inv_max]: [f32; 2]) -> (f32, f32) {
    let (d_min, d_max) = (split - o_max, split - o_min);
    let products = [
        d_min * inv_min,
        d_min * inv_max,
        d_max * inv_min,
        d_max * inv_max,
    ];
    let mut range = (f32::INFINITY, f32::NEG_INFINITY);
    for t in products {
        if t.is_nan() {
            return (f32::NEG_INFINITY, f32::INFINITY);
        }
        range = (range.0.min(t), range.1.max(t));
    }
    range
}

/// Counts a leaf visit of the rays of `visit.mask` and hands it to `visitor`; returns the rays
/// the visitor has finished.
#[inline(always)]
fn visit_leaf<L: Lanes, V: PacketVisitor<L>>(
    l: L,
    p: &RayPacket,
    visit: LeafVisit<'_>,
    visitor: &mut V,
    counters: &mut PacketCounters,
) -> u64 {
    counters.leaf_visits += 1;
    let rays = u64::from(visit.mask.count_ones());
    counters.ray_leaf_visits += rays;
    counters.potential_tests += rays * visit.triangles.ids.len() as u64;
    #[cfg(feature = "stats")]
    {
        counters.active_rays[rays as usize] += 1;
    }
    visitor.visit(l, p, visit, counters)
}

/// The per-ray intervals of a traversal stack: 32 KiB, kept per thread rather than zeroed on
/// the machine stack for every packet.
pub(crate) struct Stack {
    enter: [Column; STACK_DEPTH],
    exit: [Column; STACK_DEPTH],
}

thread_local! {
    static STACK: std::cell::RefCell<Box<Stack>> = std::cell::RefCell::new(Box::new(Stack {
        enter: [[0.0; N]; STACK_DEPTH],
        exit: [[0.0; N]; STACK_DEPTH],
    }));
}

/// Runs `f` with this thread's traversal stack. Call it outside the ISA's `#[target_feature]`
/// entry point: the closure is not inlined.
pub(crate) fn with_stack<R>(f: impl FnOnce(&mut Stack) -> R) -> R {
    STACK.with(|s| f(&mut s.borrow_mut()))
}

/// One packet ray–triangle test, per ISA.
pub(crate) trait LaneTest<L: Lanes> {
    /// Per-group work done once per leaf (the watertight shear).
    type Prepared;
    /// Prepares group `rays`.
    fn prepare(l: L, rays: &LaneRays<L>) -> Self::Prepared;
    /// Tests triangle `i` of `leaf` against the group, hits in `[tmin, tmax]`. `inside`: the
    /// beam proved every ray crosses the triangle, so its barycentric checks may be skipped.
    #[allow(clippy::too_many_arguments)]
    fn test(
        l: L,
        prepared: &Self::Prepared,
        rays: &LaneRays<L>,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmin: L::F32,
        tmax: L::F32,
        inside: bool,
    ) -> LaneHits<L>;
}

/// Kensler–Shirley on packets.
/// A ray–triangle test at every lane width: the [`LaneTest`] for each `Lanes`, so that a task
/// can name its test before the ISA is chosen.
pub(crate) trait LaneTestFamily {
    /// The test on lanes `L`.
    type For<L: Lanes>: LaneTest<L>;
}

impl LaneTestFamily for KsLanes {
    type For<L: Lanes> = KsLanes;
}

impl LaneTestFamily for WatertightLaneTest {
    type For<L: Lanes> = WatertightLaneTest;
}

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
        inside: bool,
    ) -> LaneHits<L> {
        let h = kensler_shirley::intersect_lanes(l, rays, &leaf.ks[i], tmin, tmax);
        if inside {
            // Reshetov (after Dmitriev et al.): all four corner rays hit the triangle, so every
            // ray does; only the distance decides. The barycentrics the kernel computed are
            // the same; the margin of the corner test keeps them inside.
            LaneHits {
                mask: h.t.ge(tmin) & h.t.le(tmax),
                ..h
            }
        } else {
            h
        }
    }
}

/// Watertight on packets (the beam's "inside" shortcut is not taken: the watertight verdict
/// stays the edge functions' own).
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
        _: bool,
    ) -> LaneHits<L> {
        prepared.intersect(l, &leaf.triangles[i], tmin, tmax)
    }
}

/// The beam for this leaf visit, or `None` when the visit is tested unculled (culling off, too
/// few triangles or rays for a beam to pay, or no prevalent axis).
#[inline(always)]
fn leaf_beam<L: Lanes>(
    l: L,
    p: &RayPacket,
    visit: &LeafVisit<'_>,
    culling: &Culling,
    best: Option<(&Column, u64)>,
) -> Option<Beam<L>> {
    culling
        .beam_rays(visit.triangles.ids.len(), visit.mask, visit.packet_mask)
        .and_then(|used| {
            Beam::new(
                l,
                p,
                used,
                visit.bounds,
                best,
                culling.stages(),
                visit.scene_bound,
            )
        })
}

/// The blocks of up to 64 triangles of a leaf that hold triangles to test, culled by a beam
/// when there is one: `(first triangle, survivors)`. An iterator rather than a callback, so
/// that everything stays inlined into the ISA's `#[target_feature]` entry point.
struct SurvivorBlocks<'v, L: Lanes> {
    beam: Option<Beam<L>>,
    triangles: &'v [kdbeam_kernels::Triangle],
    next: usize,
    rays: u64,
    /// Tests the survivors cost (active rays × triangles).
    tests: u64,
    #[cfg(feature = "stats")]
    culled: kdbeam_kernels::beam::CullCounts,
}

impl<'v, L: Lanes> SurvivorBlocks<'v, L> {
    #[inline(always)]
    fn new(beam: Option<Beam<L>>, visit: &LeafVisit<'v>, counters: &mut PacketCounters) -> Self {
        counters.beams += u64::from(beam.is_some());
        SurvivorBlocks {
            beam,
            triangles: visit.triangles.triangles,
            next: 0,
            rays: u64::from(visit.mask.count_ones()),
            tests: 0,
            #[cfg(feature = "stats")]
            culled: Default::default(),
        }
    }

    /// Adds what was culled to `counters` and returns the tests performed.
    #[inline(always)]
    fn finish(self, counters: &mut PacketCounters) -> u64 {
        #[cfg(feature = "stats")]
        {
            counters.culled_planes += self.rays * u64::from(self.culled.planes);
            counters.culled_distance += self.rays * u64::from(self.culled.distance);
            counters.culled_aperture += self.rays * u64::from(self.culled.aperture);
        }
        let _ = counters;
        self.tests
    }
}

impl<L: Lanes> Iterator for SurvivorBlocks<'_, L> {
    type Item = (usize, Survivors);

    #[inline(always)]
    fn next(&mut self) -> Option<(usize, Survivors)> {
        while self.next < self.triangles.len() {
            let first = self.next;
            let end = (first + 64).min(self.triangles.len());
            self.next = end;
            let s = match &mut self.beam {
                Some(beam) => beam.cull(&self.triangles[first..end]),
                None => {
                    let n = end - first;
                    let all = if n == 64 { u64::MAX } else { (1 << n) - 1 };
                    Survivors {
                        mask: all,
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

/// Closest hits: the running best per ray lives in the caller's [`HitPacket`], whose `t`
/// starts at each ray's `tmax` and whose triangle ids are carried through the lanes as `f32`
/// bit patterns (a blend moves bits unchanged).
pub(crate) struct ClosestHits<'h, T> {
    hits: &'h mut HitPacket,
    culling: Culling,
    /// Rays that have a hit.
    has_hit: u64,
    /// Ray–triangle tests performed.
    pub(super) tests: u64,
    test: core::marker::PhantomData<T>,
}

impl<'h, T> ClosestHits<'h, T> {
    /// Starts `hits` for `p`: no hit, best `t` = each ray's `tmax`.
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
        );
        let mut blocks = SurvivorBlocks::new(beam, &visit, counters);
        // `next` is called directly: a `for` loop goes through `&mut I`'s forwarding `next`,
        // which is only `#[inline]` and may stay out of the ISA's entry point.
        #[allow(clippy::while_let_on_iterator)]
        while let Some((first, survivors)) = blocks.next() {
            for g in 0..group_count::<L>(p.len()) {
                let bits = group_bits::<L>(visit.mask, g);
                if bits != 0 {
                    let better = test_group::<L, T>(
                        l,
                        p,
                        g,
                        bits,
                        &visit.triangles,
                        first,
                        survivors,
                        self.hits,
                    );
                    self.has_hit |= u64::from(better) << (g * L::WIDTH);
                    let tested = survivors.mask.count_ones();
                    let mut lanes = bits;
                    while lanes != 0 {
                        self.hits.tests[g * L::WIDTH + lanes.trailing_zeros() as usize] += tested;
                        lanes &= lanes - 1;
                    }
                    #[cfg(feature = "stats")]
                    {
                        counters.hits += u64::from(better.count_ones());
                    }
                }
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

/// Tests the triangles `first + i` for each bit `i` of `survivors.mask` against the lanes
/// `bits` of group `g`, keeping each lane's closest hit with
/// [`kdbeam_kernels::Hit::is_beaten_by`]'s tie rule. Returns the lanes whose hit improved.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn test_group<L: Lanes, T: LaneTest<L>>(
    l: L,
    p: &RayPacket,
    g: usize,
    bits: u32,
    leaf: &LeafTriangles<'_>,
    first: usize,
    survivors: Survivors,
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
        let h = T::test(l, &prepared, &rays, leaf, i, tmin, best_t, inside);
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

/// Any hit: a ray leaves the traversal at its first hit in `[tmin, tmax]`.
pub(crate) struct AnyHits<T> {
    tmax: Column,
    culling: Culling,
    /// Ray–triangle tests performed.
    tests: u64,
    occluded: u64,
    test: core::marker::PhantomData<T>,
}

impl<L: Lanes, T: LaneTest<L>> PacketVisitor<L> for AnyHits<T> {
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
        let beam = leaf_beam(l, p, &visit, &self.culling, None);
        let mut blocks = SurvivorBlocks::new(beam, &visit, counters);
        #[allow(clippy::while_let_on_iterator)]
        while let Some((first, s)) = blocks.next() {
            for g in 0..group_count::<L>(p.len()) {
                let before = group_bits::<L>(open, g);
                let mut bits = before;
                if bits == 0 {
                    continue;
                }
                let b = g * L::WIDTH;
                let rays = lane_rays(l, p, g);
                let prepared = T::prepare(l, &rays);
                let (tmin, tmax) = (l.load(&p.tmin[b..]), l.load(&p.tmax[b..]));
                let mut rest = s.mask;
                while rest != 0 && bits != 0 {
                    let j = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    tests += u64::from(bits.count_ones());
                    let inside = s.inside >> j & 1 != 0;
                    let tris = &visit.triangles;
                    let h = T::test(l, &prepared, &rays, tris, first + j, tmin, tmax, inside);
                    bits &= !(h.mask & l.mask_from_bits(bits)).bits();
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

/// Traverses `tree` with the traceable rays of `active` in `p`, one sub-packet per octant of
/// direction signs; ray by ray ([`traverse_octant`]) or, with `INTERVAL`, as one interval
/// ([`traverse_octant_interval`]).
#[inline(always)]
fn traverse_packet<L: Lanes, V: PacketVisitor<L>, const INTERVAL: bool>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    active: u64,
    visitor: &mut V,
    stack: &mut Stack,
    counters: &mut PacketCounters,
) {
    let octants = octant_masks(l, p, traceable_mask(l, p, active));
    for (octant, mask) in octants.into_iter().enumerate() {
        if mask == 0 {
            continue;
        }
        let per_ray = if INTERVAL {
            traverse_octant_interval(l, tree, p, mask, octant, visitor, counters)
        } else {
            mask
        };
        if per_ray != 0 {
            traverse_octant(l, tree, p, per_ray, octant, visitor, stack, counters);
        }
    }
}

/// Closest hits of the rays of `active` in `p`, written to `hits` (misses and inactive or
/// untraceable rays get [`kdbeam_kernels::Hit::NONE`]). `INTERVAL` must be
/// `culling.interval_traversal()`: a type parameter, so that each entry point compiles one
/// traversal (a single entry holding every variant outgrows LLVM's inlining budget, and the
/// lane intrinsics then stop being inlined).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn closest<L: Lanes, T: LaneTest<L>, const INTERVAL: bool>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    active: u64,
    culling: Culling,
    hits: &mut HitPacket,
    stack: &mut Stack,
    counters: &mut PacketCounters,
) {
    let mut visitor = ClosestHits::<T>::new(hits, p, culling);
    traverse_packet::<L, _, INTERVAL>(l, tree, p, active, &mut visitor, stack, counters);
    counters.tests += visitor.tests;
    visitor.finish();
}

/// The rays of `active` in `p` that hit anything in `[tmin, tmax]`, as a bit mask (`INTERVAL`
/// as in [`closest`]).
#[inline(always)]
pub(crate) fn occluded<L: Lanes, T: LaneTest<L>, const INTERVAL: bool>(
    l: L,
    tree: &KdTree,
    p: &RayPacket,
    active: u64,
    culling: Culling,
    stack: &mut Stack,
    counters: &mut PacketCounters,
) -> u64 {
    let mut visitor = AnyHits::<T> {
        tmax: p.tmax,
        culling,
        tests: 0,
        occluded: 0,
        test: core::marker::PhantomData,
    };
    traverse_packet::<L, _, INTERVAL>(l, tree, p, active, &mut visitor, stack, counters);
    counters.tests += visitor.tests;
    visitor.occluded
}
