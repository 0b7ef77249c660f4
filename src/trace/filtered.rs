//! Single rays whose hits a caller may reject, for alpha-tested geometry: the scalar reference
//! traversal with a hit filter.
//!
//! A rejected hit never shortens the ray: only accepted hits bound the rest of the traversal,
//! so no hit behind a rejected one is lost. These run on scalar lanes, the reference; the
//! same traversal on the widest ISA, bit for bit the same hits, is what
//! [`crate::scene::world::Scene`] runs with its [`Query`](crate::scene::world::Query)'s filter.

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Hit, Ray};

use super::{single_ray, Intersector, NoCull, Tracer};
use crate::kdtree::KdTree;

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
    single_ray::<false>(Dispatch::SCALAR, tree, intersector, ray, NoCull, accept).1
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
    single_ray::<true>(Dispatch::SCALAR, tree, intersector, ray, NoCull, accept).0
}

/// [`closest_hit`] on `tracer`'s tree, ISA, intersector and single-ray culling stages: the
/// same hit, bit for bit.
pub fn closest_hit_on(tracer: &Tracer<'_>, ray: &Ray, accept: impl FnMut(&Hit) -> bool) -> Hit {
    tracer.single_filtered::<false>(ray, accept).1
}

/// [`any_hit`] on `tracer`'s tree, ISA, intersector and single-ray culling stages.
pub fn any_hit_on(tracer: &Tracer<'_>, ray: &Ray, accept: impl FnMut(&Hit) -> bool) -> bool {
    tracer.single_filtered::<true>(ray, accept).0
}
