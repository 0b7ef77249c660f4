//! The triangle forms the kernels read, laid out flat so a leaf is a contiguous slice.

use glam::Vec3;

use crate::lanes::MAX_WIDTH;

/// A triangle by its three vertices, exactly as given (the watertight test and the frustum read
/// this form: recomputing a vertex from edges would round differently for two triangles that
/// share it, and open cracks).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Triangle {
    /// First vertex.
    pub v0: Vec3,
    /// Second vertex.
    pub v1: Vec3,
    /// Third vertex.
    pub v2: Vec3,
}

impl Triangle {
    /// The triangle `(v0, v1, v2)`.
    #[inline]
    #[must_use]
    pub fn new(v0: Vec3, v1: Vec3, v2: Vec3) -> Self {
        Triangle { v0, v1, v2 }
    }

    /// Twice the area (the length of the unnormalised normal); 0 for a degenerate triangle.
    #[inline]
    #[must_use]
    pub fn double_area(&self) -> f32 {
        (self.v1 - self.v0).cross(self.v2 - self.v0).length()
    }
}

/// The Kensler–Shirley form (RT06): `p0`, `e0 = p1 − p0`, `e1 = p0 − p2`, `n = e0 × e1`.
///
/// A degenerate triangle has `n = 0`; the test then computes `1 / 0 = inf` and `0 * inf = NaN`,
/// and every comparison with NaN fails, so it never reports a hit.
///
/// Aligned to 16 bytes, which its 48 bytes fill without padding, so that a buffer of other
/// 16-byte records (such as a builder's scratch) can be recycled for an array of them.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct KsTriangle {
    /// First vertex.
    pub p0: Vec3,
    /// `p1 − p0`.
    pub e0: Vec3,
    /// `p0 − p2`.
    pub e1: Vec3,
    /// `e0 × e1` (unnormalised).
    pub n: Vec3,
}

impl From<&Triangle> for KsTriangle {
    #[inline]
    fn from(t: &Triangle) -> Self {
        let e0 = t.v1 - t.v0;
        let e1 = t.v0 - t.v2;
        KsTriangle {
            p0: t.v0,
            e0,
            e1,
            n: e0.cross(e1),
        }
    }
}

/// Triangles per [`TriangleBlock`]: [`MAX_WIDTH`], so that every ISA reads a block in whole
/// vectors (16 lanes at once, or 2 × 8, 4 × 4, 16 × 1).
pub const BLOCK: usize = MAX_WIDTH;

/// Up to [`BLOCK`] triangles in structure-of-arrays form, with their mesh ids: lane `i` of
/// `v[k][a]` is coordinate `a` of vertex `k` of triangle `i`.
///
/// Only the vertices are stored: Kensler–Shirley's edges and normal are two subtractions and a
/// cross product away ([`KsTriangle::from`]), cheaper to recompute next to the test than to
/// read, since a leaf's triangles come from memory far more often than from a cache.
///
/// A kd-tree leaf is a run of blocks; its last block is padded with copies of a *point*
/// triangle (three equal vertices, those of the leaf's first vertex, so edges and normal 0) and id
/// `u32::MAX`. A point triangle never hits: Kensler–Shirley has `n = 0` and a NaN `t`, the
/// watertight test `det = 0`; its vertex lies in the leaf, so the beam and boxes see nothing unbounded.
/// Readers still mask lanes at or beyond the leaf's count ([`TriangleBlock::valid_bits`]), so
/// that padding costs no watertight `f64` fallback and counts no test.
///
/// 64-byte aligned: a block is 10 whole cache lines, a vector load never splits one.
///
/// ```
/// use kdbeam_kernels::triangle::{TriangleBlock, BLOCK};
/// use kdbeam_kernels::{Triangle, Vec3};
///
/// let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
/// let mut block = TriangleBlock::padding(t.v0);
/// block.set(1, &t, 9);
/// assert_eq!((block.triangle(1), block.ids[1]), (t, 9));
/// assert_eq!(block.triangle(0).double_area(), 0.0);
/// assert_eq!((block.ids[BLOCK - 1], TriangleBlock::valid_bits(2)), (u32::MAX, 0b11));
/// ```
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TriangleBlock {
    /// `v[vertex][axis][lane]`.
    pub v: [[[f32; BLOCK]; 3]; 3],
    /// Mesh triangle ids (`u32::MAX` in padding lanes).
    pub ids: [u32; BLOCK],
}

impl TriangleBlock {
    /// Triangle `i` of the block. Panics if `i >= BLOCK`.
    #[inline(always)]
    #[must_use]
    pub fn triangle(&self, i: usize) -> Triangle {
        let vertex = |k: usize| Vec3::new(self.v[k][0][i], self.v[k][1][i], self.v[k][2][i]);
        Triangle::new(vertex(0), vertex(1), vertex(2))
    }

    /// Triangle `i` of the block in Kensler–Shirley form. Panics if `i >= BLOCK`.
    #[inline(always)]
    #[must_use]
    pub fn ks_triangle(&self, i: usize) -> KsTriangle {
        KsTriangle::from(&self.triangle(i))
    }

    /// Sets lane `i` to `tri` with id `id`. Panics if `i >= BLOCK`.
    #[inline]
    pub fn set(&mut self, i: usize, tri: &Triangle, id: u32) {
        for (k, v) in [tri.v0, tri.v1, tri.v2].into_iter().enumerate() {
            for a in 0..3 {
                self.v[k][a][i] = v[a];
            }
        }
        self.ids[i] = id;
    }

    /// A block of [`BLOCK`] copies of the point triangle at `p`, ids `u32::MAX`.
    #[inline]
    #[must_use]
    pub fn padding(p: Vec3) -> Self {
        let lanes = |a: usize| [p[a]; BLOCK];
        let vertex = [lanes(0), lanes(1), lanes(2)];
        TriangleBlock {
            v: [vertex; 3],
            ids: [u32::MAX; BLOCK],
        }
    }

    /// The block of `triangles` (with their ids; at most [`BLOCK`], the rest ignored), its
    /// other lanes the point triangle at `pad`.
    #[inline]
    #[must_use]
    pub fn new(pad: Vec3, triangles: impl IntoIterator<Item = (Triangle, u32)>) -> Self {
        let mut block = TriangleBlock::padding(pad);
        for (lane, (tri, id)) in triangles.into_iter().take(BLOCK).enumerate() {
            block.set(lane, &tri, id);
        }
        block
    }

    /// Bit `i` set for the lanes `i < count` of a block holding `count` real triangles
    /// (`count >= BLOCK` sets every lane).
    #[inline(always)]
    #[must_use]
    pub const fn valid_bits(count: usize) -> u32 {
        if count >= BLOCK {
            (1 << BLOCK) - 1
        } else {
            (1 << count) - 1
        }
    }
}
