//! Tracing rays through a kd-tree: single rays, packets and streams, on every ISA.
//!
//! [`Tracer`] is the entry point: it borrows a [`KdTree`] and holds the choice of intersector,
//! ISA and culling.

mod culling;
pub mod filtered;
pub mod leaf;
mod measured_choice;
mod packet;
mod raybox;
pub mod reference;
mod single;
mod stream;
mod subspace;
pub mod synthetic;
pub(crate) mod wide;
mod wide_lanes;

use std::marker::PhantomData;

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::Hit;
use kdbeam_kernels::{HitPacket, Isa, LaneTask, Lanes, PacketShape, Ray, RayPacket};

use culling::PacketTrace;
pub use culling::{Culling, Frustum, Planes, RayBoxes};
pub use packet::{PacketCounters, StageCycles};
pub use single::is_traceable;
pub use single::RayCounters;
use single::{KsTest, RayTest, WatertightTest};
pub(crate) use single::{NoCull, TriangleCull};
pub use subspace::Subspace;

use crate::kdtree::KdTree;
use crate::{Error, Result};

/// Which ray–triangle test runs in the leaves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Intersector {
    /// Kensler & Shirley (RT06): the fastest, and the baseline of every culling figure. Rays
    /// through an edge shared by two triangles may, rarely, miss both.
    #[default]
    KenslerShirley,
    /// Woop, Benthin & Wald (JCGT 2013): no ray passes between triangles that share an edge.
    Watertight,
}

impl Intersector {
    /// Both, baseline first.
    pub const ALL: [Intersector; 2] = [Intersector::KenslerShirley, Intersector::Watertight];

    /// `kensler_shirley` or `watertight`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Intersector::KenslerShirley => "kensler_shirley",
            Intersector::Watertight => "watertight",
        }
    }
}

impl std::str::FromStr for Intersector {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "ks" | "kensler_shirley" | "kensler-shirley" => Ok(Intersector::KenslerShirley),
            "wt" | "watertight" => Ok(Intersector::Watertight),
            _ => Err(Error::InvalidParameter {
                name: "intersector",
                message: format!("expected kensler_shirley or watertight, got {s:?}"),
            }),
        }
    }
}

/// Traces rays through a borrowed [`KdTree`].
///
/// ```
/// use kdbeam::{BuildParams, KdTree, Mesh, Ray, Tracer, Vec3};
/// let mesh = Mesh::from_indexed(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], &[0, 1, 2])?;
/// let tree = KdTree::build(&mesh, &BuildParams::default())?;
/// let tracer = Tracer::new(&tree);
/// let hit = tracer.intersect(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z));
/// assert_eq!((hit.triangle, hit.t), (0, 1.0));
/// # Ok::<(), kdbeam::Error>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Tracer<'t> {
    tree: &'t KdTree,
    intersector: Intersector,
    /// Resolved once, here: every packet runs on it without checking the CPU again.
    dispatch: Dispatch,
    packet: PacketShape,
    culling: Culling,
}

impl<'t> Tracer<'t> {
    /// A tracer with the default intersector on the widest ISA this CPU runs, or the one
    /// `KDBEAM_ISA` names when that is valid and available.
    #[must_use]
    pub fn new(tree: &'t KdTree) -> Self {
        Tracer::on(tree, Dispatch::preferred())
    }

