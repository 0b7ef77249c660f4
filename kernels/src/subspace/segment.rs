//! Ray masks: the cells a ray's segment in a [`Grid`] may touch, from the look-up table keyed
//! by its discretised entry and exit points (Yoshimura & Harada, Algorithm 1), or exactly per
//! ray (the paper's "ideal culling", for measuring).

use glam::{DVec3, Vec3};

use super::{Grid, VoxelMask};
use crate::{slab, Ray};

/// Slack of the sweep test in grid units (cells of size 1): far above the `f64` rounding of
/// its divisions, so that a cell the swept set only touches is kept.
const SWEEP_SLACK: f64 = 1e-9;

/// Does a segment from some point of the box `a` to some point of the box `b` touch the closed
/// unit cell `[c, c + 1]` (grid units)? Boxes as `[lo, hi]` per axis.
///
/// Exact up to a slack of `1e-9` cells (conservative): the segments between two boxes sweep the
/// convex hull of their union (C. Ericson, *Real-Time Collision Detection*, the moving-box
/// test), and the point at parameter `λ` of all of them fills the box
/// `(1 − λ)·a + λ·b`; the cell is touched when some `λ ∈ [0, 1]` makes that box overlap it on
/// every axis, each axis allowing an interval of `λ` from two linear inequalities.
#[must_use]
pub fn sweep_touches(a: [[f64; 2]; 3], b: [[f64; 2]; 3], c: [f64; 3]) -> bool {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    // α + β·λ ≤ γ narrows [lo, hi].
    let mut at_most = |alpha: f64, beta: f64, gamma: f64| {
        if beta == 0.0 {
            if alpha > gamma + SWEEP_SLACK {
                (lo, hi) = (1.0, 0.0);
            }
        } else {
            let x = (gamma - alpha) / beta;
            if beta > 0.0 {
                hi = hi.min(x + SWEEP_SLACK);
            } else {
                lo = lo.max(x - SWEEP_SLACK);
            }
        }
    };
    for k in 0..3 {
        let ([a0, a1], [b0, b1]) = (a[k], b[k]);
        // Lower side of the swept box at or below the cell's top, upper side at or above its
        // bottom.
        at_most(a0, b0 - a0, c[k] + 1.0);
        at_most(-a1, -(b1 - a1), -c[k]);
    }
    lo <= hi
}

/// Every cell of an `M::R³` grid (grid units, cell `i` spanning `[i, i + 1]`) that a segment
/// from a point of `a` to a point of `b` may touch ([`sweep_touches`]).
#[must_use]
pub fn sweep_mask<M: VoxelMask>(a: [[f64; 2]; 3], b: [[f64; 2]; 3]) -> M {
    let r = M::R;
    let mut mask = M::EMPTY;
    for z in 0..r {
        for y in 0..r {
            for x in 0..r {
                if sweep_touches(a, b, [x as f64, y as f64, z as f64]) {
                    mask = mask.with(x + r * (y + r * z));
                }
            }
        }
    }
    mask
}

/// The box of cell `i` of an `r³` grid in grid units.
fn cell_box(r: usize, i: usize) -> [[f64; 2]; 3] {
    let c = [i % r, i / r % r, i / (r * r)].map(|k| k as f64);
    c.map(|k| [k, k + 1.0])
}

/// Fills `table` (`R⁶` entries: index `a·R³ + b` for entry cell `a` and exit cell `b`) with
/// the paper's look-up table: entry `(a, b)` holds every cell a segment from any point of cell
/// `a` to any point of cell `b` can touch ([`sweep_mask`]). Symmetric in `a` and `b`; the
/// diagonal `(a, a)` is cell `a` and its neighbours it touches only on a boundary.
///
/// # Panics
/// When `table` does not have `R⁶` entries.
pub fn build_table<M: VoxelMask>(table: &mut [M]) {
    let n = M::R * M::R * M::R;
    assert_eq!(table.len(), n * n, "a table of R⁶ entries");
    for a in 0..n {
        for b in a..n {
            let m = sweep_mask::<M>(cell_box(M::R, a), cell_box(M::R, b));
            table[a * n + b] = m;
            table[b * n + a] = m;
        }
    }
}

/// Relative rounding bound of a segment's end points, against the ray's and the grid's
/// coordinate magnitudes: `2⁻¹⁸` (64 ulps of `f32`). It covers the slab test's `t`, the point
/// `o + t·d`, its grid coordinates, and the distance by which the intersector's edge tests may
/// accept a ray passing outside a triangle: the ray is taken as a tube of that radius.
const TUBE: f32 = 1.0 / 262_144.0;

