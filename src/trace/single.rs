//! Single-ray kd-tree traversal: on scalar lanes, the reference every packet path is checked
//! against; on SIMD lanes, one ray against a vector of a leaf block's triangles per test, and
//! against a vector of child boxes per step of the tree's wide nodes ([`super::wide`]).
//!
//! On scalar lanes, front to back through the binary nodes with a stack, as in pbrt's
//! `KdTreeAccel::Intersect`. A [`LeafVisitor`] tests a leaf's triangles; traversal stops once
//! the closest hit so far lies before the next cell.

use arrayvec::ArrayVec;
use glam::Vec3A;
use kdbeam_kernels::intersect::{kensler_shirley, watertight::WatertightRay, LaneHits};
use kdbeam_kernels::raybox::segment_box;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{
    slab, Aabb, Hit, LaneF32, LaneMask, LaneTask, Lanes, Ray, RayPacket, TriangleBlock,
};

use crate::kdtree::{KdTree, LeafRecord, LeafTriangles, Node};

/// Deepest stack a traversal needs: the builder caps depth at 64.
pub(crate) const STACK_DEPTH: usize = 64;

/// A non-empty leaf as a traversal enters it.
pub(crate) struct LeafEntry<'a> {
    /// Index of the leaf's record in [`KdTree::leaves`].
    pub index: u32,
    /// The leaf's record: its first block in the tree's blocks, its count and tight box.
    pub record: &'a LeafRecord,
    /// The leaf's triangles.
    pub triangles: LeafTriangles<'a>,
    /// Where the ray enters the leaf's cell (clipped to `ray.tmin`).
    pub t_enter: f32,
    /// Where the ray leaves the leaf's cell (clipped to `ray.tmax`).
    pub t_exit: f32,
}

/// What a traversal does in each leaf it enters.
pub(crate) trait LeafVisitor {
    /// Tests `leaf`. Returns the `t` of the closest hit so far (`+inf` without one), or `None`
    /// to stop the traversal (an any-hit query that found one).
    fn visit(&mut self, leaf: LeafEntry<'_>) -> Option<f32>;
    /// Whether a walk takes the children a ray enters farthest entry first rather than
    /// nearest first: for visitors that stop at any hit, where the order cannot change the
    /// answer ([`super::wide`]).
    const FARTHEST_FIRST: bool = false;
}

/// A culling stage of single rays: it may skip a leaf the ray enters, and drop triangles of a
/// leaf before they are tested.
///
/// Every stage must be conservative: a leaf it skips holds no hit of the ray in
/// `[t_enter, t_exit]`, and a triangle it drops is not hit before `tmax`, so that the query
/// finds the hit it finds without the stage, bit for bit.
pub(crate) trait TriangleCull {
    /// Called as `ray` enters `leaf`; `false` skips the leaf.
    fn enter(&mut self, ray: &Ray, leaf: &LeafEntry<'_>) -> bool;
    /// Of the lanes `valid` of the vector of triangles `first..first + L::WIDTH` of the tree's
    /// block `block` (in the leaf last entered), those that may hold a hit before `tmax`.
    fn lanes<L: Lanes>(
        &mut self,
        l: L,
        ray: &Ray,
        block: usize,
        first: usize,
        valid: u32,
        tmax: f32,
    ) -> u32;
}

/// Two stages in turn: a leaf is entered when both enter it, and a triangle kept when both
/// keep it (the second is asked only about what the first keeps).
impl<A: TriangleCull, B: TriangleCull> TriangleCull for (A, B) {
    #[inline(always)]
    fn enter(&mut self, ray: &Ray, leaf: &LeafEntry<'_>) -> bool {
        self.0.enter(ray, leaf) && self.1.enter(ray, leaf)
    }

    #[inline(always)]
    fn lanes<L: Lanes>(
        &mut self,
        l: L,
        ray: &Ray,
        block: usize,
        first: usize,
        valid: u32,
        tmax: f32,
    ) -> u32 {
        let kept = self.0.lanes(l, ray, block, first, valid, tmax);
        if kept == 0 {
            return 0;
        }
        self.1.lanes(l, ray, block, first, kept, tmax)
    }
}

/// No culling: every leaf is entered and every triangle tested.
pub(crate) struct NoCull;

impl TriangleCull for NoCull {
    #[inline(always)]
    fn enter(&mut self, _: &Ray, _: &LeafEntry<'_>) -> bool {
        true
    }

