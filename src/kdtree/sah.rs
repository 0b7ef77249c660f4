//! The surface area heuristic and the event sweep that finds a node's best plane
//! (Wald & Havran 2006, §3 and §4.2, Algorithm 4).

use kdbeam_kernels::Aabb;

use super::events::{kind, pos_key, unkey, Event};
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

    /// Wald & Havran eq. (2) with the empty bonus: `1 + Ci/Ct · (P_b·N_b + P_a·N_a) · λ`, where
    /// `P` are the children's surface areas over the node's and λ = `1 − empty_bonus` when one
    /// side holds no triangle (the sweep only offers planes strictly inside the cell, so an
    /// empty side is never a flat, zero-volume cell), else 1.
    #[inline(always)]
    fn split_cost(&self, p_below: f32, p_above: f32, n_below: u32, n_above: u32) -> f32 {
        let lambda = if n_below == 0 || n_above == 0 {
            self.empty_factor
        } else {
            1.0
        };
        1.0 + self.ci_over_ct * lambda * (p_below * n_below as f32 + p_above * n_above as f32)
    }

    /// The cheapest plane of a node of `n` triangles in `cell`, from its sorted per-axis event
    /// lists; `None` when no plane lies strictly inside the cell (a cell flat on every axis but
    /// at most one, or extents overflowing f32).
    ///
    /// The sweep (Algorithm 4): at each distinct position p, with p⁻, p|, p⁺ the numbers of
    /// end, planar and start events there, first `N_above −= p⁻ + p|`, evaluate the plane with
    /// the planar triangles on either side, then `N_below += p⁺ + p|`. Ties keep the first
    /// plane found (axes in order, positions ascending), and the below side for planar ones.
    pub fn best_split(&self, events: &[Vec<Event>; 3], n: usize, cell: &Aabb) -> Option<Split> {
        // Areas are computed from extents divided by the largest one, so that huge
        // coordinates cannot overflow the products; the ratios P are unchanged.
        let extent = cell.extent();
        let scale = extent.max_element();
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let unit = extent / scale;
        let inv_scale = 1.0 / scale;
        let n = n as u32;
        let mut best: Option<Split> = None;
        let mut best_cost = f32::INFINITY;
        for (axis, list) in events.iter().enumerate() {
            if unit[axis] <= 0.0 {
                continue;
            }
            // SA(child) / SA(cell) = (ab + (a + b)·w_child) / (ab + (a + b)·w).
            let (a, b) = (unit[(axis + 1) % 3], unit[(axis + 2) % 3]);
            let (ab, a_plus_b) = (a * b, a + b);
            let inv_area = 1.0 / (ab + a_plus_b * unit[axis]);
            let (lo, hi) = (cell.min[axis], cell.max[axis]);
            let (mut n_below, mut n_above) = (0u32, n);
            let mut i = 0;
            while i < list.len() {
                let here = pos_key(list[i]);
                let mut counts = [0u32; 3];
                while i < list.len() && pos_key(list[i]) == here {
                    counts[kind(list[i]) as usize] += 1;
                    i += 1;
                }
                let [ends, planars, starts] = counts;
                n_above -= ends + planars;
                let p = unkey(here);
                if p > lo && p < hi {
                    let p_below = (ab + a_plus_b * ((p - lo) * inv_scale)) * inv_area;
                    let p_above = (ab + a_plus_b * ((hi - p) * inv_scale)) * inv_area;
                    let below = self.split_cost(p_below, p_above, n_below + planars, n_above);
                    let above = self.split_cost(p_below, p_above, n_below, n_above + planars);
                    let (cost, planar_below) = if below <= above {
                        (below, true)
                    } else {
                        (above, false)
                    };
                    if cost < best_cost {
                        best_cost = cost;
                        best = Some(Split {
                            axis,
                            pos_key: here,
                            planar_below,
                            cost,
                        });
                    }
                }
                n_below += starts + planars;
            }
        }
        best
    }
}
