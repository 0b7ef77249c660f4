//! The binned search of large nodes: the boundaries of 32 bins per axis across the boxes'
//! union as candidate planes, with counts estimated at the boundaries.

use glam::Vec3A;
use kdbeam_kernels::lanes::{truncate_to_i32, MAX_WIDTH};
use kdbeam_kernels::split_planes::AxisPlanes;
use kdbeam_kernels::Aabb;

use super::cost::{Candidates, Split};
use crate::kdtree::events::key;
use crate::kdtree::refs::Ref;
#[cfg(doc)]
use kdbeam_kernels::split_planes::cheapest_plane;

/// Tables [`BinCounts::of`] counts in, in turn.
const TABLES: usize = 4;

/// Planes per axis of the binned search: [`BINS`] − 1 bin boundaries.
pub(crate) const BINS: usize = 32;
const _: () = assert!(BINS.is_power_of_two(), "bin_index masks with BINS − 1");

/// The index of a bin coordinate already clamped to `[0, BINS − 1]`: its integer part (the mask
/// lets the compiler drop the bounds checks).
#[inline(always)]
fn bin_index(t: i32) -> usize {
    (t as usize) & (BINS - 1)
}

/// Candidate planes per axis of the binned search: the union's lower face, the [`BINS`] − 1
/// bin boundaries and its upper face, padded to whole vectors of the widest lanes.
const BINNED_PLANES: usize = (BINS + 1).next_multiple_of(MAX_WIDTH);

/// A binned node's candidate planes with their counts, in the lanes [`cheapest_plane`] reads:
/// per axis, plane 0 is the lower face of its clipped boxes' union (none below, all above),
/// plane `j` in `1..BINS` the boundary between bins `j − 1` and `j` (the boxes starting in the
/// bins before it are counted below, those ending in the bins from `j` on above), and plane
/// [`BINS`] the union's upper face (all below, none above). Bin `j` of an axis covers
/// `[first + j·w/BINS, first + (j+1)·w/BINS)` of the union's span `[first, first + w]` (up to
/// f32 rounding, which only blurs the counts), the last bin closed. A boundary not strictly
/// between the faces, and the padding, have a NaN position, which no cell contains. Kept
/// across the empty-space cuts of a node, which change its cell, not its triangles.
pub(crate) struct Bins {
    pos: [[f32; BINNED_PLANES]; 3],
    below: [[f32; BINNED_PLANES]; 3],
    above: [[f32; BINNED_PLANES]; 3],
}

/// How many boxes start and end in each bin, per axis: [`Bins`] before its planes are placed.
///
/// Counts of disjoint runs of boxes add up ([`BinCounts::add`]) to those of the whole run, in
/// integers, so that binning a large node in parallel chunks gives the same bins as binning it
/// at once.
#[derive(Clone, Copy)]
pub(crate) struct BinCounts {
    starts: [[u32; BINS]; 3],
    ends: [[u32; BINS]; 3],
}

impl BinCounts {
    /// No boxes.
    pub const ZERO: BinCounts = BinCounts {
        starts: [[0; BINS]; 3],
        ends: [[0; BINS]; 3],
    };

    /// The counts of the boxes of `refs` in the bins across `union` (which holds them).
    ///
    /// Neighbouring references usually fall in the same bins (a node's references keep the
    /// mesh's order), so one table would make each increment wait for the one before it
    /// through memory; [`TABLES`] tables, one per reference of each run of [`TABLES`], summed at
    /// the end, let those increments overlap.
    #[inline]
    pub fn of(refs: &[Ref], union: &Aabb) -> BinCounts {
        let mut tables = [[[0u32; BINS]; 6]; TABLES];
        let (first, scale) = (Vec3A::from(union.min), Vec3A::from(per_unit(union)));
        let last = Vec3A::splat((BINS - 1) as f32);
        // Three axes at once; `max` first takes NaN (0 · ∞ on a flat axis) to bin 0.
        let bin = |x: Vec3A| ((x - first) * scale).max(Vec3A::ZERO).min(last);
        let count = |table: &mut [[u32; BINS]; 6], r: &Ref| {
            let (lo, hi) = (truncate_to_i32(bin(r.lo())), truncate_to_i32(bin(r.hi())));
            for axis in 0..3 {
                table[axis][bin_index(lo[axis])] += 1;
                table[3 + axis][bin_index(hi[axis])] += 1;
            }
        };
        let mut runs = refs.chunks_exact(TABLES);
        for run in &mut runs {
            for (table, r) in tables.iter_mut().zip(run) {
                count(table, r);
            }
        }
        for (table, r) in tables.iter_mut().zip(runs.remainder()) {
            count(table, r);
        }
        let mut counts = BinCounts::ZERO;
        for table in &tables {
            let (starts, ends) = table.split_at(3);
            for (sum, part) in counts
                .starts
                .iter_mut()
                .chain(&mut counts.ends)
                .zip(starts.iter().chain(ends))
            {
                for (s, p) in sum.iter_mut().zip(part) {
                    *s += p;
                }
            }
        }
        counts
    }

