//! The SAH cost of a plane, and the search for the cheapest one among a node's candidates.

use glam::{Vec3A, Vec3Swizzles};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::split_planes::{cheapest_plane, AxisCell, AxisPlanes, CheapestPlane};
use kdbeam_kernels::{Aabb, LaneTask, Lanes};

use super::bins::Bins;
use super::exact::ExactPlanes;
use crate::kdtree::BuildParams;

/// The SAH costs in units of one traversal step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CostModel {
    /// `Ci / Ct`.
    ci_over_ct: f32,
    /// `1 − empty_bonus`: the factor λ on a split's intersection cost when one side is empty.
    empty_factor: f32,
}

/// The best plane of a node.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Split {
    /// 0, 1 or 2.
    pub axis: usize,
    /// The plane's position key ([`super::events::key`]).
    pub pos_key: u32,
    /// Do the triangles lying in the plane go to the below side?
    pub planar_below: bool,
    /// Its SAH cost.
    pub cost: f32,
    /// Triangles on the below side, the planar ones included when they go below. When it is
    /// 0, every triangle goes above, unclipped, with its events unchanged.
    pub below_count: u32,
    /// Triangles on the above side, likewise.
    pub above_count: u32,
}

impl CostModel {
    /// The cost model of valid `params`.
    pub fn new(params: &BuildParams) -> Self {
        CostModel {
            ci_over_ct: params.ci_over_ct,
            empty_factor: 1.0 - params.empty_bonus,
        }
    }

    /// The cost of not splitting a node of `n` triangles: `Ci/Ct · n`.
    #[inline]
    pub fn leaf_cost(&self, n: usize) -> f32 {
        self.ci_over_ct * n as f32
    }

    /// The cheapest plane in `cell` among a small node's [`ExactPlanes`]: every face of its
    /// boxes strictly inside the cell; `None` when there is none (a cell flat on every axis but
    /// at most one, or extents overflowing f32). Costed in the lanes of `dispatch`'s ISA, with the same
    /// plane, cost and counts on every ISA.
    ///
    /// The cost of a plane is Wald & Havran's eq. (2) with the empty bonus:
    /// `1 + Ci/Ct · (P_b·N_b + P_a·N_a) · λ`, where `P` are the children's surface areas over
    /// the node's and λ = `1 − empty_bonus` when one side holds no triangle, else 1. Each plane
    /// is evaluated with the triangles lying in it on either side. Only planes strictly inside
    /// the cell are offered, so an empty side is never a flat, zero-volume cell (which would
    /// earn the bonus for nothing, and could repeat forever).
    ///
    /// Ties: on an axis the lowest weight `λ · (P_b·N_b + P_a·N_a)` wins, then the lowest
    /// position; between axes the lowest cost, then the first axis. The triangles lying in the
    /// plane go below when both sides cost the same.
    #[inline]
    pub fn best_split(
        &self,
        dispatch: Dispatch,
        planes: &ExactPlanes,
        cell: &Aabb,
    ) -> Option<Split> {
        self.cheapest(dispatch, planes, cell, |axis, index, planar_below| {
            planes.split(axis, index, planar_below)
        })
    }

    /// The cheapest plane in `cell` among a binned node's candidates ([`Bins`]): per axis, the
    /// face of the triangles' union below them all (with `N_below = 0`), the [`BINS`] − 1 bin
    /// boundaries strictly between the union's faces, and the face above them all
    /// (`N_above = 0`); only planes strictly inside the cell are offered. `None` as for
    /// [`CostModel::best_split`]. Costed in the lanes of `dispatch`'s ISA by the exact search's kernel,
    /// with the same plane on every ISA.
    ///
    /// The cost is the same as the sweep's, with the bins' counts: exact at the union's faces
    /// (so that empty space is cut off exactly where the sweep would cut it), and at a boundary
    /// an estimate that may count a triangle touching the plane on the wrong side. Only the
    /// choice of plane is approximate: the split itself classifies and clips exactly. A boundary
    /// never sees an empty side (the union's faces lie in the first and last bins), so
    /// [`Split::below_count`] and [`Split::above_count`] are 0 only when exact.
    ///
    /// Ties as for [`CostModel::best_split`]. (A weight, not the cost `1 + Ci/Ct · weight`, picks
    /// the plane of an axis: two weights can round to one cost.) Triangles lying in a plane go
    /// below, except at the union's lower face (where they go above, so that the below side is
    /// empty).
    #[inline]
    pub fn best_binned_split(&self, dispatch: Dispatch, bins: &Bins, cell: &Aabb) -> Option<Split> {
        self.cheapest(dispatch, bins, cell, |axis, index, _| {
            bins.split(axis, index)
        })
    }

