//! What packet traversals count: packets, node and leaf visits, tests, culled tests, hits.

/// Work done by packet traversals, summed by callers.
///
/// A handful of counters, so that a call that builds and returns one per packet
/// ([`Tracer::intersect_packet`](crate::Tracer::intersect_packet)) pays little for it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketCounters {
    /// Packets (after the split by octant) traced.
    pub packets: u64,
    /// Inner nodes entered by a packet: binary nodes, or the wide nodes of the whole-packet
    /// traversal where it steps through them.
    pub inner_visits: u64,
    /// Non-empty leaves entered by a packet.
    pub leaf_visits: u64,
    /// Ray–leaf visits: active rays summed over leaf visits.
    pub ray_leaf_visits: u64,
    /// Ray–triangle tests a packet would perform without culling (active rays × triangles).
    pub potential_tests: u64,
    /// Ray–triangle tests performed.
    pub tests: u64,
    /// Leaf visits where a beam was built.
    pub beams: u64,
    /// Tests culled by the side planes (counted with the `stats` feature).
    pub culled_planes: u64,
    /// Tests culled by the near and far planes (counted with the `stats` feature).
    pub culled_distance: u64,
    /// Tests culled by the aperture test (counted with the `stats` feature).
    pub culled_aperture: u64,
    /// Hits found (a ray's closest hit improving; counted with the `stats` feature).
    pub hits: u64,
    /// Leaf visits with a single active ray (counted with the `stats` feature).
    pub single_ray_visits: u64,
    /// TSC reference cycles by stage (timed with the `stats` feature).
    pub cycles: StageCycles,
}

/// TSC reference cycles (RDTSC) spent in the stages of packet traversals, timed with the
/// `stats` feature (zero without it). The stages nest: `traversal` holds `leaves`, which holds
/// `beams` and `culling`; inner nodes and the packet's setup are `traversal − leaves`, the
/// ray–triangle tests and hit updates `leaves − beams − culling`. Each reading costs a few
/// dozen cycles, counted in the stage it closes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageCycles {
    /// Whole packet traversals: setup, octant split, inner nodes and leaves.
    pub traversal: u64,
    /// Leaf visits: beams, culling, tests and hit updates.
    pub leaves: u64,
    /// Beam construction in the leaves.
    pub beams: u64,
    /// Culling of triangles by the beams.
    pub culling: u64,
}

impl StageCycles {
    fn add(&mut self, o: &StageCycles) {
        self.traversal += o.traversal;
        self.leaves += o.leaves;
        self.beams += o.beams;
        self.culling += o.culling;
    }
}

/// A reading of the time-stamp counter with the `stats` feature; nothing without it.
#[derive(Clone, Copy)]
pub(crate) struct Stamp(#[cfg(feature = "stats")] u64);

impl Stamp {
    /// Reads the counter (with `stats`).
    #[inline(always)]
    pub(crate) fn now() -> Stamp {
        Stamp(
            #[cfg(feature = "stats")]
            kdbeam_kernels::lanes::tsc().unwrap_or(0),
        )
    }

    /// Adds the cycles since `self` to `total` (with `stats`).
    #[inline(always)]
    pub(crate) fn add_to(self, total: &mut u64) {
        #[cfg(feature = "stats")]
        {
            *total += kdbeam_kernels::lanes::tsc()
                .unwrap_or(0)
                .saturating_sub(self.0);
        }
        let _ = total;
    }
}

impl PacketCounters {
    /// Adds `o` to `self`.
    pub fn add(&mut self, o: &PacketCounters) {
        self.packets += o.packets;
        self.inner_visits += o.inner_visits;
        self.leaf_visits += o.leaf_visits;
        self.ray_leaf_visits += o.ray_leaf_visits;
        self.potential_tests += o.potential_tests;
        self.tests += o.tests;
        self.beams += o.beams;
        self.culled_planes += o.culled_planes;
        self.culled_distance += o.culled_distance;
        self.culled_aperture += o.culled_aperture;
        self.hits += o.hits;
        self.single_ray_visits += o.single_ray_visits;
        self.cycles.add(&o.cycles);
    }

    /// Share of the potential ray–triangle tests that culling eliminated, in percent.
    #[must_use]
    pub fn eliminated_percent(&self) -> f64 {
        if self.potential_tests == 0 {
            return 0.0;
        }
        100.0 * (1.0 - self.tests as f64 / self.potential_tests as f64)
    }

    /// Share of leaf visits with a single active ray, in percent (with the `stats` feature).
    #[must_use]
    pub fn single_ray_visits_percent(&self) -> f64 {
        100.0 * self.single_ray_visits as f64 / self.leaf_visits.max(1) as f64
    }
}