    #[inline(always)]
    fn lanes<L: Lanes>(&mut self, _: L, _: &Ray, _: usize, _: usize, valid: u32, _: f32) -> u32 {
        valid
    }
}

/// Can this ray be traced? Finite origin and direction, a non-zero direction and
/// `tmin <= tmax` (`tmax` may be `+inf`). Every other ray reports a miss on every path.
#[inline(always)]
#[must_use]
pub fn is_traceable(ray: &Ray) -> bool {
    let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.direction));
    // One vector test of the six coordinates (`bitmask` of the three lanes each).
    let finite = (o.is_finite_mask() & d.is_finite_mask()).all();
    finite && d.cmpne(Vec3A::ZERO).any() && ray.tmin <= ray.tmax && !ray.tmax.is_nan()
}

/// Walks the leaves `ray` passes through, nearest first, until `visitor` has its answer.
///
/// A cell is entered over the closed interval `[t_enter, t_exit]` (clipped to
/// `[ray.tmin, ray.tmax]`) and skipped once the closest hit so far is strictly before `t_enter`:
/// a triangle hit at exactly that `t` in a later cell may still win the tie on its smaller id.
///
/// The near child is chosen by the sign bit of the direction, and a child is entered when its
/// part of the interval ([`split_intervals`]) is non-empty; this is the packet traversal's rule,
/// lane for lane, so both visit the same leaves. The walk starts at the deepest node whose cell
/// holds the ray's whole segment ([`entry_node`]), which passes only nodes where that rule
/// enters one child with the interval unchanged.
#[inline(always)]
pub(crate) fn traverse<V: LeafVisitor>(tree: &KdTree, ray: &Ray, visitor: &mut V) {
    if !is_traceable(ray) {
        return;
    }
    let inv = ray.direction.recip();
    let Some((mut t_enter, mut t_exit)) =
        slab::ray_box(ray.origin, inv, ray.tmin, ray.tmax, &root_bounds(tree))
    else {
        return;
    };
    let nodes = tree.nodes();
    let segment = segment_box(ray.origin, ray.direction, t_enter, t_exit);
    let mut stack = [(0u32, 0f32, 0f32); STACK_DEPTH];
    let mut top = 0;
    let mut node_index = entry_node(nodes, &segment);
    let mut best_t = f32::INFINITY;
    loop {
        if t_enter <= best_t {
            let node = nodes[node_index as usize];
            if !node.is_leaf() {
                let axis = node.axis();
                let t_split = (node.split() - ray.origin[axis]) * inv[axis];
                let err = LaneF32::min((ray.origin[axis] * inv[axis]).abs(), f32::MAX);
                // The reference steps into empty leaves too: it ignores the marks.
                let [(near, _), (far, _)] =
                    node.children_in_order(node_index, ray.direction[axis].is_sign_negative());
                let (near_exit, far_enter) =
                    split_intervals(t_split, t_enter, t_exit, err, INTERVAL_EPS, f32::MAX);
                match (t_enter <= near_exit, far_enter <= t_exit) {
                    (true, true) => {
                        stack[top] = (far, far_enter, t_exit);
                        top += 1;
                        (node_index, t_exit) = (near, near_exit);
                        continue;
                    }
                    (true, false) => {
                        (node_index, t_exit) = (near, near_exit);
                        continue;
                    }
                    (false, true) => {
                        (node_index, t_enter) = (far, far_enter);
                        continue;
                    }
                    (false, false) => {}
                }
            } else {
                let index = node.leaf_record();
                if tree.leaves()[index as usize].count > 0 {
                    match visit_leaf(tree, index, t_enter, t_exit, visitor) {
                        Some(t) => best_t = t,
                        None => return,
                    }
                }
            }
        }
        if top == 0 {
            return;
        }
        top -= 1;
        (node_index, t_enter, t_exit) = stack[top];
    }
}

/// What `visitor` answers in the leaf of record `index`, entered over `[t_enter, t_exit]`.
#[inline(always)]
pub(crate) fn visit_leaf<V: LeafVisitor>(
    tree: &KdTree,
    index: u32,
    t_enter: f32,
    t_exit: f32,
    visitor: &mut V,
) -> Option<f32> {
    let record = &tree.leaves()[index as usize];
    visitor.visit(LeafEntry {
        index,
        record,
        triangles: tree.leaf_triangles(record),
        t_enter,
        t_exit,
    })
}

