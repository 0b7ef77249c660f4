//! The whole-packet interval traversal of [`Frustum::Packet`]: one `[t_enter, t_exit]` for the
//! whole packet, through the tree's wide nodes (or its binary ones), and a slab test per leaf
//! to find the rays that can hit there.

use std::cell::Cell;

use arrayvec::ArrayVec;

use kdbeam_kernels::beam::BeamRays;
use kdbeam_kernels::groups::{group_bits, lane_rays, load_axes, take_group};
use kdbeam_kernels::{slab, Aabb, LaneF32, LaneMask, Lanes, RayPacket};

#[cfg(doc)]
use super::per_ray::traverse_octant;
use super::visit::{visit_leaf, LeafVisit, PacketVisitor};
use super::{Column, Traversal};
#[cfg(doc)]
use crate::kdtree::WideNode;
use crate::kdtree::{LeafRecord, WideChild, WIDE, WIDE_STACK};
#[cfg(doc)]
use crate::trace::culling::Frustum;
#[cfg(doc)]
use crate::trace::single::split_intervals;
use crate::trace::single::{root_bounds, INTERVAL_EPS, STACK_DEPTH};
use crate::trace::wide::first_by_entry;

/// Inner nodes a whole-packet traversal may visit before it hands its rays to the per-ray
/// traversal: several times what a coherent primary packet visits, and far fewer than the
/// interval of a diverging packet can cover (its bounds then span most of the tree).
pub(crate) const INTERVAL_NODE_BUDGET: u32 = 192;

/// Traverses `tree` with the rays of `mask` (traceable, sharing the direction signs `octant`)
/// as one interval of `t`: the whole-packet traversal of [`Frustum::Packet`].
///
/// Where the packet's ranges of origin and reciprocal direction are finite it steps through
/// the tree's wide nodes, a vector of child boxes per step ([`traverse_wide`]), as Embree's
/// coherent traversal steps a packet's frustum through its BVH. Otherwise (a ray with a
/// direction component zero or nearly so) it steps through the binary kd-tree, as follows.
/// The packet carries one `[t_enter, t_exit]` that contains every ray's own interval in the
/// cell. At a split `s` on axis `a`, every ray's `t_split = (s − o)·inv` (rounded as
/// [`split_intervals`] rounds it) lies in `[lo, hi]`, the extremes of the four corner products
/// of `s − [o_min, o_max]` and `[inv_min, inv_max]`: rounding is monotonic in each operand, so
/// the extremes over the box are at its corners. Widened by the largest slack any ray gets,
/// the near child is entered when `t_enter <= hi + slack` (up to `min(t_exit, hi + slack)`)
/// and the far child when `lo − slack <= t_exit` (from `max(t_enter, lo − slack)`): a superset
/// of the cells [`traverse_octant`] would visit with any of the rays, with bounds that contain
/// theirs. A NaN product (an origin in the plane, a direction parallel to it) keeps both
/// children whole, as the per-ray traversal does. A child its parent marks as an empty leaf is
/// never entered (it has nothing to test), and a cell is skipped once its `t_enter` lies
/// after every ray's best hit. In a leaf, the rays are those whose segment up to their best hit
/// meets the leaf's tight box ([`rays_in_box`]: one slab test per group of lanes), which may
/// include rays that do not cross the leaf's cell: such a ray can only find real hits of its
/// own, and the visitor keeps the closest (ties to the smaller id). So every test the per-ray
/// traversal makes is made here too, and a ray's hit is never farther than there; it differs
/// only where an extra test finds a closer or tie-winning hit (an edge or vertex shared with a
/// triangle of a leaf the ray's own traversal does not enter).
///
/// An incoherent packet's interval covers far more cells than its rays cross. After
/// [`INTERVAL_NODE_BUDGET`] inner nodes (a third as many wide nodes; for closest hits only
/// before any leaf test, for any-hit rays at any point) the traversal stops and returns the
/// rays still unfinished, for [`traverse_octant`] to trace again (hits found so far stay: they
/// are real, and the per-ray traversal only improves on them); `0` when it finished.
/// `reciprocals` is scratch for the rays' reciprocal directions.
#[inline(always)]
pub(crate) fn traverse_octant_interval<L: Lanes, V: PacketVisitor<L>>(
    t: &mut Traversal<'_, L, V>,
    mask: u64,
    octant: usize,
    reciprocals: &mut [Column; 3],
) -> u64 {
    let rays = IntervalRays::new(t.l, t.packet, mask, &root_bounds(t.tree), reciprocals);
    if rays.live == 0 {
        return 0;
    }
    if rays.has_finite_ranges() {
        traverse_wide(t, &rays, octant)
    } else {
        traverse_binary(t, &rays, octant)
    }
}

