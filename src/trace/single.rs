//! Single-ray kd-tree traversal: the scalar reference every packet path is checked against.
//!
//! Front to back with a stack, as in pbrt's `KdTreeAccel::Intersect`. A [`LeafVisitor`] tests a
//! leaf's triangles; traversal stops once the closest hit so far lies before the next cell.

use kdbeam_kernels::intersect::{kensler_shirley, watertight::WatertightRay, TriangleHit};
use kdbeam_kernels::{slab, Hit, LaneF32, Ray, Vec3};

use crate::kdtree::{KdTree, LeafTriangles};

/// Deepest stack a traversal needs: the builder caps depth at 64.
pub(crate) const STACK_DEPTH: usize = 64;

/// What a traversal does in each leaf it enters.
pub(crate) trait LeafVisitor {
    /// Tests `leaf`, entered over `[t_enter, t_exit]`. Returns the `t` of the closest hit so far
    /// (`+inf` without one), or `None` to stop the traversal (an any-hit query that found one).
    fn visit(&mut self, leaf: LeafTriangles<'_>, t_enter: f32, t_exit: f32) -> Option<f32>;
}

/// Can this ray be traced? Finite origin and direction, a non-zero direction and
/// `tmin <= tmax` (`tmax` may be `+inf`). Every other ray reports a miss on every path.
#[inline(always)]
#[must_use]
pub fn is_traceable(ray: &Ray) -> bool {
    ray.origin.is_finite()
        && ray.direction.is_finite()
        && ray.direction != Vec3::ZERO
        && ray.tmin <= ray.tmax
        && !ray.tmax.is_nan()
}

/// Walks the leaves `ray` passes through, nearest first, until `visitor` has its answer.
///
/// A cell is entered over the closed interval `[t_enter, t_exit]` (clipped to
/// `[ray.tmin, ray.tmax]`) and skipped once the closest hit so far is strictly before `t_enter`:
/// a triangle hit at exactly that `t` in a later cell may still win the tie on its smaller id.
///
/// The near child is chosen by the sign bit of the direction, and a child is entered when its
/// part of the interval ([`split_intervals`]) is non-empty; this is the packet traversal's rule,
/// lane for lane, so both visit the same leaves.
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
    let mut stack = [(0u32, 0f32, 0f32); STACK_DEPTH];
    let mut top = 0;
    let mut node_index = 0u32;
    let mut best_t = f32::INFINITY;
    loop {
        if t_enter <= best_t {
            let node = nodes[node_index as usize];
            if !node.is_leaf() {
                let axis = node.axis();
                let t_split = (node.split() - ray.origin[axis]) * inv[axis];
                let err = LaneF32::min((ray.origin[axis] * inv[axis]).abs(), f32::MAX);
                let (near, far) = if ray.direction[axis].is_sign_negative() {
                    (node.above_child(), node_index + 1)
                } else {
                    (node_index + 1, node.above_child())
                };
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
                let leaf = &tree.leaves()[node.leaf_record() as usize];
                if leaf.count > 0 {
                    match visitor.visit(tree.leaf_triangles(leaf), t_enter, t_exit) {
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
}

/// One scalar ray–triangle test, as the traversal sees it.
pub(crate) trait ScalarTest {
    /// The hit of `ray` on triangle `i` of `leaf` in `[ray.tmin, tmax]`, if any.
    fn test(&self, ray: &Ray, leaf: &LeafTriangles<'_>, i: usize, tmax: f32)
        -> Option<TriangleHit>;
}

/// The Kensler–Shirley test on the leaf's precomputed form.
pub(crate) struct KsTest;

impl ScalarTest for KsTest {
    #[inline(always)]
    fn test(
        &self,
        ray: &Ray,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmax: f32,
    ) -> Option<TriangleHit> {
        kensler_shirley::intersect(ray, &leaf.ks[i], ray.tmin, tmax)
    }
}

/// The watertight test, its per-ray shear computed once.
pub(crate) struct WatertightTest(pub WatertightRay);

impl ScalarTest for WatertightTest {
    #[inline(always)]
    fn test(
        &self,
        ray: &Ray,
        leaf: &LeafTriangles<'_>,
        i: usize,
        tmax: f32,
    ) -> Option<TriangleHit> {
        self.0.intersect(&leaf.triangles[i], ray.tmin, tmax)
    }
}

/// The closest hit of `ray` (the tie rule of [`Hit::is_beaten_by`]) and the work it took.
pub(crate) fn closest_hit(tree: &KdTree, ray: &Ray, test: &impl ScalarTest) -> (Hit, RayCounters) {
    struct Closest<'a, T> {
        ray: &'a Ray,
        test: &'a T,
        hit: Hit,
        counters: RayCounters,
    }
    impl<T: ScalarTest> LeafVisitor for Closest<'_, T> {
        #[inline(always)]
        fn visit(&mut self, leaf: LeafTriangles<'_>, _: f32, _: f32) -> Option<f32> {
            self.counters.leaves += 1;
            self.counters.tests += leaf.ids.len() as u64;
            for (i, &id) in leaf.ids.iter().enumerate() {
                let tmax = if self.hit.is_hit() {
                    self.hit.t
                } else {
                    self.ray.tmax
                };
                if let Some(h) = self.test.test(self.ray, &leaf, i, tmax) {
                    if self.hit.is_beaten_by(h.t, id) {
                        self.hit = Hit {
                            t: h.t,
                            u: h.u,
                            v: h.v,
                            triangle: id,
                        };
                    }
                }
            }
            Some(self.hit.t)
        }
    }
    let mut v = Closest {
        ray,
        test,
        hit: Hit::NONE,
        counters: RayCounters::default(),
    };
    traverse(tree, ray, &mut v);
    (v.hit, v.counters)
}

/// Whether anything is hit in `[ray.tmin, ray.tmax]`, stopping at the first hit.
pub(crate) fn any_hit(tree: &KdTree, ray: &Ray, test: &impl ScalarTest) -> (bool, RayCounters) {
    struct Any<'a, T> {
        ray: &'a Ray,
        test: &'a T,
        found: bool,
        counters: RayCounters,
    }
    impl<T: ScalarTest> LeafVisitor for Any<'_, T> {
        #[inline(always)]
        fn visit(&mut self, leaf: LeafTriangles<'_>, _: f32, _: f32) -> Option<f32> {
            self.counters.leaves += 1;
            for i in 0..leaf.ids.len() {
                self.counters.tests += 1;
                if self.test.test(self.ray, &leaf, i, self.ray.tmax).is_some() {
                    self.found = true;
                    return None;
                }
            }
            Some(f32::INFINITY)
        }
    }
    let mut v = Any {
        ray,
        test,
        found: false,
        counters: RayCounters::default(),
    };
    traverse(tree, ray, &mut v);
    (v.found, v.counters)
}