/// The traversal of single rays on `L`: the binary one on scalar lanes (the reference), the
/// wide nodes' on SIMD lanes, a vector of child boxes per step ([`super::wide::traverse`]).
#[inline(always)]
fn traverse_lanes<L: Lanes, V: LeafVisitor>(l: L, tree: &KdTree, ray: &Ray, visitor: &mut V) {
    if L::WIDTH == 1 {
        traverse(tree, ray, visitor);
    } else {
        super::wide::traverse(l.up_to_8(), tree, ray, visitor);
    }
}

/// The deepest node whose cell holds all of `segment`, the padded box of a ray's segment in the
/// root cell ([`segment_box`]): where the ray's traversal starts.
///
/// A short ray (an ambient-occlusion or a shadow ray to a nearby light) lies in a small cell,
/// and the traversal from the root would step down to it one inner node at a time, computing
/// and clipping its interval at each. Here a step is two comparisons: the segment lies below
/// the split (`max < split`: the below child), above it (`min > split`: the above child), or
/// across it (stop). The traversal from the root visits no cell outside that node either: at
/// each node passed, the segment stays clear of the split by more than the box's padding
/// (2⁻¹⁵ of the coordinates' magnitude), far above the slack [`split_intervals`] gives a cell
/// (2⁻²⁰), so the root traversal enters the same child with the same interval. A box with an
/// infinite bound (a segment that overflows) stops at the root.
#[inline(always)]
fn entry_node(nodes: &[Node], segment: &Aabb) -> u32 {
    let (lo, hi) = (segment.min.to_array(), segment.max.to_array());
    let mut index = 0u32;
    loop {
        let node = nodes[index as usize];
        if node.is_leaf() {
            return index;
        }
        let (axis, split) = (node.axis(), node.split());
        if hi[axis] < split {
            index += 1;
        } else if lo[axis] > split {
            index = node.above_child();
        } else {
            return index;
        }
    }
}

/// Relative slack of the cell intervals: 16 ulps, well above the few roundings of
/// `(split − o) · (1 / d)` and of the box slab.
pub(crate) const INTERVAL_EPS: f32 = 1.0 / 1_048_576.0;

/// The interval of the near child ending at `t_split` and of the far child starting there,
/// each widened by the rounding `t_split` may carry.
///
/// `t_split = (split − o)·inv` is off by up to a few ulps of `|t_split| + |o·inv|` (the second
/// term for the subtraction, when the origin's coordinate is large); a ray that meets the split
/// where it enters or leaves the cell, or exactly on a triangle edge lying in the plane, would
/// otherwise lose the cell that holds its hit. `err = |o·inv|` per ray and axis (clamped
/// finite). Visiting one cell too many cannot change the closest hit. NaN (`0·inf`: origin on
/// the plane, direction parallel) keeps the whole interval on both sides, as the `min`/`max`
/// operand order returns the second operand; `±inf` empties the side the ray is not on. The
/// scalar and packet traversals both call this, so they agree lane for lane.
#[inline(always)]
pub(crate) fn split_intervals<F: LaneF32>(
    t_split: F,
    t_enter: F,
    t_exit: F,
    err: F,
    eps: F,
    max: F,
) -> (F, F) {
    let slack = (t_split.abs().min(max) + err).min(max) * eps;
    (
        (t_split + slack).min(t_exit),
        (t_split - slack).max(t_enter),
    )
}

/// The root cell, widened by `INTERVAL_EPS` of its size and position so that rounding in the
/// slab test never drops a hit on its faces.
#[inline(always)]
pub(crate) fn root_bounds(tree: &KdTree) -> kdbeam_kernels::Aabb {
    let b = tree.bounds();
    if b.is_empty() {
        return b;
    }
    let pad = (b.extent() + b.min.abs().max(b.max.abs())) * INTERVAL_EPS;
    kdbeam_kernels::Aabb::new(b.min - pad, b.max + pad)
}

/// Counters of one traversal, summed by callers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    /// Non-empty leaves entered.
    pub leaves: u64,
    /// Ray–triangle tests performed.
    pub tests: u64,
    /// Leaves skipped by a culling stage (counted in `leaves` too).
    pub leaves_culled: u64,
    /// Ray–triangle tests a culling stage removed (not counted in `tests`).
    pub culled: u64,
}