/// A ray's segment in a grid: the grid coordinates of its ends, each known to within `slack`
/// cells per axis.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    /// Entry point, grid units (`[0, R]` inside the grid).
    pub entry: Vec3,
    /// Exit point, grid units.
    pub exit: Vec3,
    /// Rounding bound of both, grid units per axis.
    pub slack: Vec3,
}

/// The part of `ray` in `[ray.tmin, tmax]` inside `grid` (`r` cells per axis) as a [`Segment`],
/// `inv_direction = 1 / ray.direction` and `ray_magnitude` the largest `|origin|` component
/// given by the caller (per ray, once); `None` when the ray misses the grid's box grown by
/// the rounding bound.
///
/// The ray is a tube of radius `2⁻¹⁸·(ray_magnitude + grid.magnitude)` (see `TUBE`): the box is
/// grown by it for the slab test, and it is the end points' `slack` (plus `2⁻¹⁸·r` for the
/// grid coordinates' own rounding). The slack may be a cell or more for a ray from far away
/// against a small grid: its mask then holds more cells, never fewer.
#[inline(always)]
#[must_use]
pub fn segment(
    grid: &Grid,
    r: usize,
    ray: &Ray,
    inv_direction: Vec3,
    ray_magnitude: f32,
    tmax: f32,
) -> Option<Segment> {
    let tube = TUBE * (ray_magnitude + grid.magnitude);
    let b = crate::Aabb::new(grid.lower - tube, grid.upper + tube);
    let (t0, t1) = slab::ray_box(ray.origin, inv_direction, ray.tmin, tmax, &b)?;
    let scale = grid.inv_extent * r as f32;
    let at = |t: f32| (ray.origin + ray.direction * t - grid.lower) * scale;
    Some(Segment {
        entry: at(t0),
        exit: at(t1),
        slack: scale * tube + TUBE * r as f32,
    })
}

/// The cells `[lo, hi]` per axis (clamped to the grid) that a coordinate `u ± slack` lies in;
/// `None` when `u` is not finite.
#[inline(always)]
fn span(u: Vec3, slack: Vec3, r: usize) -> Option<([usize; 3], [usize; 3])> {
    if !(u.is_finite() && slack.is_finite()) {
        return None;
    }
    let top = r as f32;
    // Clamped to [−1, R + 1] first, then floored by truncation of a positive value.
    let floor = |x: Vec3| {
        let v = (x.clamp(Vec3::splat(-1.0), Vec3::splat(top + 1.0)) + 2.0).to_array();
        v.map(|c| (c as usize).saturating_sub(2).min(r - 1))
    };
    Some((floor(u - slack), floor(u + slack)))
}

impl Segment {
    /// The ray mask from `table` ([`build_table`]): the union of the entries of every pair of
    /// cells the entry and exit points may lie in (one entry unless a point lies within its
    /// slack of a cell boundary). [`VoxelMask::FULL`] for a non-finite segment.
    #[inline(always)]
    #[must_use]
    pub fn table_mask<M: VoxelMask>(&self, table: &[M]) -> M {
        let r = M::R;
        let n = r * r * r;
        let (Some((a0, a1)), Some((b0, b1))) = (
            span(self.entry, self.slack, r),
            span(self.exit, self.slack, r),
        ) else {
            return M::FULL;
        };
        let index = |c: [usize; 3]| c[0] + r * (c[1] + r * c[2]);
        if a0 == a1 && b0 == b1 {
            return table[index(a0) * n + index(b0)];
        }
        let mut mask = M::EMPTY;
        for az in a0[2]..=a1[2] {
            for ay in a0[1]..=a1[1] {
                for ax in a0[0]..=a1[0] {
                    let a = index([ax, ay, az]) * n;
                    for bz in b0[2]..=b1[2] {
                        for by in b0[1]..=b1[1] {
                            for bx in b0[0]..=b1[0] {
                                mask = mask.or(table[a + index([bx, by, bz])]);
                            }
                        }
                    }
                }
            }
        }
        mask
    }

