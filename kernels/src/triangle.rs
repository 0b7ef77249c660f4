//! The triangle forms the kernels read, laid out flat so a leaf is a contiguous slice.

use glam::Vec3;

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
