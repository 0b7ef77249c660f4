//! The SAH split-plane search over a small set of boxes, in SIMD lanes: every candidate plane on
//! one axis is counted against every box, then costed, `WIDTH` planes at a time.
//!
//! This is the exact search of Wald & Havran ("On building fast kd-trees for ray tracing, and on
//! doing that in O(N log N)", RT06, §4.2) without its sort. Their sweep visits the sorted events
//! and counts, at each plane `p`, the boxes reaching below it, above it, and lying in it. For a
//! few dozen boxes it is cheaper to count those directly, `O(n²)` but branch-free: for each box
//! and each lane of planes, `lo < p`, `hi > p` and `lo = hi = p` are one comparison each. The
//! counts are the sweep's exactly:
//!
//! - `below(p) = #{lo < p}`: boxes that start before `p` (flat ones lying before it included);
//! - `above(p) = #{hi > p}`: boxes that end after `p`;
//! - `planar(p) = #{lo = hi = p}`: flat boxes lying in `p`, counted on neither side.
//!
//! The counts are kept in integer lanes ([`crate::LaneCount`]: one subtraction of the mask per
//! box and plane vector) and returned as `f32`: exact for the at most 2²⁴ boxes a caller may
//! pass, and already in the form the cost needs.

use crate::lanes::{LaneCount, LaneF32, LaneMask, Lanes, MAX_WIDTH};

/// A set of planes on one axis with their counts ([`count_planes`]), in lanes: entry `k` of each
/// slice belongs to plane `k`. All the slices have the same length, a multiple of the widest
/// `WIDTH` ([`MAX_WIDTH`]); unused entries hold a NaN position, which no cell
/// contains.
#[derive(Clone, Copy, Debug)]
pub struct AxisPlanes<'a> {
    /// Positions.
    pub pos: &'a [f32],
    /// Boxes reaching below each plane: `#{lo < p}`.
    pub below: &'a [f32],
    /// Boxes reaching above each plane: `#{hi > p}`.
    pub above: &'a [f32],
    /// Flat boxes lying in each plane: `#{lo = hi = p}`; `None` when no box is flat on this axis
    /// (every count 0), which spares the costing of the planar boxes on either side.
    pub planar: Option<&'a [f32]>,
}

/// How a cell's surface area splits at a plane on one axis, and the SAH weights; the caller
/// derives it from the cell (kdbeam's kd-tree build does, in `AxisGeometry`).
///
/// `P_below(p) = base + slope · (p − lo)` and `P_above(p) = base + slope · (hi − p)` are the
/// children's surface areas over the cell's.
#[derive(Clone, Copy, Debug)]
pub struct AxisCell {
    /// A child's area ratio at zero width.
    pub base: f32,
    /// Its growth per unit of width.
    pub slope: f32,
    /// The cell's lower face on this axis.
    pub lo: f32,
    /// The cell's upper face on this axis.
    pub hi: f32,
    /// `λ = 1 − empty_bonus`: the factor on a plane's weight when one side holds no box.
    pub empty_factor: f32,
}

/// The cheapest plane of an axis ([`cheapest_plane`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheapestPlane {
    /// Its index in the [`AxisPlanes`] (one of them, if its position is listed more than once).
    pub index: usize,
    /// Its weight `λ · (P_below · N_below + P_above · N_above)`.
    pub weight: f32,
    /// Do the boxes lying in it go below (else above)?
    pub planar_below: bool,
}

/// Counts boxes on each side of each plane `pos[k]` across one axis, with `spans` each box's
/// faces `(lo, hi)` on that axis: `below[k] = #{lo < p}`, `above[k] = #{hi > p}`, and
/// `planar[k] = #{lo = hi = p}` when `flat` (some box is flat on this axis), else 0.
///
/// `spans` is walked once per two vectors of planes: an iterator over the boxes in place (such
/// as `boxes.iter().map(|b| (b.min.x, b.max.x))`), cheap to clone.
///
/// Edge cases: a NaN position counts nothing (every comparison is false); `-0.0` and `+0.0` are
/// the same plane.
///
/// # Panics
/// If `below`, `above` or `planar` is shorter than `pos`, or the length of `pos` is not a
/// multiple of `L::WIDTH`.
#[inline(always)]
pub fn count_planes<L: Lanes>(
    l: L,
    spans: impl Iterator<Item = (f32, f32)> + Clone,
    flat: bool,
    pos: &[f32],
    below: &mut [f32],
    above: &mut [f32],
    planar: &mut [f32],
) {
    assert!(pos.len().is_multiple_of(L::WIDTH));
    assert!(below.len() >= pos.len() && above.len() >= pos.len() && planar.len() >= pos.len());
    // Two vectors of planes per pass over the boxes, so that each box is broadcast once for
    // both; then the odd one out.
    let pairs = pos.len() / (2 * L::WIDTH) * (2 * L::WIDTH);
    let mut lists = [below, above, planar];
    for k in (0..pairs).step_by(2 * L::WIDTH) {
        count_block::<L, 2>(
            l,
            spans.clone(),
            flat,
            &pos[k..],
            lists.each_mut().map(|list| &mut list[k..]),
        );
    }
    for k in (pairs..pos.len()).step_by(L::WIDTH) {
        count_block::<L, 1>(
            l,
            spans.clone(),
            flat,
            &pos[k..],
            lists.each_mut().map(|list| &mut list[k..]),
        );
    }
}