/// What the whole-packet traversal knows of its rays: the ranges of origin and reciprocal
/// direction over the rays inside the root box, the largest `|o·inv|` per axis, the packet's
/// interval `[t_enter, t_exit]`, which rays are inside, and every ray's reciprocal.
struct IntervalRays<'a> {
    o: [[f32; 2]; 3],
    inv: [[f32; 2]; 3],
    err: [f32; 3],
    t_enter: f32,
    t_exit: f32,
    live: u64,
    inv_columns: &'a [Column; 3],
}

impl<'a> IntervalRays<'a> {
    /// The summary of the rays of `mask` of `p` (traceable, one octant) clipped to `bounds`;
    /// their reciprocal directions are written to `inv_columns` (the lanes of `mask` only).
    #[inline(always)]
    fn new<L: Lanes>(
        l: L,
        p: &RayPacket,
        mask: u64,
        bounds: &Aabb,
        inv_columns: &'a mut [Column; 3],
    ) -> Self {
        let (inf, ninf, max) = (
            l.splat(f32::INFINITY),
            l.splat(f32::NEG_INFINITY),
            l.splat(f32::MAX),
        );
        // Kept lane-wise over the groups and reduced once at the end.
        let (mut o_lo, mut o_hi) = ([inf; 3], [ninf; 3]);
        let (mut inv_lo, mut inv_hi) = ([inf; 3], [ninf; 3]);
        let mut err = [l.splat(0.0); 3];
        let (mut enter_lo, mut exit_hi) = (inf, ninf);
        let mut live_mask = 0u64;
        let mut rest = mask;
        while rest != 0 {
            let g = take_group::<L>(&mut rest);
            let bits = group_bits::<L>(mask, g);
            let b = g * L::WIDTH;
            let rays = lane_rays(l, p, g);
            let inv = [
                l.splat(1.0) / rays.direction[0],
                l.splat(1.0) / rays.direction[1],
                l.splat(1.0) / rays.direction[2],
            ];
            for a in 0..3 {
                l.store(inv[a], &mut inv_columns[a][b..]);
            }
            let (hit, tn, tf) = slab::slab_lanes(
                l,
                &rays.origin,
                &inv,
                l.load(&p.tmin[b..]),
                l.load(&p.tmax[b..]),
                bounds,
            );
            let live = hit & l.mask_from_bits(bits);
            if live.none() {
                continue;
            }
            live_mask |= u64::from(live.bits()) << b;
            enter_lo = enter_lo.min(L::F32::select(live, tn, inf));
            exit_hi = exit_hi.max(L::F32::select(live, tf, ninf));
            for a in 0..3 {
                o_lo[a] = o_lo[a].min(L::F32::select(live, rays.origin[a], inf));
                o_hi[a] = o_hi[a].max(L::F32::select(live, rays.origin[a], ninf));
                inv_lo[a] = inv_lo[a].min(L::F32::select(live, inv[a], inf));
                inv_hi[a] = inv_hi[a].max(L::F32::select(live, inv[a], ninf));
                let e = (rays.origin[a] * inv[a]).abs().min(max);
                err[a] = err[a].max(L::F32::select(live, e, l.splat(0.0)));
            }
        }
        let (o_lo, o_hi) = (axes_min(o_lo), axes_max(o_hi));
        let (inv_lo, inv_hi) = (axes_min(inv_lo), axes_max(inv_hi));
        IntervalRays {
            o: [0, 1, 2].map(|a| [o_lo[a], o_hi[a]]),
            inv: [0, 1, 2].map(|a| [inv_lo[a], inv_hi[a]]),
            err: axes_max(err),
            t_enter: enter_lo.reduce_min(),
            t_exit: exit_hi.reduce_max(),
            live: live_mask,
            inv_columns,
        }
    }

