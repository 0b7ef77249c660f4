//! Packets of a scene: a packet walks the top level as a whole and enters each instance as one
//! packet carried to the mesh's space, so the beam and the packet kernels work in the
//! instance's kd-tree as in a lone mesh.

use kdbeam_kernels::{
    slab, Aabb, HitPacket, LaneMask, LaneTask, Lanes, RayPacket, MAX_PACKET_RAYS,
};

use super::commit::{Committed, Entry};
use super::top_level::MAX_DEPTH;
use super::trace::{object_ray, scene_hit};
use super::{Query, Scene, SceneHit};
use crate::trace::{is_traceable, Tracer};
use crate::{Error, Result};

impl Scene {
    /// The closest hits of the rays of `packet` whose bit is set in `active`, into `hits[i]`
    /// for ray `i` (the other entries untouched): each [`Scene::intersect_with`] of that ray,
    /// bit for bit.
    ///
    /// The top-level BVH is walked by the packet as a whole, a vector of rays per box test (a
    /// node is entered by the rays whose `[tmin, closest hit so far]` meets its box); each
    /// instance is entered once by the packet of those rays, carried to its mesh's space, and
    /// traced by [`Tracer::intersect_packet`] with the scene's intersector and the default
    /// culling, each ray bounded by its closest hit so far. With `query.filter` set, the rays
    /// are traced one by one (the packet kernels take no filter). Rays that cannot be traced,
    /// and every ray of a scene never committed, get [`SceneHit::NONE`].
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
        for i in bits(active) {
            hits[i] = SceneHit::NONE;
        }
        let Some(c) = &self.committed else {
            return Ok(());
        };
        if query.filter.is_some() {
            for i in bits(active) {
                hits[i] = self.intersect_with(&packet.ray(i), query);
            }
            return Ok(());
        }
        let mut object = packet.clone();
        let mut found = HitPacket::default();
        self.walk_packet(c, packet, active, query.mask, |e, m, bound| {
            carry(e, packet, m, bound, &mut object);
            let tree = &c.blas[e.blas as usize].tree;
            Tracer::on(tree, self.dispatch)
                .with_intersector(self.intersector)
                .intersect_packet(&object, m, &mut found);
            for i in bits(m) {
                let h = found.hit(i);
                if h.is_hit() {
                    let candidate = scene_hit(e, &h);
                    if hits[i].is_beaten_by(&candidate) {
                        hits[i] = candidate;
                        bound[i] = candidate.t.min(packet.tmax[i]);
                    }
                }
            }
            0
        });
        Ok(())
    }

    /// The rays of `packet` set in `active` that hit something in `[tmin, tmax]`, as a mask:
    /// bit `i` is [`Scene::occluded_with`] of ray `i`.
    ///
    /// The packet walks the top level as [`Scene::intersect_packet`] does, enters each
    /// instance as one packet traced by [`Tracer::occluded_packet`], and a ray leaves the walk
    /// at its first hit. With `query.filter` set, the rays are traced one by one. Rays that
    /// cannot be traced, and every ray of a scene never committed, are not occluded.
    ///
    /// ```
    /// use kdbeam::scene::world::{Query, Scene};
    /// use kdbeam::{Mesh, Ray, RayPacket, Vec3};
    ///
    /// let mut scene = Scene::new();
    /// let triangle = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
    /// scene.add_mesh(Mesh::from_indexed(&triangle, &[0, 1, 2])?)?;
    /// scene.commit()?;
    /// let packet = RayPacket::from_rays(&[
    ///     Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z), // through the triangle
    ///     Ray::new(Vec3::new(2.0, 2.0, 0.0), Vec3::Z),   // beside it
    /// ]);
    /// assert_eq!(scene.occluded_packet(&packet, packet.full_mask(), &Query::default()), 0b01);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn occluded_packet(&self, packet: &RayPacket, active: u64, query: &Query<'_>) -> u64 {
        let active = active & packet.full_mask();
        let Some(c) = &self.committed else {
            return 0;
        };
        if query.filter.is_some() {
            return bits(active)
                .filter(|&i| self.occluded_with(&packet.ray(i), query))
                .fold(0, |m, i| m | 1 << i);
        }
        let mut object = packet.clone();
        let mut occluded = 0u64;
        self.walk_packet(c, packet, active, query.mask, |e, m, bound| {
            carry(e, packet, m, bound, &mut object);
            let tree = &c.blas[e.blas as usize].tree;
            let hit = Tracer::on(tree, self.dispatch)
                .with_intersector(self.intersector)
                .occluded_packet(&object, m);
            occluded |= hit;
            hit
        });
        occluded
    }

    /// Walks the top level with the traceable rays of `active`, calling `visit(entry, rays,
    /// bound)` for each entry whose mask meets `mask` and whose box some of the rays enter
    /// over `[tmin, bound]`; `visit` may lower `bound` (the closest hits so far) and returns
    /// the rays it has finished, which leave the walk.
    fn walk_packet(
        &self,
        c: &Committed,
        packet: &RayPacket,
        active: u64,
        mask: u32,
        visit: impl FnMut(&Entry, u64, &mut [f32; MAX_PACKET_RAYS]) -> u64,
    ) {
        let mut rays = TopRays {
            origin: packet.origin,
            inv: [[0.0; MAX_PACKET_RAYS]; 3],
            tmin: packet.tmin,
            bound: packet.tmax,
            len: packet.len(),
        };
        let mut live = 0u64;
        for i in bits(active) {
            let ray = packet.ray(i);
            let inv = ray.direction.recip();
            for axis in 0..3 {
                rays.inv[axis][i] = inv[axis];
            }
            if is_traceable(&ray) {
                live |= 1 << i;
            }
        }
        if live == 0 || c.top.nodes.is_empty() {
            return;
        }
        self.dispatch.run(PacketWalk {
            c,
            direction: &packet.direction,
            rays,
            live,
            mask,
            visit,
        });
    }
}

