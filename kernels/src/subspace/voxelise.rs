//! Conservative voxelisation of a triangle: the cells of a [`Grid`] it touches.

use glam::DVec3;

use super::{cell_index, Grid, VoxelMask};
use crate::Triangle;

/// Dilation of every cell before the overlap test, relative to the grid's coordinate
/// magnitude: `2⁻²⁰`, far above the `f64` rounding of the separating-axis test and of the
/// cell corners, so that a cell the triangle touches (or grazes) is never lost.
const DILATION: f64 = 1.0 / 1_048_576.0;

/// The cells of `grid` (`M::R` per axis) that the triangle `tri` touches: its object mask.
///
/// A cell is set when the closed cell, dilated by `2⁻²⁰` of the grid's coordinate magnitude,
/// overlaps the closed triangle by the separating-axis test (T. Akenine-Möller, *Fast 3D
/// Triangle-Box Overlap Testing*, JGT 2001: the three box normals, the triangle's normal and
/// the nine edge × axis products), computed in `f64`. The triangle is thereby clipped to the
/// grid: its parts outside touch no cell. Degenerate triangles (zero area, a segment, a point)
/// are handled, as the products of a zero edge or normal never separate. A triangle with a
/// non-finite coordinate gets [`VoxelMask::FULL`].
#[must_use]
pub fn voxelise<M: VoxelMask>(grid: &Grid, tri: &Triangle) -> M {
    let v = [tri.v0, tri.v1, tri.v2].map(|p| p.as_dvec3());
    if !v.iter().all(|p| p.is_finite()) {
        return M::FULL;
    }
    let r = M::R;
    let eps = DILATION * f64::from(grid.magnitude);
    let (lo, hi) = (grid.lower.as_dvec3(), grid.upper.as_dvec3());
    let cell = (hi - lo) / r as f64;
    let tmin = v[0].min(v[1]).min(v[2]);
    let tmax = v[0].max(v[1]).max(v[2]);
    // The cells the triangle's dilated box overlaps, a cell wider on each side for safety.
    let range = |a: usize| {
        let r1 = (r - 1) as f64;
        let first = ((tmin[a] - eps - lo[a]) / cell[a]).clamp(-1.0, r1 + 1.0) - 1.0;
        let last = ((tmax[a] + eps - lo[a]) / cell[a]).clamp(-1.0, r1 + 1.0) + 1.0;
        // Truncation is a floor here up to one cell, which the extra cell on each side covers.
        (first.clamp(0.0, r1) as usize, last.clamp(0.0, r1) as usize)
    };
    let ((x0, x1), (y0, y1), (z0, z1)) = (range(0), range(1), range(2));
    if tmax.x < lo.x - eps
        || tmax.y < lo.y - eps
        || tmax.z < lo.z - eps
        || tmin.x > hi.x + eps
        || tmin.y > hi.y + eps
        || tmin.z > hi.z + eps
    {
        return M::EMPTY;
    }
    let mut mask = M::EMPTY;
    for z in z0..=z1 {
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (c0, c1) = grid.cell(r, x, y, z);
                if overlaps(&v, (c0 + c1) * 0.5, (c1 - c0) * 0.5 + eps) {
                    mask = mask.with(cell_index_dyn(r, x, y, z));
                }
            }
        }
    }
    mask
}

/// [`cell_index`] for a run-time `r`.
#[inline(always)]
fn cell_index_dyn(r: usize, x: usize, y: usize, z: usize) -> usize {
    match r {
        4 => cell_index::<4>(x, y, z),
        6 => cell_index::<6>(x, y, z),
        _ => x + r * (y + r * z),
    }
}