    /// A tracer with the default intersector on an ISA already resolved: no look at the CPU
    /// or the environment, for callers that make a tracer per query (a scene's instances).
    ///
    /// ```
    /// use kdbeam::kernels::Dispatch;
    /// use kdbeam::{BuildParams, Isa, KdTree, Mesh, Ray, Tracer, Vec3};
    /// let mesh = Mesh::from_indexed(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], &[0, 1, 2])?;
    /// let tree = KdTree::build(&mesh, &BuildParams::default())?;
    /// let tracer = Tracer::on(&tree, Dispatch::SCALAR);
    /// assert_eq!(tracer.isa(), Isa::Scalar);
    /// assert_eq!(tracer.intersect(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z)).t, 1.0);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn on(tree: &'t KdTree, dispatch: Dispatch) -> Self {
        Tracer {
            tree,
            intersector: Intersector::default(),
            dispatch,
            packet: PacketShape::P8x8,
            culling: Culling::AUTO,
        }
    }

    /// The same tracer on `isa`.
    ///
    /// # Errors
    /// [`Error::IsaUnavailable`] when this CPU does not run it.
    pub fn with_isa(self, isa: Isa) -> Result<Self> {
        Ok(self.with_dispatch(Dispatch::new(isa)?))
    }

    /// The same tracer on an ISA already checked.
    #[must_use]
    pub fn with_dispatch(self, dispatch: Dispatch) -> Self {
        Tracer { dispatch, ..self }
    }

    /// The same tracer with another intersector.
    #[must_use]
    pub fn with_intersector(self, intersector: Intersector) -> Self {
        Tracer {
            intersector,
            ..self
        }
    }

    /// The same tracer, cutting streams into packets of `packet`.
    #[must_use]
    pub fn with_packet(self, packet: PacketShape) -> Self {
        Tracer { packet, ..self }
    }

    /// The same tracer with another culling setting: the beam stages cull packets, the
    /// [`raybox`](Culling::raybox) and [`subspace`](Culling::subspace) stages single rays.
    #[must_use]
    pub fn with_culling(self, culling: Culling) -> Self {
        Tracer { culling, ..self }
    }

    /// The culling setting.
    #[must_use]
    pub fn culling(&self) -> Culling {
        self.culling
    }

    /// The packet shape streams are cut into.
    #[must_use]
    pub fn packet(&self) -> PacketShape {
        self.packet
    }

    /// The tree.
    #[must_use]
    pub fn tree(&self) -> &'t KdTree {
        self.tree
    }

    /// The ISA packets run on.
    #[must_use]
    pub fn isa(&self) -> Isa {
        self.dispatch.isa()
    }

    /// The intersector.
    #[must_use]
    pub fn intersector(&self) -> Intersector {
        self.intersector
    }

    /// The closest hit of one ray: [`Hit::NONE`] for a miss or a ray that cannot be traced
    /// (non-finite or zero direction, NaN origin, `tmin > tmax`). Equal `t` goes to the
    /// smaller triangle id. The ray meets a leaf's triangles a vector of the ISA's width at a
    /// time; on [`Isa::Scalar`] one by one, the reference every other path is checked against,
    /// and every ISA returns its hit bit for bit.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Hit {
        self.intersect_counted(ray).0
    }

    /// [`Tracer::intersect`], with its traversal counters.
    #[must_use]
    pub fn intersect_counted(&self, ray: &Ray) -> (Hit, RayCounters) {
        let (_, hit, counters) = self.single::<false>(ray);
        (hit, counters)
    }

    /// Is anything hit in `[tmin, tmax]`? (Shadow rays.) `false` for a ray that cannot be traced.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_counted(ray).0
    }

    /// [`Tracer::occluded`], with its traversal counters.
    #[must_use]
    pub fn occluded_counted(&self, ray: &Ray) -> (bool, RayCounters) {
        let (occluded, _, counters) = self.single::<true>(ray);
        (occluded, counters)
    }

    /// One ray on this tracer's ISA: `ANY` for an any-hit query.
    #[inline]
    fn single<const ANY: bool>(&self, ray: &Ray) -> (bool, Hit, RayCounters) {
        self.single_filtered::<ANY>(ray, |_| true)
    }

    /// [`Tracer::single`] counting only hits `accept` accepts, with the culling's single-ray
    /// stages.
    #[inline]
    pub(crate) fn single_filtered<const ANY: bool>(
        &self,
        ray: &Ray,
        accept: impl FnMut(&Hit) -> bool,
    ) -> (bool, Hit, RayCounters) {
        let (dispatch, tree, intersector) = (self.dispatch, self.tree, self.intersector);
        let raybox = self.culling.runs_raybox_on_single_rays(dispatch.isa());
        match (self.culling.subspace, raybox) {
            (Some(s), false) => subspace::single_ray_culled::<ANY>(
                dispatch,
                tree,
                intersector,
                ray,
                s,
                NoCull,
                accept,
            ),
            (Some(s), true) => {
                let then = raybox::RayBoxCull::new(tree.triangle_boxes());
                subspace::single_ray_culled::<ANY>(
                    dispatch,
                    tree,
                    intersector,
                    ray,
                    s,
                    then,
                    accept,
                )
            }
            (None, true) => {
                let cull = raybox::RayBoxCull::new(tree.triangle_boxes());
                single_ray::<ANY>(dispatch, tree, intersector, ray, cull, accept)
            }
            (None, false) => single_ray::<ANY>(dispatch, tree, intersector, ray, NoCull, accept),
        }
    }

    /// Closest hits of the rays of `packet` whose bit is set in `active`, on this tracer's ISA.
    ///
    /// Rays of one packet may have any origins and directions: rays whose direction signs
    /// differ are traced as separate sub-packets, one per octant. Inactive rays and rays that
    /// cannot be traced get [`Hit::NONE`] and never change the other rays' results.
    ///
    /// Each ray's hit equals [`Tracer::intersect`] on the same ray, bit for bit (`t`, `u`, `v`,
    /// triangle id), on every ISA and with every culling setting but those whose packets may
    /// traverse the tree as a whole ([`Culling::may_traverse_whole_packets`]: [`Frustum::Packet`],
    /// and [`Frustum::Coherent`] of the default [`Culling::AUTO`] for coherent packets);
    /// `tests/packet_vs_scalar.rs` and `tests/culling_vs_none.rs` check this. The whole-packet
    /// traversal also tests triangles of leaves the ray's own traversal does not enter, and a
    /// ray's hit then differs exactly where
    /// such a test beats the per-ray hit — a smaller `t`, or an equal `t` with a smaller
    /// triangle id — with a hit the intersector reports for that triangle alone (a real hit,
    /// never a farther one; see [`Frustum::Packet`]).
    pub fn intersect_packet(
        &self,
        packet: &RayPacket,
        active: u64,
        hits: &mut HitPacket,
    ) -> PacketCounters {
        let mut counters = PacketCounters::default();
        self.intersect_packet_counted(packet, active, hits, &mut counters);
        counters
    }

    /// [`Tracer::intersect_packet`], adding its work to `counters`: for callers that trace
    /// many packets and sum their counters (no counters built and copied per packet).
    ///
    /// ```
    /// use kdbeam::{trace::PacketCounters, BuildParams, HitPacket, KdTree, Mesh, Ray, RayPacket, Tracer, Vec3};
    /// let mesh = Mesh::from_indexed(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], &[0, 1, 2])?;
    /// let tree = KdTree::build(&mesh, &BuildParams::default())?;
    /// let tracer = Tracer::new(&tree);
    /// let packet = RayPacket::from_rays(&[Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z); 8]);
    /// let (mut hits, mut counters) = (HitPacket::default(), PacketCounters::default());
    /// for _ in 0..2 {
    ///     tracer.intersect_packet_counted(&packet, packet.full_mask(), &mut hits, &mut counters);
    /// }
    /// let once = tracer.intersect_packet(&packet, packet.full_mask(), &mut hits);
    /// assert_eq!(counters.tests, 2 * once.tests);
    /// assert_eq!((hits.triangle[7], hits.t[7]), (0, 1.0));
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    pub fn intersect_packet_counted(
        &self,
        packet: &RayPacket,
        active: u64,
        hits: &mut HitPacket,
        counters: &mut PacketCounters,
    ) {
        let (trace, measurement) = self.packet_trace::<false>(packet, active);
        self.intersect_packet_as(trace, packet, active, hits, counters);
        if let Some(m) = measurement {
            m.finish();
        }
    }

    /// [`Tracer::intersect_packet_counted`] traced as `trace` says.
    fn intersect_packet_as(
        &self,
        trace: PacketTrace,
        packet: &RayPacket,
        active: u64,
        hits: &mut HitPacket,
        counters: &mut PacketCounters,
    ) {
        let culling = match trace {
            PacketTrace::Packet(culling) => culling,
            // A contested packet left unsettled goes ray by ray, as without a cycle counter.
            PacketTrace::Measured { together, .. } | PacketTrace::RayByRay { together } => {
                *hits = HitPacket::default();
                self.ray_by_ray::<false>(packet, active, together, counters, |i, (_, hit, c)| {
                    (hits.t[i], hits.u[i], hits.v[i]) = (hit.t, hit.u, hit.v);
                    hits.triangle[i] = hit.triangle;
                    hits.tests[i] = u32::try_from(c.tests).unwrap_or(u32::MAX);
                });
                return;
            }
        };
        let q = PacketCall {
            culling,
            packet,
            active,
        };
        match (self.intersector, q.culling.interval_traversal()) {
            (Intersector::KenslerShirley, false) => {
                self.closest_task::<packet::KsLanes, false>(q, hits, counters)
            }
            (Intersector::KenslerShirley, true) => {
                self.closest_task::<packet::KsLanes, true>(q, hits, counters)
            }
            (Intersector::Watertight, false) => {
                self.closest_task::<packet::WatertightLaneTest, false>(q, hits, counters)
            }
            (Intersector::Watertight, true) => {
                self.closest_task::<packet::WatertightLaneTest, true>(q, hits, counters)
            }
        }
    }

    /// How the rays `active` of `packet` are traced ([`Culling::for_packet`] in the tree's
    /// box, a contested packet settled by this thread's measurements for closest hits or, with
    /// `ANY`, any hit), and the measurement to finish when it has been.
    fn packet_trace<const ANY: bool>(
        &self,
        packet: &RayPacket,
        active: u64,
    ) -> (PacketTrace, Option<measured_choice::Measurement>) {
        let trace = self.culling.for_packet(packet, active, &self.tree.bounds());
        let rays = (active & packet.full_mask()).count_ones();
        measured_choice::resolve(trace, self.tree, ANY, rays)
    }

    /// The packet query of call `q` in this tracer's tree.
    fn query<'a>(
        &'a self,
        q: PacketCall<'a>,
        stack: &'a mut packet::Stack,
        counters: &'a mut PacketCounters,
    ) -> packet::Query<'a> {
        packet::Query {
            tree: self.tree,
            packet: q.packet,
            active: q.active,
            culling: q.culling,
            stack,
            counters,
        }
    }

    /// [`Tracer::intersect_packet_counted`] with the test `F` and the traversal `INTERVAL`:
    /// one ISA entry point per combination.
    fn closest_task<F: packet::LaneTestFamily, const INTERVAL: bool>(
        &self,
        q: PacketCall<'_>,
        hits: &mut HitPacket,
        counters: &mut PacketCounters,
    ) {
        packet::with_stack(|stack| {
            let task = ClosestPacket::<F, INTERVAL> {
                query: self.query(q, stack, counters),
                hits,
                test: PhantomData,
            };
            self.dispatch.run(task)
        });
    }

    /// The rays of `packet` whose bit is set in `active` that hit anything in `[tmin, tmax]`,
    /// as a bit mask: [`Tracer::occluded`] of each ray, except that where packets traverse the
    /// tree as a whole ([`Culling::may_traverse_whole_packets`]) a ray may also be reported
    /// occluded by a real hit that only the whole-packet traversal's extra tests find (see
    /// [`Tracer::intersect_packet`]).
    #[must_use]
    pub fn occluded_packet(&self, packet: &RayPacket, active: u64) -> u64 {
        self.occluded_packet_counted(packet, active, &mut PacketCounters::default())
    }

    /// [`Tracer::occluded_packet`], adding its work to `counters`.
    pub fn occluded_packet_counted(
        &self,
        packet: &RayPacket,
        active: u64,
        counters: &mut PacketCounters,
    ) -> u64 {
        let (trace, measurement) = self.packet_trace::<true>(packet, active);
        let occluded = self.occluded_packet_as(trace, packet, active, counters);
        if let Some(m) = measurement {
            m.finish();
        }
        occluded
    }

    /// [`Tracer::occluded_packet_counted`] traced as `trace` says.
    fn occluded_packet_as(
        &self,
        trace: PacketTrace,
        packet: &RayPacket,
        active: u64,
        counters: &mut PacketCounters,
    ) -> u64 {
        let culling = match trace {
            PacketTrace::Packet(culling) => culling,
            // A contested packet left unsettled goes ray by ray, as without a cycle counter.
            PacketTrace::Measured { together, .. } | PacketTrace::RayByRay { together } => {
                let mut occluded = 0;
                self.ray_by_ray::<true>(packet, active, together, counters, |i, (found, _, _)| {
                    occluded |= u64::from(found) << i;
                });
                return occluded;
            }
        };
        let q = PacketCall {
            culling,
            packet,
            active,
        };
        match (self.intersector, q.culling.interval_traversal()) {
            (Intersector::KenslerShirley, false) => {
                self.occluded_task::<packet::KsLanes, false>(q, counters)
            }
            (Intersector::KenslerShirley, true) => {
                self.occluded_task::<packet::KsLanes, true>(q, counters)
            }
            (Intersector::Watertight, false) => {
                self.occluded_task::<packet::WatertightLaneTest, false>(q, counters)
            }
            (Intersector::Watertight, true) => {
                self.occluded_task::<packet::WatertightLaneTest, true>(q, counters)
            }
        }
    }

    /// [`Tracer::occluded_packet_counted`] with the test `F` and the traversal `INTERVAL`.
    fn occluded_task<F: packet::LaneTestFamily, const INTERVAL: bool>(
        &self,
        q: PacketCall<'_>,
        counters: &mut PacketCounters,
    ) -> u64 {
        packet::with_stack(|stack| {
            let task = OccludedPacket::<F, INTERVAL> {
                query: self.query(q, stack, counters),
                test: PhantomData,
            };
            self.dispatch.run(task)
        })
    }
}

