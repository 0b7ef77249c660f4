//! Single-ray box culling in a leaf: the box of the ray's segment in the leaf against a box per
//! triangle (J.-H. Nah, W.-C. Park, Y.-S. Kang & T.-D. Han, *Ray-Box Culling for Tree
//! Structures*, Journal of Information Science and Engineering).
//!
//! A ray that reaches a leaf over `[t0, t1]` can only hit a triangle there at a point of the
//! segment `o + t·d`, `t ∈ [t0, t1]`, whose axis-aligned box is spanned by its two ends. A
//! triangle whose box (clipped to the leaf's box: only the part of the triangle in the leaf can
//! be hit in the leaf's segment) does not overlap the segment's box is not hit there, and its
//! test is skipped. The paper shrinks `t1` to the closest hit so far, which tightens the box as
//! hits are found. Six comparisons per triangle, one vector of triangles at a time.
//!
//! **Conservative in floating point.** The segment's ends are rounded (`o + t·d`, two roundings
//! per axis), and the intersector's `t` for a hit is itself off by a few ulps of `t` (more near
//! grazing incidence, where `n·d` loses its leading bits). [`segment_box`] therefore widens the
//! box on each axis by [`SEGMENT_EPS`] of `|o| + max(|t0|, |t1|)·|d|`, a bound on the magnitude
//! of every coordinate the segment takes, and [`BoxBlock::clipped`] widens the leaf's box by the
//! same relative amount before clipping, since the leaf's tight box comes from clipped polygons
//! whose vertices were rounded. Every comparison is ordered, written as "cull when strictly
//! apart": a NaN anywhere keeps the triangle.

use glam::Vec3;

use crate::aabb::Aabb;
use crate::lanes::{LaneF32, LaneMask, Lanes};
use crate::triangle::{TriangleBlock, BLOCK};

/// Relative widening of the segment's box and of the leaf box the triangle boxes are clipped
/// to: 2⁻¹⁵, 256 ulps of a coordinate's magnitude — far above the two roundings of `o + t·d`
/// and the few of a clipped vertex, with room for the intersector's error in `t` at incidence
/// angles down to a few hundredths of a radian, yet far below a triangle's size in any mesh
/// that is not itself near the limits of `f32`.
pub const SEGMENT_EPS: f32 = 1.0 / 32_768.0;

/// The boxes of the triangles of one [`TriangleBlock`], each clipped to its leaf's box, in
/// structure-of-arrays form: lane `i` of `min[a]` is the smallest coordinate `a` of triangle `i`.
///
/// A triangle that lies in several leaves is stored once per leaf, each copy in its own block,
/// so each has the box of its own part. Lanes that hold no triangle (a leaf's padding) have the
/// empty box (`min = +inf`, `max = −inf`), which no segment overlaps.
///
/// ```
/// use kdbeam_kernels::raybox::BoxBlock;
/// use kdbeam_kernels::triangle::TriangleBlock;
/// use kdbeam_kernels::{Aabb, Triangle, Vec3};
///
/// let t = Triangle::new(Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 4.0, 0.0));
/// let block = TriangleBlock::new(t.v0, [(t, 0)]);
/// let leaf = Aabb::new(Vec3::ZERO, Vec3::ONE);
/// let boxes = BoxBlock::clipped(&block, 1, &leaf);
/// let b = boxes.get(0);
/// // The triangle's box [0, 4]² × [0, 0], clipped to the leaf (widened by a few ulps).
/// assert!(b.max.x >= 1.0 && b.max.x < 1.001 && b.min.z <= 0.0);
/// assert!(boxes.get(1).is_empty());
/// ```
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BoxBlock {
    /// `min[axis][lane]`.
    pub min: [[f32; BLOCK]; 3],
    /// `max[axis][lane]`.
    pub max: [[f32; BLOCK]; 3],
}

impl BoxBlock {
    /// Every lane the empty box.
    pub const EMPTY: BoxBlock = BoxBlock {
        min: [[f32::INFINITY; BLOCK]; 3],
        max: [[f32::NEG_INFINITY; BLOCK]; 3],
    };

    /// The boxes of the first `count` triangles of `block` (at most [`BLOCK`]), each clipped to
    /// `leaf` widened by [`SEGMENT_EPS`] of its magnitude and extent; the other lanes empty.
    ///
    /// A triangle outside `leaf` gets an empty box on some axis, which culls it for every
    /// segment. A NaN vertex coordinate leaves a NaN bound, which culls nothing.
    #[must_use]
    pub fn clipped(block: &TriangleBlock, count: usize, leaf: &Aabb) -> BoxBlock {
        let magnitude = leaf.min.abs().max(leaf.max.abs()) + (leaf.max - leaf.min).abs();
        let pad = magnitude * SEGMENT_EPS;
        let widened = Aabb::new(leaf.min - pad, leaf.max + pad);
        let mut boxes = BoxBlock::EMPTY;
        for lane in 0..count.min(BLOCK) {
            let t = block.triangle(lane);
            let own = Aabb::new(t.v0.min(t.v1).min(t.v2), t.v0.max(t.v1).max(t.v2));
            boxes.set(lane, &clip(own, &widened));
        }
        boxes
    }