/// One ray against a vector of a leaf block's triangles, as the traversal sees it.
pub(crate) trait BlockTest {
    /// The hits of `ray` on triangles `first..first + WIDTH` of `block` (one per lane) in
    /// `[ray.tmin, tmax]`; only lanes of `valid` (bit `i`: triangle `first + i`) may hit.
    fn test<L: Lanes>(
        &self,
        l: L,
        ray: &Ray,
        lanes: (&TriangleBlock, usize, u32),
        tmax: f32,
    ) -> LaneHits<L>;
}

/// The Kensler–Shirley test on the block's precomputed form.
pub(crate) struct KsTest;

impl BlockTest for KsTest {
    #[inline(always)]
    fn test<L: Lanes>(
        &self,
        l: L,
        ray: &Ray,
        (block, first, valid): (&TriangleBlock, usize, u32),
        tmax: f32,
    ) -> LaneHits<L> {
        let h = kensler_shirley::intersect_block(l, ray, block, first, ray.tmin, tmax);
        LaneHits {
            mask: h.mask & l.mask_from_bits(valid),
            ..h
        }
    }
}

/// The watertight test, its per-ray shear computed once.
pub(crate) struct WatertightTest(pub WatertightRay);

impl BlockTest for WatertightTest {
    #[inline(always)]
    fn test<L: Lanes>(
        &self,
        l: L,
        ray: &Ray,
        (block, first, valid): (&TriangleBlock, usize, u32),
        tmax: f32,
    ) -> LaneHits<L> {
        self.0
            .intersect_block(l, block, first, valid, (ray.tmin, tmax))
    }
}

/// How many lanes of `bits` (a mask of `WIDTH` lanes) are set: on one lane the bit itself, as
/// `count_ones` without POPCNT (the baseline x86-64) is a dozen instructions.
#[inline(always)]
fn set_lanes<L: Lanes>(bits: u32) -> u64 {
    if L::WIDTH == 1 {
        u64::from(bits & 1)
    } else {
        u64::from(bits.count_ones())
    }
}

