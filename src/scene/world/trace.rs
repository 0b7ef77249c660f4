//! Queries of a committed scene: the top-level BVH walked front to back, each instance's
//! kd-tree traced with the ray carried to its space.

use kdbeam_kernels::{slab, Hit, Ray};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::commit::{Committed, Entry};
use super::top_level::MAX_DEPTH;
use super::{GeometryId, InstanceId, Query, Scene, SceneHit};
use crate::trace::{is_traceable, single_ray, NoCull};
use crate::{Error, Result};

/// Rays per task of a stream.
const STREAM_CHUNK: usize = 256;

impl Scene {
    /// The closest hit of `ray` among every instance and every mesh traced as it is, as of the
    /// last commit: [`SceneHit::NONE`] for a miss, a ray that cannot be traced (see
    /// [`crate::trace::is_traceable`]) or a scene never committed. Ties in `t` as
    /// [`SceneHit::is_beaten_by`].
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> SceneHit {
        self.intersect_with(ray, &Query::default())
    }

    /// [`Scene::intersect`] seeing only the instances `query.mask` selects, and returning the
    /// closest hit `query.filter` accepts.
    #[must_use]
    pub fn intersect_with(&self, ray: &Ray, query: &Query<'_>) -> SceneHit {
        match &self.committed {
            Some(c) if is_traceable(ray) => self.closest(c, ray, query),
            _ => SceneHit::NONE,
        }
    }

    /// Does `ray` hit anything in `[tmin, tmax]`? `false` for a ray that cannot be traced or a
    /// scene never committed.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &Query::default())
    }

    /// [`Scene::occluded`] seeing only the instances `query.mask` selects, and counting only
    /// hits `query.filter` accepts.
    #[must_use]
    pub fn occluded_with(&self, ray: &Ray, query: &Query<'_>) -> bool {
        match &self.committed {
            Some(c) if is_traceable(ray) => self.any(c, ray, query),
            _ => false,
        }
    }

    /// [`Scene::intersect_with`] of every ray of `rays` into `hits[i]` for `rays[i]`, on all
    /// cores with the `parallel` feature.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `hits.len() != rays.len()`, [`Error::NotCommitted`]
    /// for a scene never committed (`hits` then untouched).
    pub fn intersect_stream(
        &self,
        rays: &[Ray],
        hits: &mut [SceneHit],
        query: &Query<'_>,
    ) -> Result<()> {
        check_lengths(rays.len(), hits.len())?;
        if self.committed.is_none() {
            return Err(Error::NotCommitted);
        }
        let run = |(rays, hits): (&[Ray], &mut [SceneHit])| {
            for (r, h) in rays.iter().zip(hits) {
                *h = self.intersect_with(r, query);
            }
        };
        #[cfg(feature = "parallel")]
        rays.par_chunks(STREAM_CHUNK)
            .zip(hits.par_chunks_mut(STREAM_CHUNK))
            .for_each(run);
        #[cfg(not(feature = "parallel"))]
        rays.chunks(STREAM_CHUNK)
            .zip(hits.chunks_mut(STREAM_CHUNK))
            .for_each(run);
        Ok(())
    }

    /// [`Scene::occluded_with`] of every ray of `rays` into `occluded[i]`, on all cores with the
    /// `parallel` feature.
    ///
    /// # Errors
    /// As [`Scene::intersect_stream`].
    pub fn occluded_stream(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        query: &Query<'_>,
    ) -> Result<()> {
        check_lengths(rays.len(), occluded.len())?;
        if self.committed.is_none() {
            return Err(Error::NotCommitted);
        }
        let run = |(rays, out): (&[Ray], &mut [bool])| {
            for (r, o) in rays.iter().zip(out) {
                *o = self.occluded_with(r, query);
            }
        };
        #[cfg(feature = "parallel")]
        rays.par_chunks(STREAM_CHUNK)
            .zip(occluded.par_chunks_mut(STREAM_CHUNK))
            .for_each(run);
        #[cfg(not(feature = "parallel"))]
        rays.chunks(STREAM_CHUNK)
            .zip(occluded.chunks_mut(STREAM_CHUNK))
            .for_each(run);
        Ok(())
    }
}

fn check_lengths(rays: usize, out: usize) -> Result<()> {
    if rays == out {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name: "stream output",
            message: format!("{out} outputs for {rays} rays"),
        })
    }
}

