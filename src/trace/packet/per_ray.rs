//! The per-ray packet traversal: each ray keeps its own interval, a mask says which rays are in
//! the current cell.

use kdbeam_kernels::groups::{group_bits, group_count, load_axes, take_group};
use kdbeam_kernels::{slab, LaneF32, LaneMask, Lanes};

use super::visit::{visit_leaf, LeafBoxes, LeafVisit, PacketVisitor};
use super::{Stack, Traversal, N};
use crate::trace::single::{root_bounds, split_intervals, INTERVAL_EPS, STACK_DEPTH};

/// Traverses `tree` with the rays of `mask`, which must all be traceable and share the
/// direction signs `octant` (bit `a` set for a negative component on axis `a`).
#[inline(always)]
pub(crate) fn traverse_octant<L: Lanes, V: PacketVisitor<L>>(
    t: &mut Traversal<'_, L, V>,
    mut mask: u64,
    octant: usize,
    stack: &mut Stack,
) {
    let (l, tree, p) = (t.l, t.tree, t.packet);
    let (visitor, counters, boxes) = (&mut *t.visitor, &mut *t.counters, t.boxes);
    let groups = group_count::<L>(p.len());
    let mut inv = [[0f32; N]; 3];
    let mut err = [[0f32; N]; 3];
    let max = l.splat(f32::MAX);
    for a in 0..3 {
        for g in 0..groups {
            let b = g * L::WIDTH;
            let i = l.splat(1.0) / l.load(&p.direction[a][b..]);
            l.store(i, &mut inv[a][b..]);
            l.store(
                (l.load(&p.origin[a][b..]) * i).abs().min(max),
                &mut err[a][b..],
            );
        }
    }
    // The current cell's per-ray interval and the split's scratch intervals, swapped by
    // reference rather than copied. Only the lanes of rays in the current mask are ever read,
    // so each loop below touches only the vectors that hold one.
    let mut buffers = [[0f32; N]; 4];
    let [t_enter, t_exit, near_exit, far_enter] = &mut buffers;
    let (mut t_enter, mut t_exit) = (t_enter, t_exit);
    let (mut near_exit, mut far_enter) = (near_exit, far_enter);
    let bounds = root_bounds(tree);
    let scene_bound = bounds.min.abs().max(bounds.max.abs()).max_element();
    let mut clipped = 0u64;
    let mut rest = mask;
    while rest != 0 {
        let g = take_group::<L>(&mut rest);
        let bits = group_bits::<L>(mask, g);
        let b = g * L::WIDTH;
        let origin = load_axes(l, &p.origin, b);
        let iv = load_axes(l, &inv, b);
        let (hit, tn, tf) = slab::slab_lanes(
            l,
            &origin,
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
        ..
    } = stack;
    let mut top = 0;
    let mut node_index = 0u32;
    let mut done = 0u64;
    while mask != 0 {
        let node = nodes[node_index as usize];
        let mut descended = false;
        if !node.is_leaf() {
            counters.inner_visits += 1;
            let axis = node.axis();
            let split = l.splat(node.split());
            let eps = l.splat(INTERVAL_EPS);
            let [(near, near_empty), (far, far_empty)] =
                node.children_in_order(node_index, octant >> axis & 1 != 0);
            let (mut near_mask, mut far_mask) = (0u64, 0u64);
            let mut rest = mask;
            while rest != 0 {
                let g = take_group::<L>(&mut rest);
                let bits = group_bits::<L>(mask, g);
                let b = g * L::WIDTH;
                let ts = (split - l.load(&p.origin[axis][b..])) * l.load(&inv[axis][b..]);
                let (tn, tf) = (l.load(&t_enter[b..]), l.load(&t_exit[b..]));
                let (ne, fe) = split_intervals(ts, tn, tf, l.load(&err[axis][b..]), eps, max);
                let act = l.mask_from_bits(bits);
                l.store(ne, &mut near_exit[b..]);
                l.store(fe, &mut far_enter[b..]);
                // The interval of the child taken second, written where it is pushed if both
                // children are taken.
                let (second_enter, second_exit) = if V::FARTHEST_FIRST {
                    (tn, ne)
                } else {
                    (fe, tf)
                };
                l.store(second_enter, &mut stack_enter[top][b..]);
                l.store(second_exit, &mut stack_exit[top][b..]);
                near_mask |= u64::from((act & tn.le(ne)).bits()) << b;
                far_mask |= u64::from((act & fe.le(tf)).bits()) << b;
            }
            // An empty leaf has nothing to test: no ray steps into it.
            near_mask &= u64::from(!near_empty).wrapping_neg();
            far_mask &= u64::from(!far_empty).wrapping_neg();
            // Any-hit rays take the far child first ([`PacketVisitor::FARTHEST_FIRST`]).
            let take_near = near_mask != 0 && (far_mask == 0 || !V::FARTHEST_FIRST);
            let ((taken, taken_mask), (other, other_mask)) = if take_near {
                ((near, near_mask), (far, far_mask))
            } else {
                ((far, far_mask), (near, near_mask))
            };
            if taken_mask != 0 {
                if other_mask != 0 {
                    stack_node[top] = other;
                    stack_mask[top] = other_mask;
                    top += 1;
                }
                if take_near {
                    std::mem::swap(&mut t_exit, &mut near_exit);
                } else {
                    std::mem::swap(&mut t_enter, &mut far_enter);
                }
                (node_index, mask) = (taken, taken_mask);
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
                    boxes: boxes.map(|boxes| LeafBoxes {
                        boxes: &boxes[leaf.first as usize..],
                        t_enter: &*t_enter,
                        t_exit: &*t_exit,
                    }),
                    shared_rays: None,
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
            let candidates = stack_mask[top] & !done;
            let best = visitor.best_t();
            let mut rest = candidates;
            while rest != 0 {
                let g = take_group::<L>(&mut rest);
                let bits = group_bits::<L>(candidates, g);
                let b = g * L::WIDTH;
                let (enter, exit) = (
                    l.load(&stack_enter[top][b..]),
                    l.load(&stack_exit[top][b..]),
                );
                l.store(enter, &mut t_enter[b..]);
                l.store(exit, &mut t_exit[b..]);
                let keep = enter.le(l.load(&best[b..]));
                mask |= u64::from((keep & l.mask_from_bits(bits)).bits()) << b;
            }
        }
    }
}