/// Does the closed triangle `v` overlap the closed box of centre `c` and half-size `h`?
/// Separating axes; an axis that is zero (a degenerate edge or normal) never separates.
fn overlaps(v: &[DVec3; 3], c: DVec3, h: DVec3) -> bool {
    let p = v.map(|q| q - c);
    let separated = |axis: DVec3| {
        let d = [p[0].dot(axis), p[1].dot(axis), p[2].dot(axis)];
        let (min, max) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
        let rad = h.dot(axis.abs());
        min > rad || max < -rad
    };
    let edges = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    if axes.iter().any(|&a| separated(a)) {
        return false;
    }
    if separated(edges[0].cross(edges[1])) {
        return false;
    }
    !edges
        .iter()
        .any(|e| axes.iter().any(|&a| separated(e.cross(a))))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::subspace::test_rng::Rng;
    use crate::subspace::Mask6;
    use crate::Aabb;

    /// The cells a point lies in (all of them when it is on a boundary).
    fn cells_of(grid: &Grid, r: usize, p: Vec3) -> impl Iterator<Item = usize> + '_ {
        let u = ((p - grid.lower) * grid.inv_extent * r as f32).to_array();
        let span = move |a: usize| {
            let lo = (u[a] - 1e-3).floor().clamp(0.0, (r - 1) as f32) as usize;
            let hi = (u[a] + 1e-3).floor().clamp(0.0, (r - 1) as f32) as usize;
            lo..=hi
        };
        let (sx, sy, sz) = (span(0), span(1), span(2));
        sz.flat_map(move |z| {
            let sx = sx.clone();
            sy.clone()
                .flat_map(move |y| sx.clone().map(move |x| x + r * (y + r * z)))
        })
        .filter(move |_| grid.bounds().contains(p))
    }

    fn check<M: VoxelMask>(seed: u64) {
        let mut rng = Rng(seed);
        for _ in 0..300 {
            let b = Aabb::from_points([rng.point(-2.0, 2.0), rng.point(-2.0, 2.0)]);
            let grid = Grid::around(&b).unwrap();
            let tri = Triangle {
                v0: rng.point(-3.0, 3.0),
                v1: rng.point(-3.0, 3.0),
                v2: rng.point(-3.0, 3.0),
            };
            let mask: M = voxelise(&grid, &tri);
            for _ in 0..200 {
                let (a, b) = (rng.next(), rng.next());
                let (a, b) = if a + b > 1.0 {
                    (1.0 - a, 1.0 - b)
                } else {
                    (a, b)
                };
                let p = tri.v0 + (tri.v1 - tri.v0) * a + (tri.v2 - tri.v0) * b;
                for c in cells_of(&grid, M::R, p) {
                    assert!(mask.contains(c), "{tri:?} in {grid:?}: {p} in cell {c}");
                }
            }
        }
    }

    #[test]
    fn every_sampled_point_of_a_triangle_is_in_its_mask() {
        check::<u64>(0x1234_5678_9abc_def1);
        check::<Mask6>(0x0fed_cba9_8765_4321);
    }

    #[test]
    fn far_and_degenerate_triangles() {
        let grid = Grid::around(&Aabb::new(Vec3::ZERO, Vec3::ONE)).unwrap();
        let far = Triangle {
            v0: Vec3::splat(5.0),
            v1: Vec3::splat(6.0),
            v2: Vec3::new(5.0, 6.0, 5.0),
        };
        assert!(voxelise::<u64>(&grid, &far).is_empty());
        let point = Triangle {
            v0: Vec3::splat(0.1),
            v1: Vec3::splat(0.1),
            v2: Vec3::splat(0.1),
        };
        assert_eq!(voxelise::<u64>(&grid, &point), 1);
        let nan = Triangle {
            v0: Vec3::NAN,
            ..point
        };
        assert_eq!(voxelise::<u64>(&grid, &nan), u64::MAX);
        // A diagonal sliver touches far fewer than all cells.
        let sliver = Triangle {
            v0: Vec3::ZERO,
            v1: Vec3::ONE,
            v2: Vec3::new(1.0, 1.0, 0.999),
        };
        assert!(
            voxelise::<Mask6>(&grid, &sliver)
                .0
                .iter()
                .map(|w| w.count_ones())
                .sum::<u32>()
                < 60
        );
    }
}
