//! Single rays whose hits a caller may reject: the scalar traversal with a hit filter, for
//! alpha-tested geometry and for scenes of many trees.
//!
//! A rejected hit never shortens the ray: only accepted hits bound the rest of the traversal,
//! so no hit behind a rejected one is lost.

use kdbeam_kernels::intersect::watertight::WatertightRay;
use kdbeam_kernels::lanes::Scalar;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Hit, LaneF32, LaneMask, Ray};

use super::single::{traverse, BlockTest, KsTest, LeafVisitor, WatertightTest};
use super::Intersector;
use crate::kdtree::{KdTree, LeafTriangles};

/// The closest hit of `ray` in `tree` that `accept` accepts; [`Hit::NONE`] when there is none
/// or the ray cannot be traced (see [`super::is_traceable`]).
///
/// `accept` is called with each candidate hit in `[ray.tmin, ray.tmax]` that is closer than
/// the closest accepted hit so far (so it may see hits that a later, closer accepted hit
/// beats), once per test: a triangle that lies in several leaves may be offered more than
/// once, so `accept` must give the same answer for the same hit. Equal `t` goes to the smaller
/// triangle id, as in [`super::Tracer::intersect`]; with an `accept` that accepts every hit the
/// result equals it bit for bit.
///
/// ```
/// use kdbeam::{trace::filtered, BuildParams, Intersector, KdTree, Mesh, Ray, Vec3};
/// // Two parallel triangles at z = 1 and z = 2.
/// let mesh = Mesh::from_indexed(
///     &[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]],
///     &[0, 1, 2, 3, 4, 5],
/// )?;
/// let tree = KdTree::build(&mesh, &BuildParams::default())?;
/// let ray = Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z);
/// let hit = filtered::closest_hit(&tree, Intersector::KenslerShirley, &ray, |h| h.triangle != 0);
/// assert_eq!((hit.triangle, hit.t), (1, 2.0));
/// # Ok::<(), kdbeam::Error>(())
/// ```
pub fn closest_hit(
    tree: &KdTree,
    intersector: Intersector,
    ray: &Ray,
    accept: impl FnMut(&Hit) -> bool,
) -> Hit {
    match intersector {
        Intersector::KenslerShirley => closest_with(tree, ray, &KsTest, accept),
        Intersector::Watertight => {
            closest_with(tree, ray, &WatertightTest(WatertightRay::new(ray)), accept)
        }
    }
}

/// Whether `ray` hits anything in `tree` in `[ray.tmin, ray.tmax]` that `accept` accepts;
/// `false` for a ray that cannot be traced. Stops at the first accepted hit; until then
/// `accept` sees the hits in no particular order (a triangle in several leaves possibly more
/// than once).
pub fn any_hit(
    tree: &KdTree,
    intersector: Intersector,
    ray: &Ray,
    accept: impl FnMut(&Hit) -> bool,
) -> bool {
    match intersector {
        Intersector::KenslerShirley => any_with(tree, ray, &KsTest, accept),
        Intersector::Watertight => {
            any_with(tree, ray, &WatertightTest(WatertightRay::new(ray)), accept)
        }
    }
}

/// The hit of `ray` on triangle `i` of `leaf` in `[ray.tmin, tmax]`, by the scalar reference
/// (one lane of the block test).
#[inline(always)]
fn scalar_test(
    test: &impl BlockTest,
    ray: &Ray,
    leaf: &LeafTriangles<'_>,
    i: usize,
    tmax: f32,
) -> Option<Hit> {
    let (block, first) = (&leaf.blocks[i / BLOCK], i % BLOCK);
    let h = test.test(Scalar, ray, (block, first, 1), tmax);
    h.mask.any().then(|| Hit {
        t: h.t.extract(0),
        u: h.u.extract(0),
        v: h.v.extract(0),
        triangle: block.ids[first],
    })
}

fn closest_with<T: BlockTest, F: FnMut(&Hit) -> bool>(
    tree: &KdTree,
    ray: &Ray,
    test: &T,
    accept: F,
) -> Hit {
    struct Closest<'a, T, F> {
        ray: &'a Ray,
        test: &'a T,
        accept: F,
        hit: Hit,
    }
    impl<T: BlockTest, F: FnMut(&Hit) -> bool> LeafVisitor for Closest<'_, T, F> {
        #[inline(always)]
        fn visit(&mut self, leaf: LeafTriangles<'_>, _: f32, _: f32) -> Option<f32> {
            for i in 0..leaf.len() {
                let tmax = if self.hit.is_hit() {
                    self.hit.t
                } else {
                    self.ray.tmax
                };
                if let Some(candidate) = scalar_test(self.test, self.ray, &leaf, i, tmax) {
                    if self.hit.is_beaten_by(candidate.t, candidate.triangle)
                        && (self.accept)(&candidate)
                    {
                        self.hit = candidate;
                    }
                }
            }
            Some(self.hit.t)
        }
    }
    let mut v = Closest {
        ray,
        test,
        accept,
        hit: Hit::NONE,
    };
    traverse(tree, ray, &mut v);
    v.hit
}

fn any_with<T: BlockTest, F: FnMut(&Hit) -> bool>(
    tree: &KdTree,
    ray: &Ray,
    test: &T,
    accept: F,
) -> bool {
    struct Any<'a, T, F> {
        ray: &'a Ray,
        test: &'a T,
        accept: F,
        found: bool,
    }
    impl<T: BlockTest, F: FnMut(&Hit) -> bool> LeafVisitor for Any<'_, T, F> {
        #[inline(always)]
        fn visit(&mut self, leaf: LeafTriangles<'_>, _: f32, _: f32) -> Option<f32> {
            for i in 0..leaf.len() {
                if let Some(hit) = scalar_test(self.test, self.ray, &leaf, i, self.ray.tmax) {
                    if (self.accept)(&hit) {
                        self.found = true;
                        return None;
                    }
                }
            }
            Some(f32::INFINITY)
        }
    }
    let mut v = Any {
        ray,
        test,
        accept,
        found: false,
    };
    traverse(tree, ray, &mut v);
    v.found
}
