//! A group of rays, one per lane, through the wide nodes ([`WideNodes`](crate::kdtree::WideNodes))
//! together: a vector of rays against one child box per test.
//!
//! Rays that start close together, such as the ambient-occlusion rays of neighbouring pixels,
//! cross the same wide nodes near the root and around their surface whatever their directions.
//! Walked one by one ([`super::wide::walk`]), each ray loads and tests those nodes again; here
//! a node is loaded once for the group, and each of its children's boxes is tested against
//! every ray of the group in one vector step, as Embree runs its `N`-wide nodes with `K`-ray
//! packets. The rays that enter a child go down into it together, each with its own interval;
//! for closest hits the children are taken nearest entry first by the smallest entry among
//! their rays. Once a node is entered by at most [`ALONE`] rays, each finishes that subtree by
//! itself ([`super::wide::traverse_from`]): a vector step for a few rays costs more than their
//! own walks. This is the hybrid of Benthin, Wald, Woop, Ernst & Mark, *Combining Single and
//! Packet-Ray Tracing for Arbitrary Ray Distributions on the Intel MIC Architecture*, IEEE
//! TVCG 2012, which Embree's hybrid traversal follows.
//!
//! Each ray enters a box over the interval its own walk computes for it: the same planes chosen
//! by the signs of its direction, the same fused distances ([`clip_planes_fused`]) and the same
//! widening (none for a ray from within the tree's reach, [`super::wide::walk`]), lane by lane,
//! up to its own closest hit so far. So every leaf its walk would need is entered, and as the
//! closest hit does not depend on the order of the leaves ([`super::wide`]), each ray finds
//! exactly the hit its own walk finds.

use arrayvec::ArrayVec;
use kdbeam_kernels::slab::clip_planes_fused;
use kdbeam_kernels::{LaneF32, LaneMask, Lanes, Ray, RayPacket};

use super::single::{visit_leaf, LeafVisitor, INTERVAL_EPS};
use super::wide::traverse_from;
use crate::kdtree::{KdTree, WideChild, WideNode, WIDE, WIDE_STACK};

/// Rays that walk on alone from a node that at most this many of the group enter.
pub(crate) const ALONE: u32 = 4;

/// The most lanes of any ISA.
const MAX_LANES: usize = 16;

/// The rays of lanes `lanes` of `packet`'s columns `base..base + L::WIDTH` (`single[i]` is ray
/// `base + i`), each traceable ([`super::single::is_traceable`]), through `tree` together;
/// `visitors[i]` visits the leaves of lane `i` and sees what that ray's own walk shows it, for
/// every lane `i` of `lanes`. With
/// `NEAREST_FIRST` (closest hits) the children a node's rays enter are taken nearest first;
/// without (any hit) in the node's order, which saves more than a nearer first hit would.
#[inline(always)]
pub(crate) fn traverse<L: Lanes, V: LeafVisitor, const NEAREST_FIRST: bool>(
    l: L,
    tree: &KdTree,
    (packet, base, single): (&RayPacket, usize, &[Ray]),
    lanes: u32,
    visitors: &mut [V],
) {
    let traced = u64::from(lanes);
    debug_assert!(L::WIDTH <= MAX_LANES && traced >> visitors.len().min(single.len()) == 0);
    let nodes = tree.wide_nodes().nodes();
    if nodes.is_empty() || lanes == 0 {
        return;
    }
    let rays = LaneRays::new(l, packet, base, lanes, tree.wide_nodes().reach());
    let tmax = l.load(&packet.tmax[base..]);
    let mut best = [f32::INFINITY; MAX_LANES];
    let mut limit = tmax;
    let mut alive = lanes;
    let mut stack = ArrayVec::<Pending<L>, WIDE_STACK>::new();
    let mut at: Pending<L> = Pending {
        child: WideChild::ROOT,
        near: rays.tmin,
        far: tmax,
        lanes,
    };
    loop {
        if at.lanes.count_ones() <= ALONE {
            let mut bits = at.lanes;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let start = (at.child, at.near.extract(i), at.far.extract(i));
                let v = &mut visitors[i];
                match traverse_from(l.up_to_8(), tree, &single[i], start, best[i], v) {
                    Some(t) => best[i] = t,
                    None => alive &= !(1 << i),
                }
            }
            limit = tmax.min(l.load(&best));
        } else if at.child.is_node() {
            let node = &nodes[at.child.index() as usize];
            let valid = l.mask_from_bits(at.lanes);
            // The entered children go straight onto the stack, then, for closest hits, are
            // ordered there by their rays' smallest entry, nearest on top.
            let first = stack.len();
            let mut keys = [0f32; WIDE];
            let mut entered = 0;
            for k in 0..WIDE {
                if node.children[k] == WideChild::NONE {
                    break;
                }
                let (near, far) = rays.clip(l, node, k, limit);
                let hit = near.le(far) & valid;
                if hit.any() {
                    if NEAREST_FIRST {
                        let entries = L::F32::select(hit, near, l.splat(f32::INFINITY));
                        keys[entered] = entries.reduce_min();
                    }
                    stack.push(Pending {
                        child: node.children[k],
                        near,
                        far,
                        lanes: hit.bits(),
                    });
                    entered += 1;
                }
            }
            if entered != 0 {
                let children = &mut stack[first..];
                for i in (1..entered).filter(|_| NEAREST_FIRST) {
                    let mut j = i;
                    while j > 0 && keys[j - 1] < keys[j] {
                        keys.swap(j - 1, j);
                        children.swap(j - 1, j);
                        j -= 1;
                    }
                }
                at = stack.pop().expect("an entered child");
                continue;
            }
        } else {
            let mut bits = at.lanes;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (near, far) = (at.near.extract(i), at.far.extract(i));
                match visit_leaf(tree, at.child.index(), near, far, &mut visitors[i]) {
                    Some(t) => best[i] = t,
                    None => alive &= !(1 << i),
                }
            }
            limit = tmax.min(l.load(&best));
        }
        loop {
            let Some(next) = stack.pop() else { return };
            let lanes = next.lanes & alive & next.near.le(l.load(&best)).bits();
            if lanes != 0 {
                at = Pending { lanes, ..next };
                break;
            }
        }
    }
}

