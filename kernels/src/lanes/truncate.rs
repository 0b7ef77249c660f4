//! Float-to-integer truncation of three lanes at once.

use glam::Vec3A;

/// The integer parts of `v`'s lanes, rounded toward zero: `v.x as i32` and so on for lanes in
/// `(-2³¹, 2³¹)`.
///
/// Edge cases: a NaN or out-of-range lane gives an unspecified value (`i32::MIN` on x86-64),
/// never undefined behaviour. That is the point: `as i32` must saturate, which costs two compares
/// per lane, where x86-64 converts all lanes in one `cvttps2dq` (SSE2, which every x86-64 CPU
/// has). Callers that clamp first, like the kd-tree build's binning, lose nothing.
///
/// ```
/// use kdbeam_kernels::lanes::truncate_to_i32;
/// assert_eq!(truncate_to_i32(glam::Vec3A::new(0.0, 2.99, 31.5)), [0, 2, 31]);
/// ```
#[inline]
#[must_use]
pub fn truncate_to_i32(v: Vec3A) -> [i32; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{__m128, _mm_cvttps_epi32};
        // `Vec3A`'s unused fourth lane is converted along (whatever it holds, with no effect
        // but a masked floating-point flag) and dropped.
        let v: __m128 = v.into();
        // SAFETY: SSE2 is part of the x86-64 baseline: every x86-64 CPU runs this intrinsic,
        // which touches no memory.
        let lanes = unsafe { _mm_cvttps_epi32(v) };
        let [x, y, z, _]: [i32; 4] = bytemuck::cast(lanes);
        [x, y, z]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        v.to_array().map(|x| x as i32)
    }
}
