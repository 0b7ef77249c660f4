//! The surface area heuristic and the event sweep that finds a node's best plane
//! (Wald & Havran 2006, §3 and §4.2, Algorithm 4).

use kdbeam_kernels::Aabb;

use super::events::{key, kind, pos_key, unkey, Event, END, PLANAR, START};
use super::BuildParams;

/// The SAH costs in units of one traversal step.
#[derive(Clone, Copy, Debug)]
pub(super) struct CostModel {
    /// `Ci / Ct`.
    ci_over_ct: f32,
    /// `1 − empty_bonus`: the factor λ on a split's intersection cost when one side is empty.
    empty_factor: f32,
}

/// The best plane of a node.
#[derive(Clone, Copy, Debug)]
pub(super) struct Split {
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

    /// The cheapest plane of a node of `n` triangles in `cell`, from its sorted per-axis event
    /// lists; `None` when no plane lies strictly inside the cell (a cell flat on every axis but
    /// at most one, or extents overflowing f32).
    ///
    /// The cost of a plane is Wald & Havran's eq. (2) with the empty bonus:
    /// `1 + Ci/Ct · (P_b·N_b + P_a·N_a) · λ`, where `P` are the children's surface areas over
    /// the node's and λ = `1 − empty_bonus` when one side holds no triangle, else 1. Only planes
    /// strictly inside the cell are offered, so an empty side is never a flat, zero-volume cell
    /// (which would earn the bonus for nothing, and could repeat forever).
    ///
    /// Ties keep the first plane found (axes in order, positions ascending), and the below side
    /// for the triangles lying in the plane.
    pub fn best_split(&self, events: &[Vec<Event>; 3], n: usize, cell: &Aabb) -> Option<Split> {
        // Areas are computed from extents divided by the largest one, so that huge
        // coordinates cannot overflow the products; the ratios P are unchanged.
        let extent = cell.extent();
        let scale = extent.max_element();
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let unit = extent / scale;
        let mut best: Option<Split> = None;
        for (axis, list) in events.iter().enumerate() {
            if unit[axis] <= 0.0 {
                continue;
            }
            let (a, b) = (unit[(axis + 1) % 3], unit[(axis + 2) % 3]);
            let geometry = AxisGeometry {
                ab: a * b,
                a_plus_b: a + b,
                inv_area: 1.0 / (a * b + (a + b) * unit[axis]),
                inv_scale: 1.0 / scale,
                lo: cell.min[axis],
                hi: cell.max[axis],
            };
            if let Some(found) = self.sweep(list, n as u32, &geometry, axis) {
                if best.is_none_or(|b| found.cost < b.cost) {
                    best = Some(found);
                }
            }
        }
        best
    }

    /// One sweep over an axis's sorted events (Algorithm 4). At each distinct position p,
    /// with p⁻, p|, p⁺ the numbers of end, planar and start events there: `N_above −= p⁻ + p|`,
    /// evaluate the plane with the planar triangles on either side, then `N_below += p⁺ + p|`.
    /// Written as one pass with the plane evaluated where the position changes, and the counts
    /// updated without branches on the event kind.
    #[inline]
    fn sweep(&self, list: &[Event], n: u32, g: &AxisGeometry, axis: usize) -> Option<Split> {
        let (lo_key, hi_key) = (key(g.lo), key(g.hi));
        // P_below = base + slope·(p − lo), P_above = base + slope·(hi − p). Differences from
        // the cell's faces keep precision far from the origin.
        let base = g.ab * g.inv_area;
        let slope = g.a_plus_b * g.inv_scale * g.inv_area;
        let empty_factor = self.empty_factor;
        // λ · (P_b·N_b + P_a·N_a): the part of the cost that differs between planes. Counts
        // are converted to f32 (exact below 2^24; beyond, rounding only blurs near-ties).
        let weighted = |p_below: f32, p_above: f32, nb: f32, na: f32| {
            let lambda = if nb == 0.0 || na == 0.0 {
                empty_factor
            } else {
                1.0
            };
            lambda * (p_below * nb + p_above * na)
        };
        let (mut n_below, mut n_above) = (0u32, n);
        let (mut planars, mut joining_below) = (0u32, 0u32);
        let mut best_weighted = f32::INFINITY;
        let mut best = (0u32, true, 0u32, 0u32);
        for (i, &e) in list.iter().enumerate() {
            let k = kind(e);
            n_above -= u32::from(k != START);
            planars += u32::from(k == PLANAR);
            joining_below += u32::from(k != END);
            let here = pos_key(e);
            let next = list.get(i + 1).map_or(u32::MAX, |&e| pos_key(e));
            if next == here {
                continue;
            }
            // Keys order like positions, so this is lo < p < hi.
            if here > lo_key && here < hi_key {
                let p = unkey(here);
                let p_below = base + slope * (p - g.lo);
                let p_above = base + slope * (g.hi - p);
                let (nb, na) = (n_below as f32, n_above as f32);
                let (w, planar_below) = if planars == 0 {
                    (weighted(p_below, p_above, nb, na), true)
                } else {
                    let np = planars as f32;
                    let below = weighted(p_below, p_above, nb + np, na);
                    let above = weighted(p_below, p_above, nb, na + np);
                    if below <= above {
                        (below, true)
                    } else {
                        (above, false)
                    }
                };
                if w < best_weighted {
                    best_weighted = w;
                    let np = if planar_below {
                        (planars, 0)
                    } else {
                        (0, planars)
                    };
                    best = (here, planar_below, n_below + np.0, n_above + np.1);
                }
            }
            n_below += joining_below;
            joining_below = 0;
            planars = 0;
        }
        (best_weighted < f32::INFINITY).then_some(Split {
            axis,
            pos_key: best.0,
            planar_below: best.1,
            cost: 1.0 + self.ci_over_ct * best_weighted,
            below_count: best.2,
            above_count: best.3,
        })
    }
}

/// What the cost of a plane on one axis needs: with `a`, `b` the other two extents and `w`
/// this one's (all over the largest extent), SA(child) / SA(cell) =
/// `(ab + (a + b)·w_child) / (ab + (a + b)·w)`.
struct AxisGeometry {
    ab: f32,
    a_plus_b: f32,
    inv_area: f32,
    inv_scale: f32,
    lo: f32,
    hi: f32,
}