/// A child to visit, the rays that enter it and each one's interval in its box.
#[derive(Clone, Copy)]
struct Pending<L: Lanes> {
    child: WideChild,
    near: L::F32,
    far: L::F32,
    lanes: u32,
}

/// What every box test of the group reads: per lane, what [`super::wide`]'s walker keeps for
/// its one ray.
struct LaneRays<L: Lanes> {
    /// `−o·inv` per axis, NaN where the product overflows ([`fused_offsets`]).
    ///
    /// [`fused_offsets`]: kdbeam_kernels::slab::fused_offsets
    offset: [L::F32; 3],
    inv_direction: [L::F32; 3],
    /// Lanes whose reciprocal is negative (`−0` included): they enter by the `max` planes.
    backwards: [L::Mask; 3],
    /// The largest finite `|o·inv|` of each ray.
    err: L::F32,
    /// Every ray has `tmin >= 0`: entries are then at least 0, and their widening one `mul_add`.
    nonnegative: bool,
    /// Lanes with `tmin >= 0` whose origin lies within the tree's reach: their own walks take
    /// a box's interval as computed ([`super::wide::walk`]).
    within: L::Mask,
    /// Every traced lane is `within`.
    all_within: bool,
    tmin: L::F32,
}

impl<L: Lanes> LaneRays<L> {
    #[inline(always)]
    fn new(l: L, p: &RayPacket, base: usize, lanes: u32, reach: f32) -> Self {
        let (zero, inf) = (l.splat(0.0), l.splat(f32::INFINITY));
        let finite = |x: L::F32| x.abs().lt(inf);
        let mut offset = [zero; 3];
        let mut inv_direction = [zero; 3];
        let mut backwards = [zero.lt(zero); 3];
        let mut err = zero;
        let tmin = l.load(&p.tmin[base..]);
        let mut within = tmin.ge(zero);
        for k in 0..3 {
            let inv = l.splat(1.0) / l.load(&p.direction[k][base..]);
            let origin = l.load(&p.origin[k][base..]);
            within = within & origin.abs().le(l.splat(reach));
            let product = origin * inv;
            let kept = finite(product) | !finite(inv);
            offset[k] = L::F32::select(kept, -product, l.splat(f32::NAN));
            let size = offset[k].abs();
            err = err.max(L::F32::select(finite(size), size, zero));
            inv_direction[k] = inv;
            backwards[k] = inv.lt(zero);
        }
        LaneRays {
            offset,
            inv_direction,
            backwards,
            err,
            nonnegative: tmin.ge(zero).bits() & lanes == lanes,
            within,
            all_within: within.bits() & lanes == lanes,
            tmin,
        }
    }

    /// Each ray's interval in child `k`'s box of `node` over `[tmin, tmax]`, as its own walk
    /// computes it.
    #[inline(always)]
    fn clip(&self, l: L, node: &WideNode, k: usize, tmax: L::F32) -> (L::F32, L::F32) {
        let (mut enter, mut exit) = ([self.tmin; 3], [self.tmin; 3]);
        for a in 0..3 {
            let (lo, hi) = (l.splat(node.planes[a][k]), l.splat(node.planes[3 + a][k]));
            enter[a] = L::F32::select(self.backwards[a], hi, lo);
            exit[a] = L::F32::select(self.backwards[a], lo, hi);
        }
        let (n, f) = clip_planes_fused(
            &self.offset,
            &self.inv_direction,
            enter,
            exit,
            self.tmin,
            tmax,
        );
        if self.all_within {
            return (n, f);
        }
        let eps = l.splat(INTERVAL_EPS);
        let (wn, wf) = if self.nonnegative {
            (
                n.mul_add(l.splat(1.0 - INTERVAL_EPS), -self.err * eps),
                f.mul_add(
                    l.splat(1.0 + INTERVAL_EPS),
                    self.err * eps * l.splat(1.0 + 8.0 * INTERVAL_EPS),
                ),
            )
        } else {
            (
                n - (n.abs() + self.err) * eps,
                f + (f.abs() + self.err) * eps,
            )
        };
        (
            L::F32::select(self.within, n, wn),
            L::F32::select(self.within, f, wf),
        )
    }
}

