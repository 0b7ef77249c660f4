//! The measured choice between tracing a packet ray by ray and as a packet, for the packets
//! whose rays [`Frustum::Coherent`]'s rules cannot settle.
//!
//! A packet whose rays land far apart, or point every way, shares little work between its
//! rays: on most scenes each ray alone walks the tree faster than the packet does. Not on all:
//! the shadow rays of a room seen from inside (sponza's atrium) are occluded in the first leaf
//! they reach, and there the packet's shared descent is worth more than the separate walks
//! save. Which way is faster depends on where the rays end, which nothing about the rays says
//! before they are traced, so the tracer measures it: each thread keeps, per tree and per kind
//! of query (closest or any hit), a running cost in TSC cycles per ray for each way, takes the
//! cheaper one, and now and then takes the other once more, so that a camera
//! moving from one kind of view into another is followed. Both ways find the same hits (every
//! packet traversal they lead to is exact), so the choice changes the speed and the work
//! counters, never a result.
//!
//! [`Frustum::Coherent`]: super::Frustum::Coherent

use std::cell::RefCell;

use kdbeam_kernels::lanes::tsc;

use super::culling::PacketTrace;
use crate::kdtree::KdTree;

/// The share of the time the way measured slower may cost by being retried: it is retried
/// once every `(slower / faster − 1) / EXPLORE_COST` packets, [`EXPLORE_MIN`] to
/// [`EXPLORE_MAX`].
const EXPLORE_COST: f32 = 0.01;

/// The fewest packets between two retries of the way measured slower.
const EXPLORE_MIN: u32 = 16;

/// The most packets between two retries of the way measured slower: a change in the rays is
/// noticed within a few of these.
const EXPLORE_MAX: u32 = 1024;

/// The weight of a new packet in the running cost of the way taken.
const WEIGHT: f32 = 0.125;

/// The weight of a new retry in the running means of the pairs.
const PAIR_WEIGHT: f32 = 0.25;

/// A sample is cut to this multiple (or fraction) of the running cost it is compared with: a
/// packet the OS preempted, or one whose rays ran into a thousand triangles, must not decide
/// alone.
const OUTLIER: f32 = 4.0;

/// Kinds of query remembered per thread (a tree and closest or any hit each): a renderer's
/// few trees and two ray kinds.
const KINDS: usize = 8;

/// How a contested packet is traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Way {
    /// One ray at a time.
    RayByRay,
    /// Through the packet traversal.
    Packet,
}

/// What a thread has measured of the two ways for one kind of query.
///
/// Packets differ more from one part of an image to the next (rays that miss the scene, rays
/// that end in their first leaf, rays that cross it) than the two ways differ on one packet,
/// and the way measured slower is tried on few packets: two running costs, one fed every
/// packet and one every few hundred, would compare different parts of the image. So the way
/// taken keeps a running cost of its recent packets, and each retry of the other way is paired
/// with it: the running means of the two sides of those pairs say which way is cheaper, and
/// by how much. Means of costs, not of their ratios, so that the packets that take the time
/// weigh the most (a packet of background rays, cheap either way, may favour the way that
/// loses on the mesh).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Costs {
    /// TSC cycles per ray of the recent packets traced the cheaper way; NaN until measured.
    recent: f32,
    /// Running means over the retries of the cycles per ray ray by ray, then as a packet (one
    /// side the retry, the other the recent cost it was paired with); NaN until the packet
    /// way has been tried.
    paired: [f32; 2],
    /// Packets chosen for so far.
    packets: u32,
    /// The packet at which the other way is retried.
    retry_at: u32,
}

impl Costs {
    /// Nothing measured yet.
    pub(crate) const NEW: Costs = Costs {
        recent: f32::NAN,
        paired: [f32::NAN; 2],
        packets: 0,
        retry_at: EXPLORE_MIN,
    };

    /// The way measured cheaper: ray by ray until the packet way has been measured.
    fn cheaper(&self) -> Way {
        if self.paired[1] < self.paired[0] {
            Way::Packet
        } else {
            Way::RayByRay
        }
    }