    /// Are the ranges of origin and reciprocal finite on every axis? Then no corner product of
    /// a box plane in [`traverse_wide`] is NaN: the planes are finite, or the `±inf` of a
    /// missing child.
    #[inline(always)]
    fn has_finite_ranges(&self) -> bool {
        self.o
            .iter()
            .chain(&self.inv)
            .all(|r| r[0].is_finite() && r[1].is_finite())
    }
}

/// [`traverse_octant_interval`] of the rays summed up in `rays` (of finite ranges) by the
/// tree's wide nodes ([`WideNode`]): a step clips the packet's interval against the boxes of
/// all children of a node at once.
///
/// On each axis a ray enters a child's box at `(plane − o)·inv` of the box's entry plane and
/// leaves it at that of its exit plane; over the packet's ranges of `o` and `inv` those lie
/// between the extremes of the four corner products (f32 rounding is monotonic in each
/// operand, as in [`split_range`]). So the packet's interval in the box, the largest smallest
/// entry and the smallest largest exit over the axes within `[t_enter, t_exit]`, holds every
/// ray's, and is widened by the slack of [`rays_in_box`]. A child's box is the padded union of
/// the tight boxes of its non-empty leaves, so every leaf whose tight box a ray's segment meets
/// is entered unless the packet's entry lies after every unfinished ray's best hit: the leaves
/// the binary traversal would test those rays in, and no empty one. The children are taken
/// nearest entry first, or farthest first for any-hit rays ([`PacketVisitor::FARTHEST_FIRST`],
/// for the reason [`crate::trace::wide`] gives).
#[inline(always)]
fn traverse_wide<L: Lanes, V: PacketVisitor<L>>(
    t: &mut Traversal<'_, L, V>,
    rays: &IntervalRays<'_>,
    octant: usize,
) -> u64 {
    let (l, tree) = (t.l, t.tree);
    let nodes = tree.wide_nodes().nodes();
    let live_mask = rays.live;
    if nodes.is_empty() {
        return 0;
    }
    let bounds = root_bounds(tree);
    let scene_bound = bounds.min.abs().max(bounds.max.abs()).max_element();
    t.counters.packets += 1;
    let w = l.up_to_8();
    // The rows of a node's planes the packet enters and leaves its children's boxes by: `min`
    // for a positive direction.
    let (mut enter_rows, mut exit_rows) = ([0; 3], [0; 3]);
    for a in 0..3 {
        let backwards = octant >> a & 1;
        (enter_rows[a], exit_rows[a]) = (a + 3 * backwards, a + 3 - 3 * backwards);
    }
    let splat = |x: [[f32; 2]; 3], k: usize| [w.splat(x[0][k]), w.splat(x[1][k]), w.splat(x[2][k])];
    let (o_lo, o_hi) = (splat(rays.o, 0), splat(rays.o, 1));
    let (inv_lo, inv_hi) = (splat(rays.inv, 0), splat(rays.inv, 1));
    let (err, max, eps) = (
        w.splat(rays.err[0].max(rays.err[1]).max(rays.err[2])),
        w.splat(f32::MAX),
        w.splat(INTERVAL_EPS),
    );
    let one_origin = rays.o.iter().all(|r| r[0] == r[1]);
    let mut stack = ArrayVec::<(WideChild, f32, f32), WIDE_STACK>::new();
    let (mut child, mut t_enter, mut t_exit) = (WideChild::ROOT, rays.t_enter, rays.t_exit);
    let mut done = 0u64;
    let (mut budget, mut tested) = (INTERVAL_NODE_BUDGET / 3, false);
    let mut latest = latest_best(l, live_mask, t.visitor.best_t());
    // As in the binary traversal, the rays' beams share one summary.
    let shared_rays = Cell::new(None);
    loop {
        if child.is_node() {
            // For closest hits, only while no ray has been tested: the per-ray traversal then
            // starts afresh. Hits found here in another order than its front-to-back one would
            // make it skip cells entered at their `t`, and a tie the cell held. Any-hit rays
            // still unfinished have found nothing, so their per-ray traversal starts afresh
            // whenever it starts.
            if budget == 0 && (!tested || V::FARTHEST_FIRST) {
                return live_mask & !done;
            }
            budget = budget.saturating_sub(1);
            t.counters.inner_visits += 1;
            let node = &nodes[child.index() as usize];
            let (enter, exit) = (w.splat(t_enter), w.splat(t_exit.min(latest)));
            let (mut near, mut far) = ([0f32; WIDE], [0f32; WIDE]);
            let mut entered = 0u32;
            for at in (0..WIDE).step_by(<L::UpTo8 as Lanes>::WIDTH) {
                let (mut n, mut f) = (enter, exit);
                for a in 0..3 {
                    let enter_plane = w.load(&node.planes[enter_rows[a]][at..]);
                    let exit_plane = w.load(&node.planes[exit_rows[a]][at..]);
                    let (lo, hi) = if one_origin {
                        // `o_lo = o_hi`: two corners.
                        let (d, e) = (enter_plane - o_lo[a], exit_plane - o_lo[a]);
                        (
                            (d * inv_lo[a]).min(d * inv_hi[a]),
                            (e * inv_lo[a]).max(e * inv_hi[a]),
                        )
                    } else {
                        let (d0, d1) = (enter_plane - o_hi[a], enter_plane - o_lo[a]);
                        let (e0, e1) = (exit_plane - o_hi[a], exit_plane - o_lo[a]);
                        (
                            (d0 * inv_lo[a])
                                .min(d0 * inv_hi[a])
                                .min((d1 * inv_lo[a]).min(d1 * inv_hi[a])),
                            (e0 * inv_lo[a])
                                .max(e0 * inv_hi[a])
                                .max((e1 * inv_lo[a]).max(e1 * inv_hi[a])),
                        )
                    };
                    (n, f) = (n.max(lo), f.min(hi));
                }
                let (n, f) = (n - t_slack(n, err, max, eps), f + t_slack(f, err, max, eps));
                entered |= n.le(f).bits() << at;
                w.store(n, &mut near[at..]);
                w.store(f, &mut far[at..]);
            }
            if entered != 0 {
                let first = first_by_entry(entered, &near, V::FARTHEST_FIRST, |k| {
                    stack.push((node.children[k], near[k], far[k]));
                });
                (child, t_enter, t_exit) = (node.children[first], near[first], far[first]);
                continue;
            }
        } else {
            let leaf = &tree.leaves()[child.index() as usize];
            let rest = live_mask & !done;
            if let Some(now_done) = test_leaf(t, rays, leaf, rest, scene_bound, &shared_rays) {
                done |= now_done;
                latest = latest_best(l, live_mask & !done, t.visitor.best_t());
                tested = true;
            }
        }
        // The next child some ray still needs: one entered before its best hit.
        loop {
            let Some((next, enter, exit)) = stack.pop() else {
                return 0;
            };
            if enter <= latest {
                (child, t_enter, t_exit) = (next, enter, exit);
                break;
            }
        }
    }
}