/// One ray through `tree` with `intersector` on `dispatch`'s ISA, `cull` dropping what it can,
/// counting only hits `accept` accepts: with `ANY`, whether there is one in `[tmin, tmax]` (the
/// hit then [`Hit::NONE`]); otherwise the closest, bit for bit the same on every ISA. The one
/// single-ray entry point of [`Tracer`], [`filtered`] and [`crate::scene::world::Scene`].
#[inline]
pub(crate) fn single_ray<const ANY: bool>(
    dispatch: Dispatch,
    tree: &KdTree,
    intersector: Intersector,
    ray: &Ray,
    cull: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (bool, Hit, RayCounters) {
    dispatch.run(SingleRayTask::<_, _, ANY> {
        tree,
        intersector,
        ray,
        cull,
        accept,
    })
}

/// [`single_ray`] on the lanes `l`, for a caller already running on them (a scene's walk over
/// its instances, one ISA resolved for the whole ray).
#[inline(always)]
pub(crate) fn single_ray_on<L: Lanes, const ANY: bool>(
    l: L,
    tree: &KdTree,
    intersector: Intersector,
    ray: &Ray,
    cull: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (bool, Hit, RayCounters) {
    match intersector {
        Intersector::KenslerShirley => {
            single_ray_with::<L, KsTest, ANY>(l, tree, ray, cull, accept)
        }
        Intersector::Watertight => {
            single_ray_with::<L, WatertightTest, ANY>(l, tree, ray, cull, accept)
        }
    }
}

/// [`single_ray_on`] with the test `T`, made for `ray`.
#[inline(always)]
fn single_ray_with<L: Lanes, T: RayTest, const ANY: bool>(
    l: L,
    tree: &KdTree,
    ray: &Ray,
    cull: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (bool, Hit, RayCounters) {
    single::SingleRay::<_, _, _, ANY> {
        tree,
        ray,
        test: T::for_ray(ray),
        cull,
        accept,
    }
    .run(l)
}

/// [`single_ray`] as a task generic over the lanes.
struct SingleRayTask<'a, C, A, const ANY: bool> {
    tree: &'a KdTree,
    intersector: Intersector,
    ray: &'a Ray,
    cull: C,
    accept: A,
}

impl<C: TriangleCull, A: FnMut(&Hit) -> bool, const ANY: bool> LaneTask
    for SingleRayTask<'_, C, A, ANY>
{
    type Output = (bool, Hit, RayCounters);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        single_ray_on::<L, ANY>(
            l,
            self.tree,
            self.intersector,
            self.ray,
            self.cull,
            self.accept,
        )
    }
}

impl Tracer<'_> {
    /// Traces every ray `i` of `packet` set in `active` as a single ray ([`Tracer::single`]),
    /// gives `record(i, result)`, and adds the work to `counters` as one packet of single
    /// rays. Unculled (the SIMD default), the rays go in one task: with `together`, a group
    /// of lanes' rays at a time walking side by side ([`single::lanes`]) where a group holds
    /// more than [`wide_lanes::ALONE`] of them, and the others two at a time
    /// ([`single::pair`]), their walks interleaved.
    #[inline]
    fn ray_by_ray<const ANY: bool>(
        &self,
        packet: &RayPacket,
        active: u64,
        together: bool,
        counters: &mut PacketCounters,
        mut record: impl FnMut(usize, (bool, Hit, RayCounters)),
    ) {
        counters.packets += 1;
        let mut add = |i: usize, result: (bool, Hit, RayCounters)| {
            let c = result.2;
            counters.leaf_visits += c.leaves;
            counters.ray_leaf_visits += c.leaves;
            counters.tests += c.tests;
            counters.potential_tests += c.tests + c.culled;
            record(i, result);
        };
        let active = active & packet.full_mask();
        let culled = self.culling.subspace.is_some()
            || self.culling.runs_raybox_on_single_rays(self.dispatch.isa());
        if culled {
            let mut lanes = active;
            while lanes != 0 {
                let i = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                add(i, self.single::<ANY>(&packet.ray(i)));
            }
            return;
        }
        let tree = self.tree;
        match self.intersector {
            Intersector::KenslerShirley => self.dispatch.run(RayPairs::<KsTest, _, ANY> {
                tree,
                packet,
                active,
                together,
                record: add,
                test: PhantomData,
            }),
            Intersector::Watertight => self.dispatch.run(RayPairs::<WatertightTest, _, ANY> {
                tree,
                packet,
                active,
                together,
                record: add,
                test: PhantomData,
            }),
        }
    }
}

