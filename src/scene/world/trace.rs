//! Queries of a committed scene: the top-level BVH walked front to back by its wide nodes, each
//! instance's kd-tree traced with the ray carried to its space, all on the ISA resolved once
//! for the ray.

use kdbeam_kernels::{slab, Hit, LaneTask, Lanes, Ray, Vec3};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::commit::{Committed, Entry};
use super::{GeometryId, InstanceId, Query, Scene, SceneHit};
use crate::trace::wide::{self, WideLeaves};
use crate::trace::{is_traceable, single_ray_on, NoCull};
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

impl Scene {
    /// The closest accepted hit over the entries `ray` meets, each instance's tree traced on
    /// the scene's ISA ([`single_ray_on`]: a vector of a leaf's triangles per test), the filter,
    /// if any, asked about each candidate in its scene-level form.
    fn closest(&self, c: &Committed, ray: &Ray, query: &Query<'_>) -> SceneHit {
        self.dispatch
            .run(SceneRay::<false>::new(self, c, ray, query))
            .best
    }

    /// Is there an accepted hit on any entry `ray` meets? As [`Scene::closest`], stopping at
    /// the first.
    fn any(&self, c: &Committed, ray: &Ray, query: &Query<'_>) -> bool {
        self.dispatch
            .run(SceneRay::<true>::new(self, c, ray, query))
            .found
    }
}

/// One traceable ray through a committed scene, as a task generic over the lanes: with `ANY`,
/// whether there is an accepted hit; otherwise the closest accepted hit.
///
/// The top level's wide nodes are walked a vector of child boxes per step
/// ([`wide::walk`]); in a leaf of several entries each entry's own box is tested; each entry
/// the ray meets over `[tmin, bound]` (`bound` the closest hit so far) has its tree traced
/// with the ray carried to its space.
struct SceneRay<'a, const ANY: bool> {
    scene: &'a Scene,
    c: &'a Committed,
    ray: &'a Ray,
    inv: Vec3,
    query: &'a Query<'a>,
    best: SceneHit,
    found: bool,
}

impl<'a, const ANY: bool> SceneRay<'a, ANY> {
    fn new(scene: &'a Scene, c: &'a Committed, ray: &'a Ray, query: &'a Query<'a>) -> Self {
        SceneRay {
            scene,
            c,
            ray,
            inv: ray.direction.recip(),
            query,
            best: SceneHit::NONE,
            found: false,
        }
    }

    /// Traces `e`'s tree over `[tmin, bound]`; the new bound, or `None` once `ANY` found a hit.
    #[inline(always)]
    fn entry<L: Lanes>(&mut self, l: L, e: &Entry, bound: f32) -> Option<f32> {
        let tree = &self.c.blas[e.blas as usize].tree;
        let r = object_ray(e, self.ray, bound);
        let intersector = self.scene.intersector;
        let (hit, h, _) = match self.query.filter {
            None => single_ray_on::<L, ANY>(l, tree, intersector, &r, NoCull, |_| true),
            Some(f) => {
                single_ray_on::<L, ANY>(l, tree, intersector, &r, NoCull, |h| f(&scene_hit(e, h)))
            }
        };
        if ANY {
            self.found = hit;
            return (!hit).then_some(bound);
        }
        if h.is_hit() {
            let candidate = scene_hit(e, &h);
            if self.best.is_beaten_by(&candidate) {
                self.best = candidate;
            }
        }
        Some(self.best.t.min(self.ray.tmax))
    }
}

/// The walk's leaves on the lanes `L` of the instances' trees.
struct OnLanes<'r, 'a, L, const ANY: bool> {
    l: L,
    ray: &'r mut SceneRay<'a, ANY>,
}

impl<L: Lanes, const ANY: bool> WideLeaves for OnLanes<'_, '_, L, ANY> {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, _: f32, _: f32) -> Option<f32> {
        let s = &mut *self.ray;
        let (c, ray) = (s.c, s.ray);
        let mut bound = if ANY {
            ray.tmax
        } else {
            s.best.t.min(ray.tmax)
        };
        let node = &c.top.nodes[leaf as usize];
        for &i in &c.top.items[node.first as usize..(node.first + node.count) as usize] {
            let e = &c.entries[i as usize];
            if e.mask & s.query.mask == 0
                || node.count > 1
                    && slab::ray_box(ray.origin, s.inv, ray.tmin, bound, &c.boxes[i as usize])
                        .is_none()
            {
                continue;
            }
            bound = s.entry(self.l, e, bound)?;
        }
        Some(bound)
    }
}

impl<const ANY: bool> LaneTask for SceneRay<'_, ANY> {
    type Output = Self;

    #[inline(always)]
    fn run<L: Lanes>(mut self, l: L) -> Self {
        let nodes = &self.c.top.wide;
        let ray = self.ray;
        wide::walk(l.up_to_8(), nodes, ray, &mut OnLanes { l, ray: &mut self });
        self
    }
}
