//! Single-ray traversal of the wide nodes ([`WideNodes`]): a vector of child boxes per step.
//!
//! The ray is clipped against the boxes of all children of a node at once ([`clip_planes`],
//! the planes chosen once per ray by the signs of its direction), the children it enters are
//! taken nearest entry first, and the others wait on a stack with their intervals. A child
//! whose entry lies beyond the closest hit so far is skipped. Visiting the leaves in another
//! order than the binary traversal, or fewer of them, cannot change the closest hit: a hit in
//! `[tmin, tmax]` lies in the padded box of every leaf holding its triangle, and the ray meets
//! that box at the hit, so the leaf is entered unless a hit before it is already known; ties
//! in `t` go to the smaller id ([`Hit::is_beaten_by`](kdbeam_kernels::Hit::is_beaten_by)) in
//! any order.

use kdbeam_kernels::slab::clip_planes;
use kdbeam_kernels::{LaneF32, LaneMask, Lanes, Ray};

use super::single::{is_traceable, visit_leaf, LeafVisitor, INTERVAL_EPS};
use crate::kdtree::{KdTree, WideChild, WideNode, WIDE, WIDE_STACK};

/// Walks the leaves of `tree` that `ray` enters, by its wide nodes, until `visitor` has its
/// answer; `L` (at most [`WIDE`] lanes) tests a vector of children per step.
#[inline(always)]
pub(crate) fn traverse<L: Lanes, V: LeafVisitor>(l: L, tree: &KdTree, ray: &Ray, visitor: &mut V) {
    if !is_traceable(ray) {
        return;
    }
    walk(
        l,
        tree.wide_nodes().nodes(),
        ray,
        &mut KdLeaves { tree, visitor },
    );
}

/// What a walk of wide nodes ([`walk`]) does in each leaf it enters.
///
/// A trait rather than a closure so that `#[inline(always)]` keeps the leaf's work inside the
/// ISA's entry point: a closure holding a whole traversal is left out of line, compiled for
/// the baseline ISA.
pub(crate) trait WideLeaves {
    /// Visits the leaf `leaf` (the index of its [`WideChild::leaf`]), entered over
    /// `[t_enter, t_exit]`. Returns the `t` of the closest hit so far (`+inf` without one), or
    /// `None` to stop the walk.
    fn visit(&mut self, leaf: u32, t_enter: f32, t_exit: f32) -> Option<f32>;
}

/// A kd-tree's leaves, by record, tested by `visitor`.
struct KdLeaves<'a, V> {
    tree: &'a KdTree,
    visitor: &'a mut V,
}

impl<V: LeafVisitor> WideLeaves for KdLeaves<'_, V> {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, t_enter: f32, t_exit: f32) -> Option<f32> {
        visit_leaf(self.tree, leaf, t_enter, t_exit, self.visitor)
    }
}

/// Has `leaves` visit the leaves of the wide nodes `nodes` (root first) whose boxes the
/// traceable `ray` enters, each over its box's interval, nearest entry first, until it stops.
///
/// A box is entered over its slab interval widened by the slack of the binary traversal
/// ([`INTERVAL_EPS`] of `|t|` plus the ray's largest finite `|o·inv|`, the rounding of
/// `(plane − o)·inv`), and skipped once the closest hit so far lies strictly before it. No
/// nodes: no leaf.
#[inline(always)]
pub(crate) fn walk<L: Lanes>(l: L, nodes: &[WideNode], ray: &Ray, leaves: &mut impl WideLeaves) {
    debug_assert!(L::WIDTH <= WIDE);
    if nodes.is_empty() {
        return;
    }
    let inv = ray.direction.recip();
    let (o, iv) = (ray.origin.to_array(), inv.to_array());
    let origin = [l.splat(o[0]), l.splat(o[1]), l.splat(o[2])];
    let inv_direction = [l.splat(iv[0]), l.splat(iv[1]), l.splat(iv[2])];
    // The planes a ray enters by: `min` unless the reciprocal is negative (`−0` included).
    let (mut enter, mut exit) = ([0; 3], [3; 3]);
    let mut err = 0f32;
    for k in 0..3 {
        if iv[k] < 0.0 {
            (enter[k], exit[k]) = (3 + k, k);
        } else {
            (enter[k], exit[k]) = (k, 3 + k);
        }
        let e = (o[k] * iv[k]).abs();
        if e.is_finite() {
            err = err.max(e);
        }
    }
    let (err, eps, tmin) = (l.splat(err), l.splat(INTERVAL_EPS), l.splat(ray.tmin));
    let mut stack = [(WideChild::NONE, 0f32, 0f32); WIDE_STACK];
    let mut top = 0;
    let mut best_t = f32::INFINITY;
    let (mut child, mut t_enter, mut t_exit) = (WideChild::node(0), ray.tmin, ray.tmax);
    loop {
        if child.is_node() {
            let node = &nodes[child.index() as usize];
            let tmax = l.splat(ray.tmax.min(best_t));
            let (mut near, mut far) = ([0f32; WIDE], [0f32; WIDE]);
            let mut entered = 0u32;
            for at in (0..WIDE).step_by(L::WIDTH) {
                let (n, f) = clip_planes(
                    &origin,
                    &inv_direction,
                    planes(l, node, enter, at),
                    planes(l, node, exit, at),
                    tmin,
                    tmax,
                );
                let n = n - (n.abs() + err) * eps;
                let f = f + (f.abs() + err) * eps;
                entered |= n.le(f).bits() << at;
                l.store(n, &mut near[at..]);
                l.store(f, &mut far[at..]);
            }
            if entered != 0 {
                let first = nearest_first(entered, &near, |k| {
                    stack[top] = (node.children[k], near[k], far[k]);
                    top += 1;
                });
                (child, t_enter, t_exit) = (node.children[first], near[first], far[first]);
                continue;
            }
        } else {
            match leaves.visit(child.index(), t_enter, t_exit) {
                Some(t) => best_t = t,
                None => return,
            }
        }
        loop {
            if top == 0 {
                return;
            }
            top -= 1;
            (child, t_enter, t_exit) = stack[top];
            if t_enter <= best_t {
                break;
            }
        }
    }
}

/// Rows `rows` of `node`'s planes (one per axis), children `at..at + WIDTH`.
#[inline(always)]
fn planes<L: Lanes>(l: L, node: &WideNode, rows: [usize; 3], at: usize) -> [L::F32; 3] {
    [
        l.load(&node.planes[rows[0]][at..]),
        l.load(&node.planes[rows[1]][at..]),
        l.load(&node.planes[rows[2]][at..]),
    ]
}

/// Of the children `entered` (bit `k`: child `k`), the one entered first; `push` gets the
/// others, farthest first, so that a stack pops them nearest first.
#[inline(always)]
fn nearest_first(entered: u32, near: &[f32; WIDE], mut push: impl FnMut(usize)) -> usize {
    if entered & (entered - 1) == 0 {
        return entered.trailing_zeros() as usize;
    }
    let mut order = [0usize; WIDE];
    let mut len = 0;
    let mut bits = entered;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let mut i = len;
        while i > 0 && near[order[i - 1]] < near[k] {
            order[i] = order[i - 1];
            i -= 1;
        }
        order[i] = k;
        len += 1;
    }
    for &k in &order[..len - 1] {
        push(k);
    }
    order[len - 1]
}