/// The rays `active` of `packet` through `tree`, unculled, as a task generic over the lanes:
/// with `together` on SIMD lanes, the groups of lanes that hold more than [`wide_lanes::ALONE`]
/// of them walking side by side ([`single::lanes`]), and the rest two at a time
/// ([`single::pair`]); `record(i, result)` gets each ray's result.
struct RayPairs<'a, T, R, const ANY: bool> {
    tree: &'a KdTree,
    packet: &'a RayPacket,
    active: u64,
    together: bool,
    record: R,
    test: PhantomData<T>,
}

impl<T: RayTest, R: FnMut(usize, (bool, Hit, RayCounters)), const ANY: bool> LaneTask
    for RayPairs<'_, T, R, ANY>
{
    type Output = ();

    #[inline(always)]
    fn run<L: Lanes>(mut self, l: L) {
        let mut lanes = self.active;
        if L::WIDTH > 1 && self.together {
            let traceable = packet::traceable_mask(l, self.packet, lanes);
            let mut untraceable = lanes & !traceable;
            while untraceable != 0 {
                let i = untraceable.trailing_zeros() as usize;
                untraceable &= untraceable - 1;
                (self.record)(i, (false, Hit::NONE, RayCounters::default()));
            }
            lanes = 0;
            for base in (0..self.packet.len()).step_by(L::WIDTH) {
                let group = (traceable >> base) as u32 & ((1u64 << L::WIDTH) - 1) as u32;
                if group.count_ones() > wide_lanes::ALONE {
                    let record = &mut self.record;
                    single::lanes::<L, T, ANY>(l, self.tree, self.packet, base, group, |i, r| {
                        record(base + i, r)
                    });
                } else {
                    lanes |= u64::from(group) << base;
                }
            }
        }
        while lanes != 0 {
            let i = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let first = self.packet.ray(i);
            if lanes == 0 {
                let result =
                    single_ray_with::<L, T, ANY>(l, self.tree, &first, NoCull, |_: &Hit| true);
                (self.record)(i, result);
                return;
            }
            let j = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let second = self.packet.ray(j);
            let [a, b] = single::pair::<L, T, ANY>(l, self.tree, [&first, &second]);
            (self.record)(i, a);
            (self.record)(j, b);
        }
    }
}

