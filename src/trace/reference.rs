//! Exact references: the f64 watertight oracle, over every triangle or through the kd-tree.
//!
//! These are for tests and the accuracy benchmark, not for speed: the brute force is
//! O(triangles) per ray.

use kdbeam_kernels::intersect::oracle::OracleRay;
use kdbeam_kernels::{DVec3, Ray, Triangle};

use super::single::{self, LeafEntry, LeafVisitor};
use crate::kdtree::KdTree;
use crate::Mesh;

/// The closest hit as the f64 oracle computes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceHit {
    /// Ray parameter, in f64.
    pub t: f64,
    /// Mesh triangle id.
    pub triangle: u32,
}

impl ReferenceHit {
    #[inline]
    fn beats(&self, other: &Option<ReferenceHit>) -> bool {
        other.is_none_or(|o| self.t < o.t || (self.t == o.t && self.triangle < o.triangle))
    }
}

/// The closest hit of `ray` over every triangle of `mesh`, by the f64 oracle, in
/// `[ray.tmin, ray.tmax]`; equal `t` goes to the smaller id. `None` for a miss or a ray that
/// cannot be traced (see [`crate::Tracer::intersect`]).
#[must_use]
pub fn brute_force(mesh: &Mesh, ray: &Ray) -> Option<ReferenceHit> {
    if !single::is_traceable(ray) {
        return None;
    }
    closest_among(ray, mesh.triangles().enumerate())
}

/// The closest oracle hit of the traceable `ray` among `triangles` (mesh ids with their
/// triangles, in id order), in `[ray.tmin, ray.tmax]`; equal `t` goes to the smaller id.
fn closest_among(
    ray: &Ray,
    triangles: impl Iterator<Item = (usize, Triangle)>,
) -> Option<ReferenceHit> {
    let oracle = OracleRay::new(ray);
    let (tmin, tmax) = (f64::from(ray.tmin), f64::from(ray.tmax));
    let mut best = None;
    for (id, tri) in triangles {
        if let Some(h) = oracle.intersect(&tri, tmin, tmax) {
            let hit = ReferenceHit {
                t: h.t,
                triangle: id as u32,
            };
            if hit.beats(&best) {
                best = Some(hit);
            }
        }
    }
    best
}

/// [`brute_force`] for many rays of one mesh: the same hits, bit for bit, with most of the
/// oracle's tests skipped.
///
/// Each triangle's box is made once, and a ray's oracle test of a triangle is skipped when the
/// ray's line misses the box padded by 2⁻³⁰ of the largest magnitude among the box's and the
/// origin's coordinates. The skip is conservative: the slab distances `(plane − o)·(1/d)`
/// differ from the exact ones by two roundings (the difference of two f32 values is exact in
/// f64 unless their magnitudes are 2²⁹ apart, where the padding dwarfs the smaller), far
/// less than the padding's share of `t`; and a point the oracle reports lies on the triangle
/// up to the rounding of its own f64 projection, which the padding also covers. The
/// triangles left are tested in id order with [`brute_force`]'s tie break, so the closest hit
/// is the same.
pub struct BruteForce<'m> {
    mesh: &'m Mesh,
    /// Per triangle: its box's corners and the largest magnitude of their coordinates.
    boxes: Vec<(DVec3, DVec3, f64)>,
}

/// [`BruteForce`]'s padding of a triangle's box, relative to the largest coordinate magnitude
/// of the box and the ray's origin.
const BOX_PAD: f64 = 1.0 / (1u64 << 30) as f64;

impl<'m> BruteForce<'m> {
    /// The boxes of `mesh`'s triangles, for [`BruteForce::closest`].
    #[must_use]
    pub fn new(mesh: &'m Mesh) -> Self {
        let boxes = mesh
            .triangles()
            .map(|t| {
                let (v0, v1, v2) = (t.v0.as_dvec3(), t.v1.as_dvec3(), t.v2.as_dvec3());
                let (lo, hi) = (v0.min(v1).min(v2), v0.max(v1).max(v2));
                (lo, hi, lo.abs().max(hi.abs()).max_element())
            })
            .collect();
        BruteForce { mesh, boxes }
    }

    /// [`brute_force`] of `ray` over this mesh.
    #[must_use]
    pub fn closest(&self, ray: &Ray) -> Option<ReferenceHit> {
        if !single::is_traceable(ray) {
            return None;
        }
        let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
        let inv = d.recip();
        let o_magnitude = o.abs().max_element();
        let candidates = self
            .boxes
            .iter()
            .enumerate()
            .filter(|(_, &(lo, hi, magnitude))| {
                let pad = DVec3::splat(magnitude.max(o_magnitude) * BOX_PAD);
                line_meets_box(o, d, inv, lo - pad, hi + pad)
            });
        closest_among(ray, candidates.map(|(id, _)| (id, self.mesh.triangle(id))))
    }
}

