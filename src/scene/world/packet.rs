//! Packets of a scene: a packet enters each instance as one packet carried to the mesh's space,
//! so the beam and the packet kernels work in the instance's kd-tree as in a lone mesh.

use kdbeam_kernels::{slab, HitPacket, Ray, RayPacket};

use super::trace::{object_ray, scene_hit};
use super::{Query, Scene, SceneHit};
use crate::trace::{is_traceable, Tracer};
use crate::{Error, Result};

impl Scene {
    /// The closest hits of the rays of `packet` whose bit is set in `active`, into `hits[i]`
    /// for ray `i` (the other entries untouched): each [`Scene::intersect_with`] of that ray,
    /// bit for bit.
    ///
    /// The top-level BVH is walked by the packet as a whole (a node is entered by the rays
    /// whose `[tmin, closest hit so far]` meets its box); each instance is entered once by the
    /// packet of those rays, carried to its mesh's space, and traced by
    /// [`Tracer::intersect_packet`] with the scene's intersector and the default culling, each
    /// ray bounded by its closest hit so far. With `query.filter` set, the rays are traced
    /// one by one (the packet kernels take no filter). Rays that cannot be traced, and every
    /// ray of a scene never committed, get [`SceneHit::NONE`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `hits` is shorter than the packet.
    pub fn intersect_packet(
        &self,
        packet: &RayPacket,
        active: u64,
        query: &Query<'_>,
        hits: &mut [SceneHit],
    ) -> Result<()> {
        if hits.len() < packet.len() {
            return Err(Error::InvalidParameter {
                name: "packet hits",
                message: format!("{} hits for {} rays", hits.len(), packet.len()),
            });
        }
        let active = active & packet.full_mask();
        let lanes = || (0..packet.len()).filter(move |&i| active >> i & 1 != 0);
        for i in lanes() {
            hits[i] = SceneHit::NONE;
        }
        let Some(c) = &self.committed else {
            return Ok(());
        };
        if query.filter.is_some() {
            for i in lanes() {
                hits[i] = self.intersect_with(&packet.ray(i), query);
            }
            return Ok(());
        }
        let mut rays = [Ray::new(glam::Vec3::ZERO, glam::Vec3::Z); 64];
        let mut inv = [glam::Vec3::ZERO; 64];
        let mut live = 0u64;
        for i in lanes() {
            rays[i] = packet.ray(i);
            inv[i] = rays[i].direction.recip();
            if is_traceable(&rays[i]) {
                live |= 1 << i;
            }
        }
        let Some(root) = c.top.nodes.first() else {
            return Ok(());
        };
        // The rays of `mask` whose interval up to their closest hit so far meets `b`.
        let enter = |b: &kdbeam_kernels::Aabb, mask: u64, hits: &[SceneHit]| {
            let mut m = 0u64;
            let mut rest = mask;
            while rest != 0 {
                let i = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let bound = hits[i].t.min(rays[i].tmax);
                if slab::ray_box(rays[i].origin, inv[i], rays[i].tmin, bound, b).is_some() {
                    m |= 1 << i;
                }
            }
            m
        };
        let mut object = RayPacket::from_rays(&rays[..packet.len()]);
        let mut found = HitPacket::default();
        let mut stack = vec![(0u32, enter(&root.bounds, live, hits))];
        while let Some((n, mask)) = stack.pop() {
            let node = &c.top.nodes[n as usize];
            let mask = enter(&node.bounds, mask, hits);
            if mask == 0 {
                continue;
            }
            if node.count == 0 {
                stack.push((node.first + 1, mask));
                stack.push((node.first, mask));
                continue;
            }
            for &item in &c.top.items[node.first as usize..(node.first + node.count) as usize] {
                let e = &c.entries[item as usize];
                if e.mask & query.mask == 0 {
                    continue;
                }
                // A leaf of one item has that item's box: its rays are the node's.
                let m = if node.count == 1 {
                    mask
                } else {
                    enter(&c.boxes[item as usize], mask, hits)
                };
                if m == 0 {
                    continue;
                }
                let mut rest = m;
                while rest != 0 {
                    let i = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    object.set(i, &object_ray(e, &rays[i], hits[i].t.min(rays[i].tmax)));
                }
                let tree = &c.blas[e.blas as usize].tree;
                Tracer::on(tree, self.dispatch)
                    .with_intersector(self.intersector)
                    .intersect_packet(&object, m, &mut found);
                let mut rest = m;
                while rest != 0 {
                    let i = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    let h = found.hit(i);
                    if h.is_hit() {
                        let candidate = scene_hit(e, &h);
                        if hits[i].is_beaten_by(&candidate) {
                            hits[i] = candidate;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