/// The slack of a split crossing in `[lo, hi]` on an axis of error `err`.
#[inline(always)]
fn slack(lo: f32, hi: f32, err: f32) -> f32 {
    (lo.abs().max(hi.abs()).min(f32::MAX) + err).min(f32::MAX) * INTERVAL_EPS
}

/// [`traverse_octant_interval`] of the rays summed up in `rays`, by the binary kd-tree.
#[inline(always)]
fn traverse_binary<L: Lanes, V: PacketVisitor<L>>(
    t: &mut Traversal<'_, L, V>,
    rays: &IntervalRays<'_>,
    octant: usize,
) -> u64 {
    let (l, tree) = (t.l, t.tree);
    let live_mask = rays.live;
    let bounds = root_bounds(tree);
    let scene_bound = bounds.min.abs().max(bounds.max.abs()).max_element();
    t.counters.packets += 1;
    let (mut t_enter, mut t_exit) = (rays.t_enter, rays.t_exit);
    let (o_lo, o_hi) = (rays.o.map(|r| r[0]), rays.o.map(|r| r[1]));
    let (inv_lo, inv_hi) = (rays.inv.map(|r| r[0]), rays.inv.map(|r| r[1]));
    let err = rays.err;

    let nodes = tree.nodes();
    let mut stack = [(0u32, 0f32, 0f32); STACK_DEPTH];
    let mut top = 0;
    let mut node_index = 0u32;
    let mut done = 0u64;
    let (mut budget, mut tested) = (INTERVAL_NODE_BUDGET, false);
    // The latest best hit of an unfinished ray: a cell entered after it is skipped. It only
    // changes in a leaf the rays were tested in.
    let mut latest = latest_best(l, live_mask, t.visitor.best_t());
    // The rays stay `live_mask` in every leaf: their beams share one summary.
    let shared_rays = Cell::new(None);
    loop {
        let node = nodes[node_index as usize];
        if !node.is_leaf() {
            // When, and why: as in `traverse_wide`.
            if budget == 0 && (!tested || V::FARTHEST_FIRST) {
                return live_mask & !done;
            }
            budget = budget.saturating_sub(1);
            t.counters.inner_visits += 1;
            let a = node.axis();
            let (lo, hi) = split_range(node.split(), [o_lo[a], o_hi[a]], [inv_lo[a], inv_hi[a]]);
            let slack = slack(lo, hi, err[a]);
            let (near_exit, far_enter) = ((hi + slack).min(t_exit), (lo - slack).max(t_enter));
            let [(near, near_empty), (far, far_empty)] =
                node.children_in_order(node_index, octant >> a & 1 != 0);
            let to_near = (t_enter <= near_exit) & !near_empty;
            let to_far = (far_enter <= t_exit) & !far_empty;
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
            let rest = live_mask & !done;
            if let Some(now_done) = test_leaf(t, rays, leaf, rest, scene_bound, &shared_rays) {
                done |= now_done;
                latest = latest_best(l, live_mask & !done, t.visitor.best_t());
                tested = true;
            }
        }
        // Pop the next cell that some ray still needs: one entered before its best hit.
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

/// Tests the rays of `mask` whose segment up to their best hit meets `leaf`'s tight box
/// ([`rays_in_box`]) against its triangles; the rays the visitor is done with, or `None` when
/// no ray was tested.
#[inline(always)]
fn test_leaf<L: Lanes, V: PacketVisitor<L>>(
    t: &mut Traversal<'_, L, V>,
    rays: &IntervalRays<'_>,
    leaf: &LeafRecord,
    mask: u64,
    scene_bound: f32,
    shared_rays: &Cell<Option<Option<BeamRays>>>,
) -> Option<u64> {
    if leaf.count == 0 {
        return None;
    }
    let (l, p) = (t.l, t.packet);
    let best = t.visitor.best_t();
    let active = rays_in_box(l, p, rays.inv_columns, mask, best, &leaf.bounds);
    if active == 0 {
        return None;
    }
    let visit = LeafVisit {
        triangles: t.tree.leaf_triangles(leaf),
        bounds: &leaf.bounds,
        mask: active,
        packet_mask: rays.live,
        scene_bound,
        boxes: None,
        shared_rays: Some(shared_rays),
    };
    Some(visit_leaf(l, p, visit, &mut *t.visitor, &mut *t.counters))
}

/// The largest `best[i]` over the rays `i` of `mask`; `-inf` for no ray.
#[inline(always)]
fn latest_best<L: Lanes>(l: L, mask: u64, best: &Column) -> f32 {
    let ninf = l.splat(f32::NEG_INFINITY);
    let mut latest = ninf;
    let mut rest = mask;
    while rest != 0 {
        let g = take_group::<L>(&mut rest);
        let bits = group_bits::<L>(mask, g);
        let b = g * L::WIDTH;
        let t = L::F32::select(l.mask_from_bits(bits), l.load(&best[b..]), ninf);
        latest = latest.max(t);
    }
    latest.reduce_max()
}

/// Per axis, the smallest lane.
#[inline(always)]
fn axes_min<F: LaneF32>([x, y, z]: [F; 3]) -> [f32; 3] {
    [x.reduce_min(), y.reduce_min(), z.reduce_min()]
}

/// Per axis, the largest lane.
#[inline(always)]
fn axes_max<F: LaneF32>([x, y, z]: [F; 3]) -> [f32; 3] {
    [x.reduce_max(), y.reduce_max(), z.reduce_max()]
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
    let mut rest = mask;
    while rest != 0 {
        let g = take_group::<L>(&mut rest);
        let bits = group_bits::<L>(mask, g);
        let b = g * L::WIDTH;
        let origin = load_axes(l, &p.origin, b);
        let iv = load_axes(l, inv, b);
        let err = (origin[0] * iv[0])
            .abs()
            .max((origin[1] * iv[1]).abs())
            .max((origin[2] * iv[2]).abs())
            .min(max);
        let (_, near, far) = slab::slab_lanes(l, &origin, &iv, ninf, inf, bounds);
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