    /// The way for the next packet: ray by ray, then as a packet, then the cheaper one, and
    /// now and then the other (the more often the closer their costs).
    pub(crate) fn choose(&mut self) -> Way {
        self.packets = self.packets.wrapping_add(1);
        if self.recent.is_nan() {
            return Way::RayByRay;
        }
        if self.paired[0].is_nan() {
            return Way::Packet;
        }
        if self.packets.wrapping_sub(self.retry_at) < u32::MAX / 2 {
            let [rays, packet] = self.paired;
            let ratio = rays.max(packet) / rays.min(packet);
            // Saturating float-to-int: an infinite ratio waits the longest.
            let wait = ((ratio - 1.0) / EXPLORE_COST) as u32;
            self.retry_at = self
                .packets
                .wrapping_add(wait.clamp(EXPLORE_MIN, EXPLORE_MAX));
            return match self.cheaper() {
                Way::Packet => Way::RayByRay,
                Way::RayByRay => Way::Packet,
            };
        }
        self.cheaper()
    }

    /// Adds a packet traced `way` at `cycles_per_ray` (finite, not negative).
    pub(crate) fn record(&mut self, way: Way, cycles_per_ray: f32) {
        // A cycle or more a ray: no ratio divides by zero.
        let x = cycles_per_ray.max(1.0);
        if self.recent.is_nan() {
            self.recent = x;
            return;
        }
        let cheaper = self.cheaper();
        let x = x.clamp(self.recent / OUTLIER, self.recent * OUTLIER);
        if way == cheaper && !self.paired[0].is_nan() {
            self.recent += WEIGHT * (x - self.recent);
            return;
        }
        // A retry of the other way, paired with the recent packets of the cheaper one.
        let pair = match way {
            Way::Packet => [self.recent, x],
            Way::RayByRay => [x, self.recent],
        };
        for (mean, sample) in self.paired.iter_mut().zip(pair) {
            *mean = if mean.is_nan() {
                sample
            } else {
                *mean + PAIR_WEIGHT * (sample - *mean)
            };
        }
        if self.cheaper() != cheaper {
            // The other way is now the cheaper: its recent cost, as the pairs put it.
            let [rays, packet] = self.paired;
            self.recent *= match cheaper {
                Way::RayByRay => packet / rays,
                Way::Packet => rays / packet,
            };
        }
    }
}

/// One kind of query: the tree's address, any hit or not.
type Key = (usize, bool);

thread_local! {
    /// This thread's costs, by kind of query; the oldest kind is forgotten first.
    static COSTS: RefCell<([(Key, Costs); KINDS], usize)> =
        const { RefCell::new(([((0, false), Costs::NEW); KINDS], 0)) };
}

/// A packet being traced the way [`resolve`] chose: where its cost goes, and its start.
pub(crate) struct Measurement {
    /// The kind's place in this thread's table, and the kind (another may have taken the
    /// place by the time the packet is done: a scene's instances trace other trees within).
    at: usize,
    key: Key,
    way: Way,
    rays: u32,
    start: u64,
}

impl Measurement {
    /// Records the packet's cost since [`resolve`].
    pub(crate) fn finish(self) {
        let Some(now) = tsc() else {
            return;
        };
        let cycles_per_ray = now.saturating_sub(self.start) as f32 / self.rays.max(1) as f32;
        COSTS.with(|costs| {
            let (key, c) = &mut costs.borrow_mut().0[self.at];
            if *key == self.key {
                c.record(self.way, cycles_per_ray);
            }
        });
    }
}

