//! The ray–triangle tests of a group of lanes: Kensler–Shirley and watertight, behind one trait.

use kdbeam_kernels::intersect::kensler_shirley::{self, KsBlock};
use kdbeam_kernels::intersect::watertight::WatertightLanes;
use kdbeam_kernels::intersect::{LaneHits, LaneRays};
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{LaneF32, Lanes};

use crate::kdtree::LeafTriangles;

/// One packet ray–triangle test, per ISA.
pub(crate) trait LaneTest<L: Lanes> {
    /// Per-group work done once per leaf (the watertight shear).
    type Prepared;
    /// Per-block work done once per leaf visit (Kensler–Shirley's edges and normal).
    type Block;
    /// Prepares group `rays`.
    fn prepare(l: L, rays: &LaneRays<L>) -> Self::Prepared;
    /// Prepares the block of `leaf` that holds triangle `first`.
    fn prepare_block(l: L, leaf: &LeafTriangles<'_>, first: usize) -> Self::Block;
    /// Tests triangle `i` of `leaf = (triangles, block)` against the group, hits in `t_range =
    /// (tmin, tmax)`; `block` is [`LaneTest::prepare_block`] of the block holding `i`.
    /// `inside`: the beam proved every ray crosses the triangle, so its barycentric checks may
    /// be skipped.
    fn test(
        l: L,
        prepared: &Self::Prepared,
        rays: &LaneRays<L>,
        leaf: (&LeafTriangles<'_>, &Self::Block),
        i: usize,
        t_range: (L::F32, L::F32),
        inside: bool,
    ) -> LaneHits<L>;
}

/// A ray–triangle test at every lane width: the [`LaneTest`] for each `Lanes`, so that a task
/// can name its test before the ISA is chosen.
pub(crate) trait LaneTestFamily {
    /// The test on lanes `L`.
    type For<L: Lanes>: LaneTest<L>;
}

impl LaneTestFamily for KsLanes {
    type For<L: Lanes> = KsLanes;
}

impl LaneTestFamily for WatertightLaneTest {
    type For<L: Lanes> = WatertightLaneTest;
}

/// Kensler–Shirley on packets.
pub(crate) struct KsLanes;

impl<L: Lanes> LaneTest<L> for KsLanes {
    type Prepared = ();
    type Block = KsBlock;
    #[inline(always)]
    fn prepare(_: L, _: &LaneRays<L>) {}
    #[inline(always)]
    fn prepare_block(l: L, leaf: &LeafTriangles<'_>, first: usize) -> KsBlock {
        KsBlock::new(l, &leaf.blocks[first / BLOCK])
    }
    #[inline(always)]
    fn test(
        l: L,
        _: &(),
        rays: &LaneRays<L>,
        (leaf, block): (&LeafTriangles<'_>, &KsBlock),
        i: usize,
        (tmin, tmax): (L::F32, L::F32),
        inside: bool,
    ) -> LaneHits<L> {
        let tri = block.triangle(&leaf.blocks[i / BLOCK], i % BLOCK);
        let h = kensler_shirley::intersect_lanes(l, rays, &tri, tmin, tmax);
        if inside {
            // Reshetov (after Dmitriev et al.): all four corner rays hit the triangle, so every
            // ray does; only the distance decides. The barycentrics the kernel computed are
            // the same; the margin of the corner test keeps them inside.
            LaneHits {
                mask: h.t.ge(tmin) & h.t.le(tmax),
                ..h
            }
        } else {
            h
        }
    }
}

/// Watertight on packets (the beam's "inside" shortcut is not taken: the watertight verdict
/// stays the edge functions' own).
pub(crate) struct WatertightLaneTest;

impl<L: Lanes> LaneTest<L> for WatertightLaneTest {
    type Prepared = WatertightLanes<L>;
    type Block = ();
    #[inline(always)]
    fn prepare(l: L, rays: &LaneRays<L>) -> WatertightLanes<L> {
        WatertightLanes::new(l, rays)
    }
    #[inline(always)]
    fn prepare_block(_: L, _: &LeafTriangles<'_>, _: usize) {}
    #[inline(always)]
    fn test(
        l: L,
        prepared: &WatertightLanes<L>,
        _: &LaneRays<L>,
        (leaf, _): (&LeafTriangles<'_>, &()),
        i: usize,
        (tmin, tmax): (L::F32, L::F32),
        _: bool,
    ) -> LaneHits<L> {
        prepared.intersect(l, &leaf.triangle(i), tmin, tmax)
    }
}