    /// The counts of two disjoint runs of boxes binned across the same union, together.
    #[cfg(feature = "parallel")]
    #[inline]
    #[must_use]
    pub fn add(mut self, other: &BinCounts) -> BinCounts {
        for axis in 0..3 {
            for j in 0..BINS {
                self.starts[axis][j] += other.starts[axis][j];
                self.ends[axis][j] += other.ends[axis][j];
            }
        }
        self
    }
}

/// Bins per unit of length on each axis across `union`.
#[inline(always)]
fn per_unit(union: &Aabb) -> glam::Vec3 {
    BINS as f32 / union.extent()
}

impl Bins {
    /// The candidates of the non-empty boxes of `refs` (at most 2³² − 1), whose union is
    /// `union`. Counts are converted to f32, exact below 2²⁴ (beyond, rounding only blurs
    /// near-ties).
    #[inline]
    pub fn new(refs: &[Ref], union: Aabb) -> Bins {
        Bins::from_counts(&BinCounts::of(refs, &union), refs.len(), union)
    }

    /// [`Bins::new`] from the [`BinCounts`] of the `n` boxes across `union`.
    #[inline]
    pub fn from_counts(counts: &BinCounts, n: usize, union: Aabb) -> Bins {
        let per_unit = per_unit(&union);
        let BinCounts { starts, ends } = counts;
        let n = n as u32;
        let mut bins = Bins {
            pos: [[f32::NAN; BINNED_PLANES]; 3],
            below: [[0.0; BINNED_PLANES]; 3],
            above: [[0.0; BINNED_PLANES]; 3],
        };
        for axis in 0..3 {
            let (first, last) = (union.min[axis], union.max[axis]);
            let (pos, below, above) = (
                &mut bins.pos[axis],
                &mut bins.below[axis],
                &mut bins.above[axis],
            );
            (pos[0], below[0], above[0]) = (first, 0.0, n as f32);
            let (mut nb, mut na) = (0u32, n);
            for j in 1..BINS {
                nb += starts[axis][j - 1];
                na -= ends[axis][j - 1];
                let p = first + j as f32 / per_unit[axis];
                if p > first && p < last {
                    pos[j] = p;
                }
                (below[j], above[j]) = (nb as f32, na as f32);
            }
            (pos[BINS], below[BINS], above[BINS]) = (last, n as f32, 0.0);
        }
        bins
    }
}

impl Bins {
    /// Plane `index` of `axis` as a split, its cost left at 0: planar boxes go below, except at
    /// the union's lower face (plane 0), whose below side is empty.
    #[inline(always)]
    pub(super) fn split(&self, axis: usize, index: usize) -> Split {
        Split {
            axis,
            pos_key: key(self.pos[axis][index]),
            planar_below: index != 0,
            cost: 0.0,
            below_count: self.below[axis][index] as u32,
            above_count: self.above[axis][index] as u32,
        }
    }
}

impl Candidates for Bins {
    #[inline(always)]
    fn planes(&self, axis: usize) -> AxisPlanes<'_> {
        AxisPlanes {
            pos: &self.pos[axis],
            below: &self.below[axis],
            above: &self.above[axis],
            planar: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::events::unkey;
    use crate::kdtree::sah::boxes_x;
    use crate::kdtree::sah::CostModel;
    use crate::kdtree::BuildParams;
    use kdbeam_kernels::lanes::Dispatch;
    use kdbeam_kernels::Vec3;

    #[test]
    fn binned_search_cuts_empty_space_exactly_and_never_empties_a_boundary_side() {
        let costs = CostModel::new(&BuildParams::default());
        // Two clusters of 50 at either end of [0, 1] on x.
        let spans: Vec<(f32, f32)> = (0..100)
            .map(|i| {
                let at = if i < 50 { 0.0 } else { 0.9 } + 0.001 * (i % 50) as f32;
                (at, at + 0.05)
            })
            .collect();
        let boxes = boxes_x(&spans);
        let refs: Vec<Ref> = boxes
            .iter()
            .zip(0..)
            .map(|(b, id)| Ref::new(id, b))
            .collect();
        let union = boxes.iter().fold(Aabb::EMPTY, |u, b| u.union(*b));
        let bins = Bins::new(&refs, union);
        // In a cell twice as wide, the empty space above goes first, cut at the union's face.
        let wide = Aabb::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        for dispatch in Dispatch::available() {
            let cut = costs.best_binned_split(dispatch, &bins, &wide).unwrap();
            assert_eq!(
                (cut.axis, unkey(cut.pos_key)),
                (0, union.max.x),
                "{dispatch}"
            );
            assert_eq!((cut.below_count, cut.above_count), (100, 0), "{dispatch}");
        }
        // In the union itself, the plane between the clusters, with exact counts there.
        for dispatch in Dispatch::available() {
            let split = costs.best_binned_split(dispatch, &bins, &union).unwrap();
            let p = unkey(split.pos_key);
            assert_eq!(split.axis, 0, "{dispatch}");
            assert!(p > 0.1 && p < 0.9, "{dispatch}: {p}");
            assert_eq!(
                (split.below_count, split.above_count),
                (50, 50),
                "{dispatch}"
            );
        }
    }
}