/// `trace` with a [`PacketTrace::Measured`] settled for a packet of `rays` rays of `tree`
/// (`any`: any-hit rays) on this thread, and the measurement to finish once the packet is
/// traced; other traces as they are. Without a cycle counter, the contested packets are
/// traced ray by ray.
pub(crate) fn resolve(
    trace: PacketTrace,
    tree: &KdTree,
    any: bool,
    rays: u32,
) -> (PacketTrace, Option<Measurement>) {
    let PacketTrace::Measured { together, packet } = trace else {
        return (trace, None);
    };
    let Some(start) = tsc() else {
        return (PacketTrace::RayByRay { together }, None);
    };
    let key = (std::ptr::from_ref(tree) as usize, any);
    let (at, way) = COSTS.with(|costs| {
        let (kinds, oldest) = &mut *costs.borrow_mut();
        let at = kinds
            .iter()
            .position(|(k, _)| *k == key)
            .unwrap_or_else(|| {
                let at = *oldest;
                kinds[at] = (key, Costs::NEW);
                *oldest = (at + 1) % KINDS;
                at
            });
        (at, kinds[at].1.choose())
    });
    let chosen = match way {
        Way::RayByRay => PacketTrace::RayByRay { together },
        Way::Packet => PacketTrace::Packet(packet),
    };
    let measurement = Measurement {
        at,
        key,
        way,
        rays,
        start,
    };
    (chosen, Some(measurement))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::Culling;

    #[test]
    fn both_ways_are_measured_first() {
        let mut c = Costs::NEW;
        assert_eq!(c.choose(), Way::RayByRay);
        c.record(Way::RayByRay, 100.0);
        assert_eq!(c.choose(), Way::Packet);
        c.record(Way::Packet, 50.0);
        assert_eq!(c.choose(), Way::Packet);
        // The packet's recent cost is the ray by ray one scaled by the ratio.
        assert!((c.recent - 50.0).abs() < 1e-3, "{c:?}");
    }

    #[test]
    fn the_cheaper_way_is_taken_and_the_other_tried_the_rarer_the_slower_it_is() {
        let retries = |rays: f32, packet: f32, n: u32| {
            let mut c = Costs::NEW;
            c.record(Way::RayByRay, rays);
            c.paired = [rays, packet];
            (0..n).filter(|_| c.choose() == Way::Packet).count()
        };
        // Three times slower: retried every 200 packets (1% of the time spent on it).
        assert_eq!(retries(100.0, 300.0, 2000), 10);
        // Close: every 16 packets.
        assert_eq!(retries(100.0, 101.0, 160), 10);
        // Twenty times slower: every 1024.
        assert_eq!(retries(1.0, 20.0, 4096), 4);
    }

    #[test]
    fn retries_are_compared_with_the_recent_packets() {
        let mut c = Costs::NEW;
        c.record(Way::RayByRay, 100.0);
        c.record(Way::Packet, 150.0);
        assert_eq!(c.cheaper(), Way::RayByRay);
        // The image moves on to rays that end early: both ways get cheaper, the packet way
        // more so. The packets taken ray by ray bring the recent cost down first ...
        for _ in 0..40 {
            c.record(Way::RayByRay, 40.0);
        }
        assert_eq!(c.cheaper(), Way::RayByRay);
        // ... so that retries at 30 take the packet way over within a few.
        let retries = (1..=8)
            .find(|_| {
                c.record(Way::Packet, 30.0);
                c.cheaper() == Way::Packet
            })
            .expect("the packet way taken over");
        assert!(retries >= 2, "one retry outweighed the first pair: {c:?}");
        assert!(
            (c.recent - 40.0 * c.paired[1] / c.paired[0]).abs() < 1.0,
            "{c:?}"
        );
    }

    #[test]
    fn one_outlier_does_not_flip_the_choice() {
        let mut c = Costs::NEW;
        c.record(Way::RayByRay, 100.0);
        c.record(Way::Packet, 50.0);
        // A preempted packet: a million cycles a ray, cut to four times the recent cost.
        c.record(Way::Packet, 1.0e6);
        assert_eq!(c.cheaper(), Way::Packet);
        assert!((c.recent - (50.0 + WEIGHT * 150.0)).abs() < 1e-3, "{c:?}");
        // A retry of the other way at next to nothing moves the ratio by a bounded step.
        c.record(Way::RayByRay, 1.0e-4);
        assert_eq!(c.cheaper(), Way::Packet, "{c:?}");
    }

    #[test]
    fn other_traces_pass_through_and_contested_ones_alternate_at_first() {
        let mesh = crate::Mesh::from_indexed(
            &[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
            &[0, 1, 2],
        )
        .unwrap();
        let tree = KdTree::build(&mesh, &crate::BuildParams::default()).unwrap();
        let fixed = PacketTrace::Packet(Culling::FULL);
        let (trace, measurement) = resolve(fixed, &tree, false, 8);
        assert_eq!(trace, fixed);
        assert!(measurement.is_none());
        if tsc().is_none() {
            eprintln!("skipped: no cycle counter on this target, contested packets go ray by ray");
            return;
        }
        let contested = PacketTrace::Measured {
            together: true,
            packet: Culling::NONE,
        };
        let mut ways = Vec::new();
        for _ in 0..2 {
            let (trace, measurement) = resolve(contested, &tree, true, 8);
            ways.push(trace);
            measurement.expect("a cycle counter").finish();
        }
        assert_eq!(
            ways,
            [
                PacketTrace::RayByRay { together: true },
                PacketTrace::Packet(Culling::NONE)
            ]
        );
    }
}