#[cfg(test)]
mod tests {
    use kdbeam_kernels::{Hit, HitPacket, Isa, Ray, RayPacket, Vec3};

    use crate::scene::{procedural, rng::Rng};
    use crate::trace::culling::PacketTrace;
    use crate::trace::PacketCounters;
    use crate::{BuildParams, Culling, Intersector, KdTree, Tracer};

    /// Packets of 64 rays that start close together and point all over the sphere, with
    /// adversarial lanes: zero direction components, origins on the scene box's planes,
    /// segments of every length, and rays that cannot be traced.
    fn packets(bounds: &kdbeam_kernels::Aabb, count: usize, seed: u64) -> Vec<RayPacket> {
        let mut rng = Rng::new(seed);
        let e = bounds.extent();
        (0..count)
            .map(|_| {
                let c = Vec3::new(
                    rng.range(bounds.min.x, bounds.max.x),
                    rng.range(bounds.min.y, bounds.max.y),
                    rng.range(bounds.min.z, bounds.max.z),
                );
                let rays: Vec<Ray> = (0..64)
                    .map(|i| {
                        let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                        let mut o = c + (jitter - 0.5) * e * 0.01;
                        let mut d = rng.unit_vector();
                        match i % 11 {
                            1 => d.x = 0.0,
                            2 => (d.y, d.z) = (0.0, -0.0),
                            3 => o.x = bounds.min.x,
                            4 => d = Vec3::ZERO,
                            5 => o.y = f32::NAN,
                            _ => {}
                        }
                        let tmax = match i % 3 {
                            0 => f32::INFINITY,
                            1 => 0.1 * e.length(),
                            _ => rng.next_f32() * e.length(),
                        };
                        Ray {
                            origin: o,
                            direction: d,
                            tmin: 0.0,
                            tmax,
                        }
                    })
                    .collect();
                RayPacket::from_rays(&rays)
            })
            .collect()
    }

    /// Rays traced side by side find exactly the scalar reference's hits, bit for bit, on
    /// every ISA, for closest and any hit: each ray enters every box its own
    /// walk enters (the module's argument), and its leaves' tests are the single-ray tests.
    #[test]
    fn rays_side_by_side_find_the_scalar_hits_on_every_isa() {
        let mesh = procedural::builtin("default").expect("built-in scene");
        let bounds = mesh.bounds();
        for ci in [0.05, 1.0] {
            let tree = KdTree::build(&mesh, &BuildParams::default().with_ci_over_ct(ci)).unwrap();
            for intersector in Intersector::ALL {
                let scalar = Tracer::new(&tree)
                    .with_isa(Isa::Scalar)
                    .unwrap()
                    .with_intersector(intersector);
                for (k, p) in packets(&bounds, 40, u64::from(ci.to_bits()))
                    .iter()
                    .enumerate()
                {
                    let trace = Culling::AUTO.for_packet(p, p.full_mask(), &tree.bounds());
                    assert!(
                        matches!(trace, PacketTrace::Measured { together: true, .. }),
                        "packet {k}: {trace:?}"
                    );
                    // Ray by ray, whatever this thread has measured.
                    let trace = PacketTrace::RayByRay { together: true };
                    let want: Vec<_> = (0..p.len()).map(|j| scalar.intersect(&p.ray(j))).collect();
                    for isa in Isa::available() {
                        let tracer = scalar.with_isa(isa).unwrap();
                        let mut hits = HitPacket::default();
                        // One inactive lane, which must stay a miss.
                        let active = p.full_mask() & !(1 << 17);
                        let mut counters = PacketCounters::default();
                        tracer.intersect_packet_as(trace, p, active, &mut hits, &mut counters);
                        let occluded = tracer.occluded_packet_as(trace, p, active, &mut counters);
                        for (j, w) in want.iter().enumerate() {
                            let w = if active >> j & 1 != 0 { *w } else { Hit::NONE };
                            let got = hits.hit(j);
                            let bits =
                                |h: &Hit| (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits());
                            assert_eq!(
                                bits(&got),
                                bits(&w),
                                "{isa} {intersector:?} packet {k} ray {j}: {got:?}, scalar {w:?}"
                            );
                            assert_eq!(
                                occluded >> j & 1 != 0,
                                w.is_hit(),
                                "{isa} {intersector:?} packet {k} ray {j}"
                            );
                        }
                    }
                }
            }
        }
    }
}