    /// The exact ray mask: every cell the segment, grown by its slack, touches
    /// ([`sweep_mask`] of the two end points' slack boxes): the paper's ideal culling, at
    /// `R³` sweep tests per call. [`VoxelMask::FULL`] for a non-finite segment.
    #[must_use]
    pub fn exact_mask<M: VoxelMask>(&self) -> M {
        if !(self.entry.is_finite() && self.exit.is_finite() && self.slack.is_finite()) {
            return M::FULL;
        }
        let around = |u: Vec3| {
            let (lo, hi) = ((u - self.slack).as_dvec3(), (u + self.slack).as_dvec3());
            [0, 1, 2].map(|k| [lo[k], hi[k]])
        };
        sweep_mask(around(self.entry), around(self.exit))
    }
}

/// The exact mask of the segment between the points `p` and `q` in grid units, for tests.
#[must_use]
pub fn segment_mask<M: VoxelMask>(p: DVec3, q: DVec3) -> M {
    sweep_mask([0, 1, 2].map(|k| [p[k]; 2]), [0, 1, 2].map(|k| [q[k]; 2]))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::{vec, vec::Vec};

    use super::*;
    use crate::subspace::test_rng::Rng;
    use crate::subspace::Mask6;
    use crate::Aabb;

    /// Every cell a point lies in (two on a boundary), grid units.
    fn cells_of(u: Vec3, r: usize) -> Vec<usize> {
        let span = |c: f32| {
            let lo = (c - 1e-4).floor().clamp(0.0, (r - 1) as f32) as usize;
            let hi = (c + 1e-4).floor().clamp(0.0, (r - 1) as f32) as usize;
            lo..=hi
        };
        let u = u.to_array();
        let mut v = Vec::new();
        for z in span(u[2]) {
            for y in span(u[1]) {
                for x in span(u[0]) {
                    v.push(x + r * (y + r * z));
                }
            }
        }
        v
    }

    fn check<M: VoxelMask>(seed: u64) {
        let n = M::R * M::R * M::R;
        let mut table = vec![M::EMPTY; n * n];
        build_table(&mut table);
        let mut rng = Rng(seed);
        for i in 0..2000 {
            let b = Aabb::from_points([rng.point(-2.0, 2.0), rng.point(-2.0, 2.0)]);
            let grid = Grid::around(&b).unwrap();
            let mut direction = rng.point(-1.0, 1.0);
            // Axis-parallel and zero components too.
            if i % 5 == 0 {
                direction.x = 0.0;
            }
            if i % 7 == 0 {
                direction.y = 0.0;
                direction.z = 0.0;
                direction.x = 1.0;
            }
            let ray = Ray::new(rng.point(-3.0, 3.0), direction);
            let inv = ray.direction.recip();
            let mag = ray.origin.abs().max_element();
            let Some(s) = segment(&grid, M::R, &ray, inv, mag, f32::INFINITY) else {
                continue;
            };
            let (lut, exact): (M, M) = (s.table_mask(&table), s.exact_mask());
            assert_eq!(lut.and(exact), exact, "the table holds the exact mask");
            let (t0, t1) = slab::ray_box(ray.origin, inv, 0.0, f32::INFINITY, &grid.bounds())
                .unwrap_or((1.0, 0.0));
            for k in 0..=100 {
                let t = t0 + (t1 - t0) * k as f32 / 100.0;
                if t0 > t1 {
                    break;
                }
                let u =
                    (ray.origin + ray.direction * t - grid.lower) * grid.inv_extent * M::R as f32;
                for c in cells_of(u, M::R) {
                    assert!(exact.contains(c), "{ray:?} {grid:?}: t {t} cell {c}");
                }
            }
        }
    }

    #[test]
    fn every_sampled_point_of_a_segment_is_in_its_masks() {
        check::<u64>(0x9e37_79b9_7f4a_7c15);
        check::<Mask6>(0x2545_f491_4f6c_dd1d);
    }

    #[test]
    fn table_entries_hold_every_sampled_segment_between_their_cells() {
        let mut table = vec![0u64; 4096];
        build_table(&mut table);
        let mut rng = Rng(77);
        for _ in 0..20_000 {
            let (p, q) = (rng.point(0.0, 4.0), rng.point(0.0, 4.0));
            let cell = |u: Vec3| {
                let c = u.to_array().map(|c| (c as usize).min(3));
                c[0] + 4 * (c[1] + 4 * c[2])
            };
            let entry = table[cell(p) * 64 + cell(q)];
            let exact: u64 = segment_mask(p.as_dvec3(), q.as_dvec3());
            assert_eq!(entry & exact, exact);
        }
        // A diagonal through the grid's corners touches 4 cells (and the ones it grazes at
        // shared edges), far from all 64.
        assert!(table[63].count_ones() < 64 && table[0] & 1 == 1);
    }
}
