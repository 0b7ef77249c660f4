//! Single-ray traversal of the wide nodes ([`WideNodes`]): a vector of child boxes per step.
//!
//! The ray is clipped against the boxes of all children of a node at once
//! ([`clip_planes_fused`], the planes chosen once per ray by the signs of its direction, each
//! plane's distance one multiply-add), the children it enters are
//! taken nearest entry first, and the others wait on a stack with their intervals. A child
//! whose entry lies beyond the closest hit so far is skipped. Visiting the leaves in another
//! order than the binary traversal, or fewer of them, cannot change the closest hit: a hit in
//! `[tmin, tmax]` lies in the padded box of every leaf holding its triangle, and the ray meets
//! that box at the hit, so the leaf is entered unless a hit before it is already known; ties
//! in `t` go to the smaller id ([`Hit::is_beaten_by`](kdbeam_kernels::Hit::is_beaten_by)) in
//! any order.
//!
//! A walk that stops at any hit (a shadow or ambient-occlusion ray) takes the children
//! farthest entry first ([`WideLeaves::FARTHEST_FIRST`]): any order gives the same answer, and
//! such rays start on a surface, so the cells around their origin hold the surface they leave
//! and its neighbours, which they mostly miss, while their occluder tends to lie farther along.
//!
//! The walk ([`walk`]) serves any wide nodes: a kd-tree's, and a scene's top level over its
//! instances. Two rays may walk at once ([`walk_pair`]), a step of each in turn: one ray's walk
//! is a single chain of dependent loads and arithmetic, and the CPU overlaps two.

use arrayvec::ArrayVec;
use glam::Vec3A;
use kdbeam_kernels::slab::{clip_planes_fused, fused_offsets};
use kdbeam_kernels::{LaneF32, LaneMask, Lanes, Ray};

use super::single::{is_traceable, visit_leaf, LeafVisitor, INTERVAL_EPS};
use crate::kdtree::{KdTree, WideChild, WideNode, WideNodes, WIDE, WIDE_STACK};

/// Walks the leaves of `tree` that `ray` enters, by its wide nodes, until `visitor` has its
/// answer; `L` (at most [`WIDE`] lanes) tests a vector of children per step.
#[inline(always)]
pub(crate) fn traverse<L: Lanes, V: LeafVisitor>(l: L, tree: &KdTree, ray: &Ray, visitor: &mut V) {
    if !is_traceable(ray) {
        return;
    }
    walk(l, tree.wide_nodes(), ray, &mut KdLeaves { tree, visitor });
}

/// [`traverse`] of two rays, interleaved ([`walk_pair`]); each visitor sees what its ray's own
/// [`traverse`] shows it.
#[inline(always)]
pub(crate) fn traverse_pair<L: Lanes, V: LeafVisitor>(
    l: L,
    tree: &KdTree,
    rays: [&Ray; 2],
    visitors: [&mut V; 2],
) {
    let [a, b] = visitors;
    match (is_traceable(rays[0]), is_traceable(rays[1])) {
        (true, true) => walk_pair(
            l,
            tree.wide_nodes(),
            rays,
            [
                &mut KdLeaves { tree, visitor: a },
                &mut KdLeaves { tree, visitor: b },
            ],
        ),
        (true, false) => traverse(l, tree, rays[0], a),
        (false, true) => traverse(l, tree, rays[1], b),
        (false, false) => {}
    }
}

/// The rest of `ray`'s [`traverse`] from the child `start` of the tree's wide nodes, entered
/// over `start`'s interval, with the closest hit so far at `best_t` (`+inf` without one): a
/// walk that a group of rays began together ([`super::wide_lanes`]) and `ray` ends alone.
/// Returns the closest hit so far once the walk is over, or `None` when `visitor` stopped it.
#[inline(always)]
pub(crate) fn traverse_from<L: Lanes, V: LeafVisitor>(
    l: L,
    tree: &KdTree,
    ray: &Ray,
    start: Pending,
    best_t: f32,
    visitor: &mut V,
) -> Option<f32> {
    let wide = tree.wide_nodes();
    let mut leaves = Stops {
        leaves: KdLeaves { tree, visitor },
        stopped: false,
    };
    let mut stack = Stack::new();
    let mut w = Walker::new(l, ray, wide.reach());
    (w.child, w.t_enter, w.t_exit) = start;
    w.best_t = best_t;
    while w.step(l, wide.nodes(), &mut stack, &mut leaves) {}
    (!leaves.stopped).then_some(w.best_t)
}