/// The vectors of `WIDTH` triangles of `leaf` that hold real ones: `(block, index of the block
/// in the tree's blocks, first lane, valid lanes)`, in leaf order.
#[inline(always)]
fn lane_vectors<'a, L: Lanes>(
    leaf: &LeafEntry<'a>,
) -> impl Iterator<Item = (&'a TriangleBlock, usize, usize, u32)> + 'a {
    let (blocks, len, w) = (leaf.triangles.blocks, leaf.triangles.len(), L::WIDTH);
    let base = leaf.record.first as usize;
    let lane_bits = if w >= 32 { u32::MAX } else { (1u32 << w) - 1 };
    (0..len.div_ceil(w)).map(move |v| {
        let (start, rest) = (v * w, len - v * w);
        let valid = if rest >= w {
            lane_bits
        } else {
            (1u32 << rest) - 1
        };
        let (b, first) = (start / BLOCK, start % BLOCK);
        (&blocks[b], base + b, first, valid)
    })
}

/// The closest hit of `ray` that `accept` accepts (the tie rule of [`Hit::is_beaten_by`]) and
/// the work it took, one ray against `WIDTH` triangles per test, after `cull` has dropped what
/// it can. With [`Scalar`](kdbeam_kernels::lanes::Scalar) lanes this is the scalar reference;
/// every width finds the same hit, bit for bit: each lane computes what the scalar test does,
/// and the lanes' hits are taken in leaf order through `is_beaten_by` (a hit the scalar loop
/// would have rejected by its shrinking `tmax` lies beyond the best so far, so `is_beaten_by`
/// rejects it too). `accept` sees exactly the candidates that beat the closest accepted hit so
/// far, so it is asked the same questions on every width; a rejected hit never shortens the
/// ray, nor what `cull` is told of it.
#[inline(always)]
pub(crate) fn closest_hit<L: Lanes>(
    l: L,
    tree: &KdTree,
    ray: &Ray,
    test: &impl BlockTest,
    cull: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (Hit, RayCounters) {
    let mut v = Closest::new(l, ray, test, cull, accept);
    traverse_lanes(l, tree, ray, &mut v);
    (v.hit, v.leaves.counters)
}

/// What the leaf visitors of [`closest_hit`] and [`any_hit`] share: the ray, its test, its
/// culling stage, the filter and the work counted.
struct RayLeaves<'a, L, T, C, A> {
    l: L,
    ray: &'a Ray,
    test: &'a T,
    cull: C,
    accept: A,
    counters: RayCounters,
}

impl<'a, L: Lanes, T: BlockTest, C: TriangleCull, A> RayLeaves<'a, L, T, C, A> {
    #[inline(always)]
    fn new(l: L, ray: &'a Ray, test: &'a T, cull: C, accept: A) -> Self {
        RayLeaves {
            l,
            ray,
            test,
            cull,
            accept,
            counters: RayCounters::default(),
        }
    }

    /// Counts the leaf entered; `false` when the culling stage skips it.
    #[inline(always)]
    fn enter(&mut self, leaf: &LeafEntry<'_>) -> bool {
        self.counters.leaves += 1;
        if self.cull.enter(self.ray, leaf) {
            return true;
        }
        self.counters.leaves_culled += 1;
        self.counters.culled += leaf.triangles.len() as u64;
        false
    }

    /// The hits of the lanes `valid` of triangles `first..` of the block (`index` in the
    /// tree's blocks) in `[tmin, tmax]`, of those the culling stage keeps, the tests counted;
    /// `None` when it keeps none.
    #[inline(always)]
    fn test(
        &mut self,
        (block, index, first, valid): (&TriangleBlock, usize, usize, u32),
        tmax: f32,
    ) -> Option<LaneHits<L>> {
        let kept = self.cull.lanes(self.l, self.ray, index, first, valid, tmax);
        self.counters.tests += set_lanes::<L>(kept);
        self.counters.culled += set_lanes::<L>(valid & !kept);
        if kept == 0 {
            return None;
        }
        Some(self.test.test(self.l, self.ray, (block, first, kept), tmax))
    }
}

/// The leaf visitor of [`closest_hit`].
struct Closest<'a, L, T, C, A> {
    leaves: RayLeaves<'a, L, T, C, A>,
    hit: Hit,
}

impl<'a, L: Lanes, T: BlockTest, C: TriangleCull, A> Closest<'a, L, T, C, A> {
    #[inline(always)]
    fn new(l: L, ray: &'a Ray, test: &'a T, cull: C, accept: A) -> Self {
        Closest {
            leaves: RayLeaves::new(l, ray, test, cull, accept),
            hit: Hit::NONE,
        }
    }
}

impl<L: Lanes, T: BlockTest, C: TriangleCull, A: FnMut(&Hit) -> bool> LeafVisitor
    for Closest<'_, L, T, C, A>
{
    #[inline(always)]
    fn visit(&mut self, leaf: LeafEntry<'_>) -> Option<f32> {
        if !self.leaves.enter(&leaf) {
            return Some(self.hit.t);
        }
        let mut vectors = lane_vectors::<L>(&leaf);
        // `next` directly: a `for` loop may leave the forwarding `next` out of line.
        #[allow(clippy::while_let_on_iterator)]
        while let Some((block, index, first, valid)) = vectors.next() {
            let tmax = if self.hit.is_hit() {
                self.hit.t
            } else {
                self.leaves.ray.tmax
            };
            let Some(h) = self.leaves.test((block, index, first, valid), tmax) else {
                continue;
            };
            let mut lanes = h.mask.bits();
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let (t, id) = (h.t.extract(lane), block.ids[first + lane]);
                if self.hit.is_beaten_by(t, id) {
                    let candidate = Hit {
                        t,
                        u: h.u.extract(lane),
                        v: h.v.extract(lane),
                        triangle: id,
                    };
                    if (self.leaves.accept)(&candidate) {
                        self.hit = candidate;
                    }
                }
            }
        }
        Some(self.hit.t)
    }
}