/// Whether the line `o + t·d` (finite, `d ≠ 0`; `inv = 1/d`) meets the box `[lo, hi]`, by
/// slabs in f64. An axis with `d = 0` constrains nothing when `o` lies in its slab, and
/// excludes the box otherwise.
#[inline]
fn line_meets_box(o: DVec3, d: DVec3, inv: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
    for axis in 0..3 {
        if d[axis] == 0.0 {
            if o[axis] < lo[axis] || o[axis] > hi[axis] {
                return false;
            }
            continue;
        }
        let (a, b) = (
            (lo[axis] - o[axis]) * inv[axis],
            (hi[axis] - o[axis]) * inv[axis],
        );
        enter = enter.max(a.min(b));
        exit = exit.min(a.max(b));
    }
    enter <= exit
}

/// The closest hit of `ray` through `tree`, each leaf tested by the f64 oracle: equal to
/// [`brute_force`] when the tree is right (the kd-tree tests check exactly that).
#[must_use]
pub fn kd_oracle(tree: &KdTree, ray: &Ray) -> Option<ReferenceHit> {
    struct Oracle {
        ray: OracleRay,
        tmin: f64,
        tmax: f64,
        best: Option<ReferenceHit>,
    }
    impl LeafVisitor for Oracle {
        fn visit(&mut self, leaf: LeafEntry<'_>) -> Option<f32> {
            let leaf = leaf.triangles;
            for i in 0..leaf.len() {
                let id = leaf.id(i);
                if let Some(h) = self.ray.intersect(&leaf.triangle(i), self.tmin, self.tmax) {
                    let hit = ReferenceHit {
                        t: h.t,
                        triangle: id,
                    };
                    if hit.beats(&self.best) {
                        self.best = Some(hit);
                    }
                }
            }
            // Round up so that traversal never stops before a cell the f64 hit may lie in.
            Some(self.best.map_or(f32::INFINITY, |b| (b.t as f32).next_up()))
        }
    }
    let mut v = Oracle {
        ray: OracleRay::new(ray),
        tmin: f64::from(ray.tmin),
        tmax: f64::from(ray.tmax),
        best: None,
    };
    single::traverse(tree, ray, &mut v);
    v.best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rays::random_rays;
    use crate::scene::procedural::builtin;
    use crate::Vec3;

    /// Rays the padding must not lose hits of: random ones and, for every seventh triangle (at
    /// most 300), axis-parallel ones through two of its vertices (zero direction components,
    /// lines on box faces, one from far away), the line of one edge (grazing), one from its
    /// centroid (an origin on the surface) and one from far along its normal.
    fn hard_rays(mesh: &Mesh) -> Vec<Ray> {
        let b = mesh.bounds();
        let mut rays = random_rays(&b, 2000, 7);
        let far = 1.0e7 * (b.extent().length() + 1.0);
        for (i, t) in mesh.triangles().enumerate().step_by(7).take(300) {
            for (k, axis) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                let sign = if (i + k) % 2 == 0 { 1.0 } else { -1.0 };
                rays.push(Ray::new(t.v0 - sign * axis, sign * axis));
                rays.push(Ray::new(t.v1 - far * axis, axis));
            }
            rays.push(Ray::new(t.v0 - (t.v1 - t.v0), t.v1 - t.v0));
            let centroid = (t.v0 + t.v1 + t.v2) / 3.0;
            let normal = (t.v1 - t.v0).cross(t.v2 - t.v0);
            rays.push(Ray::new(centroid, normal + (t.v2 - t.v0)));
            rays.push(Ray::new(
                centroid + far * normal.normalize_or_zero(),
                -normal,
            ));
        }
        rays
    }

    #[test]
    fn the_prefiltered_brute_force_equals_the_plain_one() {
        for name in [
            "icosphere:3",
            "grid:40",
            "soup:3000",
            "hair:3000",
            "terrain:24",
        ] {
            let mesh = builtin(name).unwrap();
            let fast = BruteForce::new(&mesh);
            let rays = hard_rays(&mesh);
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let want = brute_force(&mesh, r);
                hits += usize::from(want.is_some());
                assert_eq!(fast.closest(r), want, "{name}, ray {i}: {r:?}");
            }
            assert!(
                hits * 10 > rays.len(),
                "{name}: {hits} hits of {} rays: too few to test anything",
                rays.len()
            );
        }
    }
}