    /// Lane `lane`'s box. Panics if `lane >= BLOCK`.
    #[inline]
    #[must_use]
    pub fn get(&self, lane: usize) -> Aabb {
        let at = |v: &[[f32; BLOCK]; 3]| Vec3::new(v[0][lane], v[1][lane], v[2][lane]);
        Aabb::new(at(&self.min), at(&self.max))
    }

    /// Sets lane `lane`'s box. Panics if `lane >= BLOCK`.
    #[inline]
    pub fn set(&mut self, lane: usize, b: &Aabb) {
        for a in 0..3 {
            self.min[a][lane] = b.min[a];
            self.max[a][lane] = b.max[a];
        }
    }
}

/// `own ∩ leaf`, keeping a NaN bound of `own` (so that it culls nothing): `f32::max`/`min`
/// would replace it by the leaf's bound.
fn clip(own: Aabb, leaf: &Aabb) -> Aabb {
    let mut b = own;
    for a in 0..3 {
        if leaf.min[a] > b.min[a] {
            b.min[a] = leaf.min[a];
        }
        if leaf.max[a] < b.max[a] {
            b.max[a] = leaf.max[a];
        }
    }
    b
}

/// The box of the segment `origin + t·direction`, `t` between `t0` and `t1` (in either order),
/// widened on each axis by [`SEGMENT_EPS`] of `|origin| + max(|t0|, |t1|)·|direction|`.
///
/// When an end is not finite (an infinite `t`, or `0·inf`), the box is the whole space, which
/// culls nothing; so is a NaN anywhere. Callers pass finite ends: the traversal clips a ray to
/// the tree's box, so its leaf segments are finite for every traceable ray.
///
/// ```
/// use kdbeam_kernels::raybox::segment_box;
/// use kdbeam_kernels::Vec3;
///
/// let b = segment_box(Vec3::ZERO, Vec3::new(1.0, -2.0, 0.0), 1.0, 2.0);
/// assert!(b.min.x < 1.0 && b.max.x > 2.0 && b.min.y < -4.0 && b.max.y > -2.0);
/// assert!(b.max.x < 2.001 && b.min.z == 0.0 && b.max.z == 0.0);
/// let all = segment_box(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
/// assert_eq!((all.min, all.max), (Vec3::NEG_INFINITY, Vec3::INFINITY));
/// ```
#[inline(always)]
#[must_use]
pub fn segment_box(origin: Vec3, direction: Vec3, t0: f32, t1: f32) -> Aabb {
    let (p0, p1) = (origin + direction * t0, origin + direction * t1);
    let reach = origin.abs() + direction.abs() * t0.abs().max(t1.abs());
    let pad = reach * SEGMENT_EPS;
    let b = Aabb::new(p0.min(p1) - pad, p0.max(p1) + pad);
    if b.min.is_finite() && b.max.is_finite() && reach.is_finite() {
        b
    } else {
        Aabb::new(Vec3::NEG_INFINITY, Vec3::INFINITY)
    }
}

/// Of the triangles `first..first + WIDTH` of `boxes` (bit `i`: triangle `first + i`), those
/// whose box overlaps `segment` (a [`segment_box`]): closed boxes, so touching counts.
///
/// Written as the negation of "strictly apart on some axis", with ordered comparisons: a lane
/// with a NaN bound, or a NaN in `segment`, is kept. `first + WIDTH` must not exceed [`BLOCK`]
/// (panics otherwise).
#[inline(always)]
#[must_use]
pub fn overlapping<L: Lanes>(l: L, segment: &Aabb, boxes: &BoxBlock, first: usize) -> u32 {
    let mut apart = l.mask_from_bits(0);
    for a in 0..3 {
        let lo = l.load(&boxes.min[a][first..]);
        let hi = l.load(&boxes.max[a][first..]);
        apart = apart | lo.gt(l.splat(segment.max[a])) | hi.lt(l.splat(segment.min[a]));
    }
    (!apart).bits()
}

/// Of the first `count` triangles of `boxes` (bit `i`: triangle `i`), those whose box overlaps
/// `segment`, a vector of boxes per [`overlapping`] call. `count` must not exceed [`BLOCK`].
///
/// A plain loop, not an iterator fold: a fold's closure may stay out of line, outside the
/// caller's ISA target features.
#[inline(always)]
#[must_use]
pub fn overlapping_block<L: Lanes>(l: L, segment: &Aabb, boxes: &BoxBlock, count: usize) -> u32 {
    let mut kept = 0;
    let mut first = 0;
    while first < count {
        kept |= overlapping(l, segment, boxes, first) << first;
        first += L::WIDTH;
    }
    kept
}