/// `ray` in `entry`'s mesh space, over `[ray.tmin, tmax]`: the same `t` names the same point.
#[inline]
pub(super) fn object_ray(entry: &Entry, ray: &Ray, tmax: f32) -> Ray {
    if entry.as_is {
        return Ray { tmax, ..*ray };
    }
    Ray {
        origin: entry.to_object.transform_point3(ray.origin),
        direction: entry.to_object.transform_vector3(ray.direction),
        tmin: ray.tmin,
        tmax,
    }
}

#[inline]
pub(super) fn scene_hit(entry: &Entry, h: &Hit) -> SceneHit {
    SceneHit {
        t: h.t,
        u: h.u,
        v: h.v,
        triangle: h.triangle,
        geometry: GeometryId(entry.geometry),
        instance: InstanceId(entry.instance),
    }
}

/// Visits the entries whose boxes `ray` enters over `[ray.tmin, bound]`, nearest box first,
/// where `visit` returns the new `bound` (the closest hit so far) or `None` to stop.
#[inline(always)]
fn walk(c: &Committed, ray: &Ray, mask: u32, mut visit: impl FnMut(&Entry, f32) -> Option<f32>) {
    let Some(root) = c.top.nodes.first() else {
        return;
    };
    let inv = ray.direction.recip();
    let hit_box = |b, bound| slab::ray_box(ray.origin, inv, ray.tmin, bound, b);
    let mut bound = ray.tmax;
    let Some((t0, _)) = hit_box(&root.bounds, bound) else {
        return;
    };
    let mut stack = [(0u32, 0f32); MAX_DEPTH + 2];
    stack[0] = (0, t0);
    let mut top = 1;
    while top > 0 {
        top -= 1;
        let (n, t_enter) = stack[top];
        if t_enter > bound {
            continue;
        }
        let node = &c.top.nodes[n as usize];
        if node.count > 0 {
            let items = &c.top.items[node.first as usize..(node.first + node.count) as usize];
            for &i in items {
                let e = &c.entries[i as usize];
                if e.mask & mask == 0 {
                    continue;
                }
                match visit(e, bound) {
                    Some(b) => bound = b,
                    None => return,
                }
            }
            continue;
        }
        let (l, r) = (node.first, node.first + 1);
        let tl = hit_box(&c.top.nodes[l as usize].bounds, bound).map(|h| h.0);
        let tr = hit_box(&c.top.nodes[r as usize].bounds, bound).map(|h| h.0);
        // Push the farther child first so the nearer one is visited first.
        let mut push = |child: u32, t: Option<f32>| {
            if let Some(t) = t {
                stack[top] = (child, t);
                top += 1;
            }
        };
        match (tl, tr) {
            (Some(a), Some(b)) if b < a => {
                push(l, tl);
                push(r, tr);
            }
            _ => {
                push(r, tr);
                push(l, tl);
            }
        }
    }
}

impl Scene {
    /// The closest accepted hit over the entries `ray` meets, each instance's tree traced on
    /// the scene's ISA ([`single_ray`]: a vector of a leaf's triangles per test), the filter,
    /// if any, asked about each candidate in its scene-level form.
    fn closest(&self, c: &Committed, ray: &Ray, query: &Query<'_>) -> SceneHit {
        let mut best = SceneHit::NONE;
        walk(c, ray, query.mask, |e, bound| {
            let tree = &c.blas[e.blas as usize].tree;
            let r = object_ray(e, ray, bound);
            let (_, h, _) = match query.filter {
                None => {
                    single_ray::<false>(self.dispatch, tree, self.intersector, &r, NoCull, |_| true)
                }
                Some(f) => {
                    single_ray::<false>(self.dispatch, tree, self.intersector, &r, NoCull, |h| {
                        f(&scene_hit(e, h))
                    })
                }
            };
            if h.is_hit() {
                let candidate = scene_hit(e, &h);
                if best.is_beaten_by(&candidate) {
                    best = candidate;
                }
            }
            Some(best.t.min(ray.tmax))
        });
        best
    }

    /// Is there an accepted hit on any entry `ray` meets? As [`Scene::closest`], stopping at
    /// the first.
    fn any(&self, c: &Committed, ray: &Ray, query: &Query<'_>) -> bool {
        let mut found = false;
        walk(c, ray, query.mask, |e, bound| {
            let tree = &c.blas[e.blas as usize].tree;
            let r = object_ray(e, ray, bound);
            (found, ..) = match query.filter {
                None => {
                    single_ray::<true>(self.dispatch, tree, self.intersector, &r, NoCull, |_| true)
                }
                Some(f) => {
                    single_ray::<true>(self.dispatch, tree, self.intersector, &r, NoCull, |h| {
                        f(&scene_hit(e, h))
                    })
                }
            };
            (!found).then_some(bound)
        });
        found
    }
}