/// One packet call: its rays, which of them to trace, and the culling they trace with (the
/// tracer's, its frustum resolved for these rays by [`Culling::for_packet`]).
#[derive(Clone, Copy)]
struct PacketCall<'a> {
    packet: &'a RayPacket,
    active: u64,
    culling: Culling,
}

/// [`Tracer::intersect_packet`] as a task generic over the lanes, with the test `F` and the
/// traversal `INTERVAL`.
struct ClosestPacket<'a, F, const INTERVAL: bool> {
    query: packet::Query<'a>,
    hits: &'a mut HitPacket,
    test: PhantomData<F>,
}

impl<F: packet::LaneTestFamily, const INTERVAL: bool> LaneTask for ClosestPacket<'_, F, INTERVAL> {
    type Output = ();

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        packet::closest::<L, F::For<L>, INTERVAL>(l, self.query, self.hits)
    }
}

/// [`Tracer::occluded_packet`] as a task generic over the lanes, with the test `F` and the
/// traversal `INTERVAL`.
struct OccludedPacket<'a, F, const INTERVAL: bool> {
    query: packet::Query<'a>,
    test: PhantomData<F>,
}

impl<F: packet::LaneTestFamily, const INTERVAL: bool> LaneTask for OccludedPacket<'_, F, INTERVAL> {
    type Output = u64;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> u64 {
        packet::occluded::<L, F::For<L>, INTERVAL>(l, self.query)
    }
}