/// Sets the rays `m` of `object` to `packet`'s rays carried to `e`'s mesh space, each over
/// `[tmin, bound]`.
#[inline]
fn carry(
    e: &Entry,
    packet: &RayPacket,
    m: u64,
    bound: &[f32; MAX_PACKET_RAYS],
    object: &mut RayPacket,
) {
    for i in bits(m) {
        object.set(i, &object_ray(e, &packet.ray(i), bound[i]));
    }
}

/// The set bits of `m`, lowest first.
#[inline]
fn bits(mut m: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            i
        })
    })
}

/// A packet's rays as the top level tests them, in SoA: `bound` is each ray's closest hit so
/// far (its `tmax` without one).
struct TopRays {
    origin: [[f32; MAX_PACKET_RAYS]; 3],
    inv: [[f32; MAX_PACKET_RAYS]; 3],
    tmin: [f32; MAX_PACKET_RAYS],
    bound: [f32; MAX_PACKET_RAYS],
    len: usize,
}

impl TopRays {
    /// The rays of `mask` that enter `b` over `[tmin, bound]`, a vector of rays per test:
    /// ray `i` is in it exactly when [`slab::ray_box`] returns `Some` for it, as
    /// [`slab::slab_lanes`] promises, so the walk sees what each ray's own walk sees.
    #[inline(always)]
    fn enter<L: Lanes>(&self, l: L, b: &Aabb, mask: u64) -> u64 {
        let w = L::WIDTH;
        let lane_bits = if w >= 64 { u64::MAX } else { (1u64 << w) - 1 };
        let mut entered = 0u64;
        for first in (0..self.len).step_by(w) {
            let wanted = mask >> first & lane_bits;
            if wanted == 0 {
                continue;
            }
            let load3 = |a: &[[f32; MAX_PACKET_RAYS]; 3]| {
                [
                    l.load(&a[0][first..]),
                    l.load(&a[1][first..]),
                    l.load(&a[2][first..]),
                ]
            };
            let (hit, _, _) = slab::slab_lanes(
                l,
                &load3(&self.origin),
                &load3(&self.inv),
                l.load(&self.tmin[first..]),
                l.load(&self.bound[first..]),
                b,
            );
            entered |= (u64::from(hit.bits()) & wanted) << first;
        }
        entered
    }
}

/// The walk of [`Scene::walk_packet`] as a task generic over the lanes.
struct PacketWalk<'a, V> {
    c: &'a Committed,
    direction: &'a [[f32; MAX_PACKET_RAYS]; 3],
    rays: TopRays,
    live: u64,
    mask: u32,
    visit: V,
}

impl<V: FnMut(&Entry, u64, &mut [f32; MAX_PACKET_RAYS]) -> u64> LaneTask for PacketWalk<'_, V> {
    type Output = ();

    #[inline(always)]
    fn run<L: Lanes>(mut self, l: L) {
        let (c, mut live) = (self.c, self.live);
        let mut stack = [(0u32, 0u64); MAX_DEPTH + 2];
        stack[0] = (0, live);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (n, rays) = stack[top];
            let node = &c.top.nodes[n as usize];
            let rays = self.rays.enter(l, &node.bounds, rays & live);
            if rays == 0 {
                continue;
            }
            if node.count == 0 {
                // Nearer child first along the first ray's direction, so that closest hits
                // bound the rays before the farther child is tested.
                let (a, b) = (node.first, node.first + 1);
                let i = rays.trailing_zeros() as usize;
                let d = glam::Vec3::new(
                    self.direction[0][i],
                    self.direction[1][i],
                    self.direction[2][i],
                );
                let (ca, cb) = (
                    c.top.nodes[a as usize].bounds.center(),
                    c.top.nodes[b as usize].bounds.center(),
                );
                let (near, far) = if (cb - ca).dot(d) < 0.0 {
                    (b, a)
                } else {
                    (a, b)
                };
                stack[top] = (far, rays);
                stack[top + 1] = (near, rays);
                top += 2;
                continue;
            }
            let mut rays = rays;
            for &item in &c.top.items[node.first as usize..(node.first + node.count) as usize] {
                let e = &c.entries[item as usize];
                if e.mask & self.mask == 0 {
                    continue;
                }
                // A leaf of one item has that item's box: its rays are the node's.
                let m = if node.count == 1 {
                    rays
                } else {
                    self.rays.enter(l, &c.boxes[item as usize], rays)
                };
                if m == 0 {
                    continue;
                }
                let finished = (self.visit)(e, m, &mut self.rays.bound);
                live &= !finished;
                rays &= !finished;
                if live == 0 {
                    return;
                }
            }
        }
    }
}