/// Leaves that remember whether they stopped the walk.
struct Stops<W> {
    leaves: W,
    stopped: bool,
}

impl<W: WideLeaves> WideLeaves for Stops<W> {
    const FARTHEST_FIRST: bool = W::FARTHEST_FIRST;
    #[inline(always)]
    fn visit(&mut self, leaf: u32, t_enter: f32, t_exit: f32) -> Option<f32> {
        let answer = self.leaves.visit(leaf, t_enter, t_exit);
        self.stopped = answer.is_none();
        answer
    }
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
    /// Whether the walk takes the children a ray enters farthest entry first rather than
    /// nearest first (see the module's doc).
    const FARTHEST_FIRST: bool = false;
}

/// A kd-tree's leaves, by record, tested by `visitor`.
struct KdLeaves<'a, V> {
    tree: &'a KdTree,
    visitor: &'a mut V,
}

impl<V: LeafVisitor> WideLeaves for KdLeaves<'_, V> {
    const FARTHEST_FIRST: bool = V::FARTHEST_FIRST;
    #[inline(always)]
    fn visit(&mut self, leaf: u32, t_enter: f32, t_exit: f32) -> Option<f32> {
        visit_leaf(self.tree, leaf, t_enter, t_exit, self.visitor)
    }
}

/// Has `leaves` visit the leaves of the wide nodes `wide` (root first) whose boxes the
/// traceable `ray` enters, each over its box's interval, nearest entry first, until it stops.
///
/// A box is entered over its slab interval computed by the fused `plane·inv − o·inv`, and
/// skipped once the closest hit so far lies strictly before it. A ray with `tmin >= 0` whose
/// origin lies within the nodes' reach ([`WideNodes::reach`]) takes the interval as computed:
/// the boxes' padding holds its rounding in space, so the widening, two operations on the
/// chain from one node to the next, is not needed. Other rays widen it by the slack of the
/// binary traversal ([`INTERVAL_EPS`] of `|t|` plus the ray's largest finite `|o·inv|`:
/// sixteen times the rounding). No nodes: no leaf.
#[inline(always)]
pub(crate) fn walk<L: Lanes>(l: L, wide: &WideNodes, ray: &Ray, leaves: &mut impl WideLeaves) {
    let nodes = wide.nodes();
    if nodes.is_empty() {
        return;
    }
    let mut stack = Stack::new();
    let mut w = Walker::new(l, ray, wide.reach());
    while w.step(l, nodes, &mut stack, leaves) {}
}

/// [`walk`] of two rays at once, a step of each in turn: each ray's steps form one long chain
/// of dependent loads and arithmetic, and two independent chains let the CPU overlap them.
/// Each ray sees exactly what its own [`walk`] sees.
#[inline(always)]
pub(crate) fn walk_pair<L: Lanes, W: WideLeaves>(
    l: L,
    wide: &WideNodes,
    rays: [&Ray; 2],
    leaves: [&mut W; 2],
) {
    let nodes = wide.nodes();
    if nodes.is_empty() {
        return;
    }
    let [a, b] = leaves;
    let reach = wide.reach();
    let (mut wa, mut wb) = (
        Walker::new(l, rays[0], reach),
        Walker::new(l, rays[1], reach),
    );
    let (mut sa, mut sb) = (Stack::new(), Stack::new());
    let (mut on_a, mut on_b) = (true, true);
    while on_a && on_b {
        on_a = wa.step(l, nodes, &mut sa, a);
        on_b = wb.step(l, nodes, &mut sb, b);
    }
    while on_a && wa.step(l, nodes, &mut sa, a) {}
    while on_b && wb.step(l, nodes, &mut sb, b) {}
}

/// A child left for later, with the interval the ray enters it over.
pub(crate) type Pending = (WideChild, f32, f32);

/// The children a walk has left for later, nearest on top. Not initialised: a walk's stack is
/// made for every ray, and most rays use a few of its entries.
type Stack = ArrayVec<Pending, WIDE_STACK>;