/// Whether anything that `accept` accepts is hit in `[ray.tmin, ray.tmax]`, stopping at the
/// first accepted hit, after `cull` has dropped what it can (always told `ray.tmax`: an any-hit
/// query never shortens its ray). Until then `accept` sees the hits in no particular order (a
/// triangle in several leaves possibly more than once).
#[inline(always)]
pub(crate) fn any_hit<L: Lanes>(
    l: L,
    tree: &KdTree,
    ray: &Ray,
    test: &impl BlockTest,
    cull: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (bool, RayCounters) {
    let mut v = Any::new(l, ray, test, cull, accept);
    traverse_lanes(l, tree, ray, &mut v);
    (v.found, v.leaves.counters)
}

/// The leaf visitor of [`any_hit`].
struct Any<'a, L, T, C, A> {
    leaves: RayLeaves<'a, L, T, C, A>,
    found: bool,
}

impl<'a, L: Lanes, T: BlockTest, C: TriangleCull, A> Any<'a, L, T, C, A> {
    #[inline(always)]
    fn new(l: L, ray: &'a Ray, test: &'a T, cull: C, accept: A) -> Self {
        Any {
            leaves: RayLeaves::new(l, ray, test, cull, accept),
            found: false,
        }
    }
}

impl<L: Lanes, T: BlockTest, C: TriangleCull, A: FnMut(&Hit) -> bool> LeafVisitor
    for Any<'_, L, T, C, A>
{
    const FARTHEST_FIRST: bool = true;
    #[inline(always)]
    fn visit(&mut self, leaf: LeafEntry<'_>) -> Option<f32> {
        if !self.leaves.enter(&leaf) {
            return Some(f32::INFINITY);
        }
        let mut vectors = lane_vectors::<L>(&leaf);
        #[allow(clippy::while_let_on_iterator)]
        while let Some((block, index, first, valid)) = vectors.next() {
            let tmax = self.leaves.ray.tmax;
            let Some(h) = self.leaves.test((block, index, first, valid), tmax) else {
                continue;
            };
            let mut lanes = h.mask.bits();
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let hit = Hit {
                    t: h.t.extract(lane),
                    u: h.u.extract(lane),
                    v: h.v.extract(lane),
                    triangle: block.ids[first + lane],
                };
                if (self.leaves.accept)(&hit) {
                    self.found = true;
                    return None;
                }
            }
        }
        Some(f32::INFINITY)
    }
}

/// The test of one ray, made from the ray (the watertight test's shear is per ray).
pub(crate) trait RayTest: BlockTest {
    /// The test of `ray`.
    fn for_ray(ray: &Ray) -> Self;
}

impl RayTest for KsTest {
    #[inline(always)]
    fn for_ray(_: &Ray) -> Self {
        KsTest
    }
}

impl RayTest for WatertightTest {
    #[inline(always)]
    fn for_ray(ray: &Ray) -> Self {
        WatertightTest(WatertightRay::new(ray))
    }
}

/// Two rays unculled, each with its own test `T`, every hit accepted: with `ANY`, whether each
/// hits anything (its hit then [`Hit::NONE`]), otherwise each one's closest hit, exactly as
/// [`closest_hit`] and [`any_hit`] give them; on SIMD lanes the two walks interleaved
/// ([`super::wide::traverse_pair`]), so that the CPU overlaps their latencies.
#[inline(always)]
pub(crate) fn pair<L: Lanes, T: RayTest, const ANY: bool>(
    l: L,
    tree: &KdTree,
    rays: [&Ray; 2],
) -> [(bool, Hit, RayCounters); 2] {
    let tests = [T::for_ray(rays[0]), T::for_ray(rays[1])];
    let accept = |_: &Hit| true;
    if ANY {
        let mut a = Any::new(l, rays[0], &tests[0], NoCull, accept);
        let mut b = Any::new(l, rays[1], &tests[1], NoCull, accept);
        traverse_pair(l, tree, rays, [&mut a, &mut b]);
        [
            (a.found, Hit::NONE, a.leaves.counters),
            (b.found, Hit::NONE, b.leaves.counters),
        ]
    } else {
        let mut a = Closest::new(l, rays[0], &tests[0], NoCull, accept);
        let mut b = Closest::new(l, rays[1], &tests[1], NoCull, accept);
        traverse_pair(l, tree, rays, [&mut a, &mut b]);
        [
            (a.hit.is_hit(), a.hit, a.leaves.counters),
            (b.hit.is_hit(), b.hit, b.leaves.counters),
        ]
    }
}