    /// The cheapest of `candidates` in `cell`, costed in the lanes of `dispatch`'s ISA, as a split:
    /// `split(axis, index, planar_below)` describes plane `index` of `axis`, and its cost
    /// `1 + Ci/Ct · weight` is filled in. Between axes the lowest cost wins, then the first.
    #[inline]
    fn cheapest<C: Candidates>(
        &self,
        dispatch: Dispatch,
        candidates: &C,
        cell: &Aabb,
        split: impl Fn(usize, usize, bool) -> Split,
    ) -> Option<Split> {
        let cells = AxisGeometry::of_cell(cell).map(|g| {
            g.map(|g| AxisCell {
                base: g.base,
                slope: g.slope,
                lo: g.lo,
                hi: g.hi,
                empty_factor: self.empty_factor,
            })
        });
        let found = dispatch.run(Cheapest { candidates, cells });
        let mut best: Option<Split> = None;
        for (axis, found) in found.into_iter().enumerate() {
            let Some(CheapestPlane {
                index,
                weight,
                planar_below,
            }) = found
            else {
                continue;
            };
            let cost = 1.0 + self.ci_over_ct * weight;
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    cost,
                    ..split(axis, index, planar_below)
                });
            }
        }
        best
    }
}

/// Candidate planes with their counts, per axis: [`ExactPlanes`] or [`Bins`].
pub(super) trait Candidates {
    /// The planes of `axis`, for the kernels.
    fn planes(&self, axis: usize) -> AxisPlanes<'_>;
}

/// The kernel calls of [`CostModel::best_split`] and [`CostModel::best_binned_split`]: the
/// cheapest plane of each axis with a cell span, in one ISA entry point.
struct Cheapest<'a, C> {
    candidates: &'a C,
    cells: [Option<AxisCell>; 3],
}

impl<C: Candidates> LaneTask for Cheapest<'_, C> {
    type Output = [Option<CheapestPlane>; 3];
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        // A loop, not `map`: a closure would not inherit the entry point's target features.
        let mut found = [None; 3];
        for (axis, (found, cell)) in found.iter_mut().zip(&self.cells).enumerate() {
            if let Some(cell) = cell {
                *found = cheapest_plane(l, &self.candidates.planes(axis), cell);
            }
        }
        found
    }
}

/// What the cost of a plane on one axis of a cell needs: with `a`, `b` the other two extents
/// and `w` this one's (all over the largest extent, so that huge coordinates cannot overflow
/// the products; the ratios are unchanged), SA(child) / SA(cell) =
/// `(ab + (a + b)·w_child) / (ab + (a + b)·w)`.
struct AxisGeometry {
    /// `ab / SA`: a child's area ratio at zero width.
    base: f32,
    /// `(a + b) / (scale · SA)`: its growth per unit of width.
    slope: f32,
    lo: f32,
    hi: f32,
}

impl AxisGeometry {
    /// The geometry of each axis of `cell`; `None` for an axis on which the cell is flat, and
    /// for all three when its extents are not finite and positive (no plane lies strictly
    /// inside). The three axes at once, in vector lanes: the same operations as one at a time.
    #[inline(always)]
    fn of_cell(cell: &Aabb) -> [Option<Self>; 3] {
        let extent = Vec3A::from(cell.max) - Vec3A::from(cell.min);
        let scale = extent.max_element();
        if !(scale > 0.0 && scale.is_finite()) {
            return [None, None, None];
        }
        let unit = extent / scale;
        // Per axis, the other two extents.
        let (a, b) = (unit.yzx(), unit.zxy());
        let inv_area = Vec3A::ONE / (a * b + (a + b) * unit);
        let base = a * b * inv_area;
        let slope = (a + b) * (1.0 / scale) * inv_area;
        // A loop, not `map`, whose closure stays out of line.
        let mut axes = [None, None, None];
        for (axis, g) in axes.iter_mut().enumerate() {
            if unit[axis] > 0.0 {
                *g = Some(AxisGeometry {
                    base: base[axis],
                    slope: slope[axis],
                    lo: cell.min[axis],
                    hi: cell.max[axis],
                });
            }
        }
        axes
    }
}