/// One ray's walk of wide nodes, a node or a leaf per [`Walker::step`]. Its stack is the
/// caller's, apart from the rest of its state, which then stays in registers.
struct Walker<L: Lanes> {
    /// `−o·inv` per axis ([`fused_offsets`]): a plane's distance is one `mul_add`.
    offset: [L::F32; 3],
    inv_direction: [L::F32; 3],
    /// The rows of a node's planes the ray enters and leaves its children's boxes by.
    enter: [usize; 3],
    exit: [usize; 3],
    err: L::F32,
    /// `tmin >= 0`: every box's entry is then at least 0, and its widening one `mul_add`.
    nonnegative: bool,
    /// `tmin >= 0` and the origin within the nodes' reach ([`WideNodes::reach`]): their boxes'
    /// padding holds the rounding, and no interval is widened.
    within_reach: bool,
    /// The widening of a non-negative entry `n` and exit `f` ([`Walker::step`]).
    near_scale: L::F32,
    near_shift: L::F32,
    far_scale: L::F32,
    far_shift: L::F32,
    tmin: L::F32,
    tmax: f32,
    best_t: f32,
    /// The child to visit next, and the interval the ray enters it over.
    child: WideChild,
    t_enter: f32,
    t_exit: f32,
}

impl<L: Lanes> Walker<L> {
    /// At the root, over `[tmin, tmax]`, for nodes of reach `reach`.
    #[inline(always)]
    fn new(l: L, ray: &Ray, reach: f32) -> Self {
        debug_assert!(L::WIDTH <= WIDE);
        let inv = Vec3A::from(ray.direction).recip();
        let offset = fused_offsets(ray.origin, inv.into());
        // `|o·inv|` where finite: the fused offsets are `−o·inv` there, NaN or infinite elsewhere.
        let size = Vec3A::from_array(offset).abs();
        let err = Vec3A::select(size.is_finite_mask(), size, Vec3A::ZERO).max_element();
        // The planes a ray enters by: `min` unless the reciprocal is negative (`−0` included).
        let backwards = inv.cmplt(Vec3A::ZERO).bitmask() as usize;
        let (mut enter, mut exit) = ([0; 3], [0; 3]);
        for k in 0..3 {
            let b = backwards >> k & 1;
            (enter[k], exit[k]) = (k + 3 * b, k + 3 - 3 * b);
        }
        let iv = inv.to_array();
        Walker {
            offset: [l.splat(offset[0]), l.splat(offset[1]), l.splat(offset[2])],
            inv_direction: [l.splat(iv[0]), l.splat(iv[1]), l.splat(iv[2])],
            enter,
            exit,
            err: l.splat(err),
            nonnegative: ray.tmin >= 0.0,
            within_reach: ray.tmin >= 0.0 && Vec3A::from(ray.origin).abs().max_element() <= reach,
            near_scale: l.splat(1.0 - INTERVAL_EPS),
            near_shift: l.splat(-err * INTERVAL_EPS),
            far_scale: l.splat(1.0 + INTERVAL_EPS),
            far_shift: l.splat(err * INTERVAL_EPS * (1.0 + 8.0 * INTERVAL_EPS)),
            tmin: l.splat(ray.tmin),
            tmax: ray.tmax,
            best_t: f32::INFINITY,
            child: WideChild::ROOT,
            t_enter: ray.tmin,
            t_exit: ray.tmax,
        }
    }