/// The rays of lanes `lanes` of `packet`'s columns `base..base + L::WIDTH` (traceable ones),
/// unculled, each with its own test `T`, every hit accepted, walked together
/// ([`super::wide_lanes::traverse`]); `record(i, result)` gets ray `base + i`'s result, as
/// [`pair`] gives it.
#[inline(always)]
pub(crate) fn lanes<L: Lanes, T: RayTest, const ANY: bool>(
    l: L,
    tree: &KdTree,
    packet: &RayPacket,
    base: usize,
    lanes: u32,
    record: impl FnMut(usize, (bool, Hit, RayCounters)),
) {
    let width = L::WIDTH.min(packet.len() - base);
    let rays: ArrayVec<Ray, 16> = (0..width).map(|i| packet.ray(base + i)).collect();
    let tests: ArrayVec<T, 16> = rays.iter().map(T::for_ray).collect();
    let walk = LaneWalk {
        l,
        tree,
        packet,
        base,
        lanes,
        rays: &rays,
    };
    let accept = |_: &Hit| true;
    let each = rays.iter().zip(&tests);
    if ANY {
        let visitors = each.map(|(ray, test)| Any::new(l, ray, test, NoCull, accept));
        walk.run::<_, false>(visitors.collect(), record, |v| {
            (v.found, Hit::NONE, v.leaves.counters)
        });
    } else {
        let visitors = each.map(|(ray, test)| Closest::new(l, ray, test, NoCull, accept));
        walk.run::<_, true>(visitors.collect(), record, |v| {
            (v.hit.is_hit(), v.hit, v.leaves.counters)
        });
    }
}

/// One lane group's walk of [`lanes`]: what [`super::wide_lanes::traverse`] reads.
struct LaneWalk<'a, L> {
    l: L,
    tree: &'a KdTree,
    packet: &'a RayPacket,
    base: usize,
    lanes: u32,
    rays: &'a [Ray],
}

impl<L: Lanes> LaneWalk<'_, L> {
    /// Walks the group with a visitor per lane, then gives `record` each traced lane's
    /// `result`.
    #[inline(always)]
    fn run<V: LeafVisitor, const NEAREST_FIRST: bool>(
        &self,
        mut visitors: ArrayVec<V, 16>,
        mut record: impl FnMut(usize, (bool, Hit, RayCounters)),
        result: impl Fn(&V) -> (bool, Hit, RayCounters),
    ) {
        let (l, tree, lanes) = (self.l, self.tree, self.lanes);
        let rays = (self.packet, self.base, self.rays);
        super::wide_lanes::traverse::<_, _, NEAREST_FIRST>(l, tree, rays, lanes, &mut visitors);
        for (i, v) in visitors.iter().enumerate() {
            if lanes >> i & 1 != 0 {
                record(i, result(v));
            }
        }
    }
}

/// [`traverse_lanes`] of two rays: interleaved on SIMD lanes, one after the other on scalar
/// ones.
#[inline(always)]
fn traverse_pair<L: Lanes, V: LeafVisitor>(
    l: L,
    tree: &KdTree,
    rays: [&Ray; 2],
    visitors: [&mut V; 2],
) {
    let [a, b] = visitors;
    if L::WIDTH == 1 {
        traverse(tree, rays[0], a);
        traverse(tree, rays[1], b);
    } else {
        super::wide::traverse_pair(l.up_to_8(), tree, rays, [a, b]);
    }
}

/// A single-ray query as a task generic over the lanes: `ANY` for [`any_hit`] (the hit is then
/// [`Hit::NONE`]), else [`closest_hit`]; `cull` drops what it can, and only hits `accept`
/// accepts count.
pub(crate) struct SingleRay<'a, T, C, A, const ANY: bool> {
    pub tree: &'a KdTree,
    pub ray: &'a Ray,
    pub test: T,
    pub cull: C,
    pub accept: A,
}

impl<T: BlockTest, C: TriangleCull, A: FnMut(&Hit) -> bool, const ANY: bool> LaneTask
    for SingleRay<'_, T, C, A, ANY>
{
    type Output = (bool, Hit, RayCounters);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (bool, Hit, RayCounters) {
        if ANY {
            let (found, counters) =
                any_hit(l, self.tree, self.ray, &self.test, self.cull, self.accept);
            (found, Hit::NONE, counters)
        } else {
            let (hit, counters) =
                closest_hit(l, self.tree, self.ray, &self.test, self.cull, self.accept);
            (hit.is_hit(), hit, counters)
        }
    }
}
