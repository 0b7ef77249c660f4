//! Exact references: the f64 watertight oracle, over every triangle or through the kd-tree.
//!
//! These are for tests and the accuracy benchmark, not for speed: the brute force is
//! O(triangles) per ray.

use kdbeam_kernels::intersect::oracle::OracleRay;
use kdbeam_kernels::Ray;

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
    let oracle = OracleRay::new(ray);
    let (tmin, tmax) = (f64::from(ray.tmin), f64::from(ray.tmax));
    let mut best = None;
    for (id, tri) in mesh.triangles().enumerate() {
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