/// [`count_planes`] for the `V` plane vectors at the start of `pos`, written to the start of
/// `[below, above, planar]`.
#[inline(always)]
fn count_block<L: Lanes, const V: usize>(
    l: L,
    boxes: impl Iterator<Item = (f32, f32)>,
    flat: bool,
    pos: &[f32],
    lists: [&mut [f32]; 3],
) {
    // A loop, not `array::from_fn`, whose closure may stay out of line, without the ISA's
    // target features.
    let mut p = [l.splat(0.0); V];
    for (v, p) in p.iter_mut().enumerate() {
        *p = l.load(&pos[v * L::WIDTH..]);
    }
    let mut counts = [[l.zero_counts(); V]; 3];
    for (lo, hi) in boxes {
        let (lo, hi) = (l.splat(lo), l.splat(hi));
        for v in 0..V {
            counts[0][v] = counts[0][v].add_set(lo.lt(p[v]));
            counts[1][v] = counts[1][v].add_set(hi.gt(p[v]));
            if flat {
                counts[2][v] = counts[2][v].add_set(lo.eq(p[v]) & hi.eq(p[v]));
            }
        }
    }
    for (list, counts) in lists.into_iter().zip(counts) {
        for (v, count) in counts.into_iter().enumerate() {
            l.store(count.to_f32(), &mut list[v * L::WIDTH..]);
        }
    }
}

/// The cheapest of `planes` strictly inside the cell's span `(cell.lo, cell.hi)`; `None` when
/// none is.
///
/// A plane's weight is `λ · (P_below · N_below + P_above · N_above)`, with `λ =
/// cell.empty_factor` when a side is empty, else 1; the boxes lying in the plane are tried on
/// either side, below when both weigh the same. Each product and sum is rounded as written
/// (never fused), so every ISA returns the same plane and weight bit for bit, and so does a
/// scalar loop over the planes in any order.
///
/// Ties: the lowest weight, then the lowest position. Planes listed more than once (equal
/// positions, which have equal counts, hence equal weights and sides; `-0.0` and `+0.0` are one
/// position) are one plane: which of their indices is returned is left open, and may differ
/// between ISAs.
///
/// # Panics
/// If the slices of `planes` differ in length or are not a multiple of `L::WIDTH` long.
#[inline(always)]
pub fn cheapest_plane<L: Lanes>(
    l: L,
    planes: &AxisPlanes<'_>,
    cell: &AxisCell,
) -> Option<CheapestPlane> {
    let len = planes.pos.len();
    assert!(len.is_multiple_of(L::WIDTH));
    assert!(planes.below.len() == len && planes.above.len() == len);
    assert!(planes.planar.is_none_or(|planar| planar.len() == len));
    let (zero, one) = (l.splat(0.0), l.splat(1.0));
    let (base, slope) = (l.splat(cell.base), l.splat(cell.slope));
    let (lo, hi) = (l.splat(cell.lo), l.splat(cell.hi));
    let empty_factor = l.splat(cell.empty_factor);
    let weighted = |pb: L::F32, pa: L::F32, nb: L::F32, na: L::F32| {
        let lambda = L::F32::select(nb.eq(zero) | na.eq(zero), empty_factor, one);
        lambda * (pb * nb + pa * na)
    };
    let mut best_weight = l.splat(f32::INFINITY);
    let (mut best_pos, mut best_index, mut best_planar_below) = (zero, zero, zero);
    let mut index = [0.0f32; MAX_WIDTH];
    for (i, x) in index.iter_mut().enumerate().take(L::WIDTH) {
        *x = i as f32;
    }
    let (mut lane_index, step) = (l.load(&index), l.splat(L::WIDTH as f32));
    for k in (0..len).step_by(L::WIDTH) {
        let p = l.load(&planes.pos[k..]);
        let (nb, na) = (l.load(&planes.below[k..]), l.load(&planes.above[k..]));
        let (pb, pa) = (base + slope * (p - lo), base + slope * (hi - p));
        let (weight, planar_below) = match planes.planar {
            Some(planar) => {
                let np = l.load(&planar[k..]);
                let with_below = weighted(pb, pa, nb + np, na);
                let with_above = weighted(pb, pa, nb, na + np);
                let planar_below = with_below.le(with_above);
                let weight = L::F32::select(planar_below, with_below, with_above);
                (weight, planar_below)
            }
            // The same weight as with `np = 0` (`nb + 0 = nb` exactly), and "below".
            None => (weighted(pb, pa, nb, na), zero.eq(zero)),
        };
        let better = (p.gt(lo) & p.lt(hi))
            & (weight.lt(best_weight) | (weight.eq(best_weight) & p.lt(best_pos)));
        best_weight = L::F32::select(better, weight, best_weight);
        best_pos = L::F32::select(better, p, best_pos);
        best_index = L::F32::select(better, lane_index, best_index);
        best_planar_below = L::F32::select(better, one.masked(planar_below), best_planar_below);
        lane_index = lane_index + step;
    }
    // Across the lanes by the same rule: the lowest weight, then among its lanes the lowest
    // position, without a branch. Ties are common: a mesh's neighbouring boxes share faces,
    // listed once per box, so a branch to the tie rule would be taken often and mispredicted.
    let weight = best_weight.reduce_min();
    if weight == f32::INFINITY {
        return None;
    }
    let lightest = best_weight.eq(l.splat(weight));
    let inf = l.splat(f32::INFINITY);
    let pos = L::F32::select(lightest, best_pos, inf).reduce_min();
    let winner = lightest & best_pos.eq(l.splat(pos));
    let lane = winner.bits().trailing_zeros() as usize;
    let (index, planar_below) = (best_index.extract(lane), best_planar_below.extract(lane));
    Some(CheapestPlane {
        index: index as usize,
        weight,
        planar_below: planar_below != 0.0,
    })
}