    /// Visits the next node or leaf, children left for later going on `stack`; `false` once
    /// the walk is over.
    #[inline(always)]
    fn step<W: WideLeaves>(
        &mut self,
        l: L,
        nodes: &[WideNode],
        stack: &mut Stack,
        leaves: &mut W,
    ) -> bool {
        if self.child.is_node() {
            let node = &nodes[self.child.index() as usize];
            let tmax = l.splat(self.tmax.min(self.best_t));
            let eps = l.splat(INTERVAL_EPS);
            let (mut near, mut far) = ([0f32; WIDE], [0f32; WIDE]);
            let mut entered = 0u32;
            for at in (0..WIDE).step_by(L::WIDTH) {
                let (n, f) = clip_planes_fused(
                    &self.offset,
                    &self.inv_direction,
                    planes(l, node, self.enter, at),
                    planes(l, node, self.exit, at),
                    self.tmin,
                    tmax,
                );
                // As computed within the nodes' reach (their padding holds the rounding), else
                // widened by `(|t| + err)·eps` each. With `tmin >= 0` the entry `n` is at least
                // 0, so `n − (n + err)·eps` is one `mul_add`; so is the exit's `f + (f + err)·eps`
                // where `f >= 0`, and where `f < 0` the box is entered only if `|f|` is within
                // `2·err·eps` of 0 (as `n >= −err·eps`), which the shift's extra `8·eps` of itself
                // covers.
                let (n, f) = if self.within_reach {
                    (n, f)
                } else if self.nonnegative {
                    (
                        n.mul_add(self.near_scale, self.near_shift),
                        f.mul_add(self.far_scale, self.far_shift),
                    )
                } else {
                    (
                        n - (n.abs() + self.err) * eps,
                        f + (f.abs() + self.err) * eps,
                    )
                };
                entered |= n.le(f).bits() << at;
                l.store(n, &mut near[at..]);
                l.store(f, &mut far[at..]);
            }
            if entered != 0 {
                let first = first_by_entry(entered, &near, W::FARTHEST_FIRST, |k| {
                    stack.push((node.children[k], near[k], far[k]));
                });
                (self.child, self.t_enter, self.t_exit) =
                    (node.children[first], near[first], far[first]);
                return true;
            }
        } else {
            match leaves.visit(self.child.index(), self.t_enter, self.t_exit) {
                Some(t) => self.best_t = t,
                None => return false,
            }
        }
        while let Some(pending) = stack.pop() {
            (self.child, self.t_enter, self.t_exit) = pending;
            if self.t_enter <= self.best_t {
                return true;
            }
        }
        false
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

/// Of the children `entered` (bit `k`: child `k`), the one entered first by their entries
/// `near`, or with `farthest` the one entered last; `push` gets the others, last in that order
/// first, so that a stack pops them in order.
#[inline(always)]
pub(crate) fn first_by_entry(
    entered: u32,
    near: &[f32; WIDE],
    farthest: bool,
    mut push: impl FnMut(usize),
) -> usize {
    let before = |a: f32, b: f32| if farthest { a > b } else { a < b };
    let rest = entered & (entered - 1);
    if rest == 0 {
        return entered.trailing_zeros() as usize;
    }
    if rest & (rest - 1) == 0 {
        // Two children, ordered by a select: the insertion below branches on a comparison
        // that the walk often mispredicts. Ties go as the insertion takes them (the later
        // child first).
        let (a, b) = (
            entered.trailing_zeros() as usize,
            rest.trailing_zeros() as usize,
        );
        let b_first = !before(near[a], near[b]);
        push(if b_first { a } else { b });
        return if b_first { b } else { a };
    }
    let mut order = [0usize; WIDE];
    let mut len = 0;
    let mut bits = entered;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let mut i = len;
        while i > 0 && before(near[order[i - 1]], near[k]) {
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

#[cfg(test)]
mod tests {
    use super::{first_by_entry, WIDE};
    use crate::scene::rng::Rng;

    /// The children in the order a walk visits them: the first, then the others as a stack
    /// pops them.
    fn visits(entered: u32, near: &[f32; WIDE], farthest: bool) -> Vec<usize> {
        let mut stack = Vec::new();
        let first = first_by_entry(entered, near, farthest, |k| stack.push(k));
        std::iter::once(first)
            .chain(stack.into_iter().rev())
            .collect()
    }

    /// Every entered child is visited once, by its entry: ascending nearest first, descending
    /// farthest first, ties in either order (entries drawn from a few values make many).
    #[test]
    fn children_are_visited_in_order_of_entry_each_once() {
        let mut rng = Rng::new(11);
        for _ in 0..2000 {
            let entered = rng.next_u32() & ((1 << WIDE) - 1);
            if entered == 0 {
                continue;
            }
            let near: [f32; WIDE] = std::array::from_fn(|_| (rng.next_f32() * 4.0).floor());
            let nearest = visits(entered, &near, false);
            let farthest = visits(entered, &near, true);
            for (got, ascending) in [(nearest, true), (farthest, false)] {
                let mut sorted = got.clone();
                sorted.sort_unstable();
                let want: Vec<usize> = (0..WIDE).filter(|k| entered >> k & 1 != 0).collect();
                assert_eq!(sorted, want, "{entered:#b} {near:?}: {got:?}");
                for pair in got.windows(2) {
                    let (a, b) = (near[pair[0]], near[pair[1]]);
                    assert!(
                        if ascending { a <= b } else { a >= b },
                        "{entered:#b} {near:?}: {got:?}"
                    );
                }
            }
        }
    }
}
