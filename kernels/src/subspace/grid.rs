//! The box a mask's cells divide.

use glam::{DVec3, Vec3};

use crate::Aabb;

/// A box cut into `R³` equal cells, for any `R`: the padded box and its inverse extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Smallest corner of the padded box.
    pub lower: Vec3,
    /// Largest corner of the padded box.
    pub upper: Vec3,
    /// `1 / (upper − lower)` per axis, finite and positive.
    pub inv_extent: Vec3,
    /// The largest coordinate magnitude of the box, for rounding bounds.
    pub magnitude: f32,
}

/// Padding of [`Grid::around`], relative to the box's largest extent.
const PAD_EXTENT: f32 = 1.0 / 4096.0;
/// Padding of [`Grid::around`], relative to the box's largest coordinate magnitude.
const PAD_MAGNITUDE: f32 = 1.0 / 65536.0;

impl Grid {
    /// The grid over `b` padded on every side by `2⁻¹²` of its largest extent plus `2⁻¹⁶` of its
    /// largest coordinate magnitude (at least the smallest normal `f32`).
    ///
    /// Why the padding: a box flat on an axis (triangles in a face plane) gets cells of non-zero
    /// size, and points that rounding puts a few ulps outside `b` (a clipped triangle's bound,
    /// a hit on a face) still fall inside the grid, so a ray's slab test against the grid
    /// never loses a segment that holds a hit. Cells are coarser by that fraction only.
    ///
    /// `None` for an empty box, a non-finite one, or one whose padded extent overflows `f32`:
    /// such a box gets no mask (nothing is culled in it).
    #[must_use]
    pub fn around(b: &Aabb) -> Option<Grid> {
        if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
            return None;
        }
        let magnitude = b.min.abs().max(b.max.abs()).max_element();
        let pad = (b.extent().max_element() * PAD_EXTENT + magnitude * PAD_MAGNITUDE)
            .max(f32::MIN_POSITIVE);
        let (lower, upper) = (b.min - pad, b.max + pad);
        let inv_extent = (upper - lower).recip();
        let ok = lower.is_finite()
            && upper.is_finite()
            && inv_extent.is_finite()
            && inv_extent.min_element() > 0.0;
        ok.then(|| Grid {
            lower,
            upper,
            inv_extent,
            magnitude: lower.abs().max(upper.abs()).max_element(),
        })
    }

    /// The box, in `f32`.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.lower, self.upper)
    }

    /// Cell `(x, y, z)` of `r` per axis as `[lower, upper]` in `f64`, from the `f32` corners
    /// exactly (`lower + (upper − lower)·i/r` rounded once in `f64`).
    #[must_use]
    pub fn cell(&self, r: usize, x: usize, y: usize, z: usize) -> (DVec3, DVec3) {
        let (lo, hi) = (self.lower.as_dvec3(), self.upper.as_dvec3());
        let at = |i: DVec3| lo + (hi - lo) * i / r as f64;
        let i = DVec3::new(x as f64, y as f64, z as f64);
        (at(i), at(i + 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_and_bad_boxes() {
        let g = Grid::around(&Aabb::new(
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 2.0),
        ))
        .unwrap();
        assert!(g.lower.y < 1.0 && g.upper.y > 1.0 && g.inv_extent.y.is_finite());
        let point = Grid::around(&Aabb::new(Vec3::ZERO, Vec3::ZERO)).unwrap();
        assert!(point.inv_extent.is_finite());
        assert!(Grid::around(&Aabb::EMPTY).is_none());
        let huge = Aabb::new(Vec3::splat(-f32::MAX), Vec3::splat(f32::MAX));
        assert!(Grid::around(&huge).is_none());
        let nan = Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE);
        assert!(Grid::around(&nan).is_none());
    }
}
