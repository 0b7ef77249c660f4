//! Four lanes of `__m128`, SSE4.1.

use core::arch::x86_64::*;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

use super::proof::proven;
use super::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// The SSE4.1 token: four `f32` lanes in an `__m128`.
///
/// It can only be made by [`Sse::try_new`] (run-time detection) or [`Sse::new_unchecked`] (a
/// promise), so holding one proves the CPU runs SSE4.1.
#[derive(Clone, Copy, Debug)]
pub struct Sse {
    _proof: (),
}

impl Sse {
    /// The token, if this CPU supports SSE4.1.
    #[cfg(feature = "std")]
    #[inline]
    #[must_use]
    pub fn try_new() -> Option<Self> {
        Isa::Sse.is_available().then_some(Sse { _proof: () })
    }

    /// The token, without checking the CPU.
    ///
    /// # Safety
    ///
    /// The CPU running the program must support SSE4.1: every vector operation made through this
    /// token executes SSE4.1 instructions.
    #[must_use]
    pub const unsafe fn new_unchecked() -> Self {
        Sse { _proof: () }
    }
}

/// Four `f32` lanes of an `__m128`. Made only through an [`Sse`] token.
#[derive(Clone, Copy, Debug)]
pub struct SseF32(__m128);

/// Four lanes of an `__m128` comparison result: each lane all ones (set) or all zeros (clear).
/// Made only through an [`Sse`] token or by comparing [`SseF32`]s.
#[derive(Clone, Copy, Debug)]
pub struct SseMask(__m128);

/// Four `u32` counters in an `__m128i`. Made only through an [`Sse`] token.
#[derive(Clone, Copy, Debug)]
pub struct SseCount(__m128i);

/// The `#[target_feature]` entry point: `task` and everything it inlines compile for SSE4.1.
///
/// # Safety
///
/// The CPU must support SSE4.1 (an [`Sse`] token proves it).
#[target_feature(enable = "sse4.1")]
unsafe fn enter_sse41<T: LaneTask>(lanes: Sse, task: T) -> T::Output {
    task.run(lanes)
}

impl Lanes for Sse {
    const WIDTH: usize = 4;
    const ISA: Isa = Isa::Sse;
    type F32 = SseF32;
    type Mask = SseMask;
    type Count = SseCount;
    type UpTo8 = Sse;

    #[inline(always)]
    fn splat(self, x: f32) -> SseF32 {
        SseF32(proven!(_mm_set1_ps(x)))
    }
    #[inline(always)]
    fn load(self, src: &[f32]) -> SseF32 {
        let src = &src[..4];
        // SAFETY: `src` holds 4 `f32`s; `loadu` has no alignment requirement.
        SseF32(unsafe { _mm_loadu_ps(src.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, v: SseF32, dst: &mut [f32]) {
        let dst = &mut dst[..4];
        // SAFETY: `dst` holds 4 `f32`s; `storeu` has no alignment requirement.
        unsafe { _mm_storeu_ps(dst.as_mut_ptr(), v.0) }
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> SseMask {
        SseMask(proven!({
            let lane_bit = _mm_setr_epi32(1, 2, 4, 8);
            let set = _mm_and_si128(_mm_set1_epi32(bits as i32), lane_bit);
            _mm_castsi128_ps(_mm_cmpeq_epi32(set, lane_bit))
        }))
    }
    #[inline(always)]
    fn zero_counts(self) -> SseCount {
        SseCount(proven!(_mm_setzero_si128()))
    }
    #[inline(always)]
    fn up_to_8(self) -> Self {
        self
    }
    #[inline(always)]
    fn run<T: LaneTask>(self, task: T) -> T::Output {
        // SAFETY: `self` exists, so the CPU supports SSE4.1.
        unsafe { enter_sse41(self, task) }
    }
}

/// All bits of every lane set.
#[inline(always)]
fn ones128() -> __m128 {
    // SAFETY: SSE2 is part of the x86-64 baseline: every x86-64 CPU runs it.
    unsafe { _mm_castsi128_ps(_mm_set1_epi32(-1)) }
}

/// Smallest lane, NaN lanes ignored. `minps(v, +inf)` turns NaN lanes into `+inf` (`minps`
/// returns its second operand when either is NaN); the rest is a min-tree.
#[inline(always)]
pub(super) fn reduce_min128(v: __m128) -> f32 {
    // SAFETY: SSE is part of the x86-64 baseline: every x86-64 CPU runs it.
    unsafe {
        let v = _mm_min_ps(v, _mm_set1_ps(f32::INFINITY));
        let v = _mm_min_ps(v, _mm_movehl_ps(v, v));
        _mm_cvtss_f32(_mm_min_ps(v, _mm_shuffle_ps::<0b01>(v, v)))
    }
}

/// Largest lane, NaN lanes ignored; see [`reduce_min128`].
#[inline(always)]
pub(super) fn reduce_max128(v: __m128) -> f32 {
    // SAFETY: SSE is part of the x86-64 baseline: every x86-64 CPU runs it.
    unsafe {
        let v = _mm_max_ps(v, _mm_set1_ps(f32::NEG_INFINITY));
        let v = _mm_max_ps(v, _mm_movehl_ps(v, v));
        _mm_cvtss_f32(_mm_max_ps(v, _mm_shuffle_ps::<0b01>(v, v)))
    }
}

// The operator impls below are safe functions that call SSE4.1 intrinsics through `proven!`: sound
// because an `SseF32` or `SseMask` can only exist after an `Sse` token was made.

impl Add for SseF32 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        SseF32(proven!(_mm_add_ps(self.0, o.0)))
    }
}

impl Sub for SseF32 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        SseF32(proven!(_mm_sub_ps(self.0, o.0)))
    }
}

impl Mul for SseF32 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        SseF32(proven!(_mm_mul_ps(self.0, o.0)))
    }
}

impl Div for SseF32 {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        SseF32(proven!(_mm_div_ps(self.0, o.0)))
    }
}

impl Neg for SseF32 {
    type Output = Self;
    /// Flips the sign bit (so `-(+0) = -0` and NaN stays NaN), as scalar negation does.
    #[inline(always)]
    fn neg(self) -> Self {
        SseF32(proven!(_mm_xor_ps(self.0, _mm_set1_ps(-0.0))))
    }
}

impl LaneF32 for SseF32 {
    type Mask = SseMask;

    /// `self * a + b` with two roundings (SSE4.1 has no FMA).
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        SseF32(proven!(_mm_min_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        SseF32(proven!(_mm_max_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        SseF32(proven!(_mm_andnot_ps(_mm_set1_ps(-0.0), self.0)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> SseMask {
        SseMask(proven!(_mm_cmplt_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn le(self, o: Self) -> SseMask {
        SseMask(proven!(_mm_cmple_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> SseMask {
        SseMask(proven!(_mm_cmpgt_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> SseMask {
        SseMask(proven!(_mm_cmpge_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> SseMask {
        SseMask(proven!(_mm_cmpeq_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn is_nan(self) -> SseMask {
        SseMask(proven!(_mm_cmpunord_ps(self.0, self.0)))
    }
    #[inline(always)]
    fn masked(self, m: SseMask) -> Self {
        SseF32(proven!(_mm_and_ps(m.0, self.0)))
    }
    #[inline(always)]
    fn select(m: SseMask, a: Self, b: Self) -> Self {
        SseF32(proven!(_mm_blendv_ps(b.0, a.0, m.0)))
    }
    #[inline(always)]
    fn extract(self, i: usize) -> f32 {
        bytemuck::cast::<__m128, [f32; 4]>(self.0)[i]
    }
    /// Smallest non-NaN lane; when the smallest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        reduce_min128(self.0)
    }
    /// Largest non-NaN lane; when the largest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        reduce_max128(self.0)
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        proven!(_mm_movemask_ps(self.0)) as u32
    }
}

impl LaneCount for SseCount {
    type Mask = SseMask;
    type F32 = SseF32;

    #[inline(always)]
    fn add_set(self, m: SseMask) -> Self {
        SseCount(proven!(_mm_sub_epi32(self.0, _mm_castps_si128(m.0))))
    }
    #[inline(always)]
    fn to_f32(self) -> SseF32 {
        SseF32(proven!(_mm_cvtepi32_ps(self.0)))
    }
}

impl BitAnd for SseMask {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        SseMask(proven!(_mm_and_ps(self.0, o.0)))
    }
}

impl BitOr for SseMask {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        SseMask(proven!(_mm_or_ps(self.0, o.0)))
    }
}

impl BitXor for SseMask {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, o: Self) -> Self {
        SseMask(proven!(_mm_xor_ps(self.0, o.0)))
    }
}

impl Not for SseMask {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        SseMask(proven!(_mm_xor_ps(self.0, ones128())))
    }
}

impl LaneMask for SseMask {
    #[inline(always)]
    fn bits(self) -> u32 {
        proven!(_mm_movemask_ps(self.0)) as u32
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        SseMask(proven!(_mm_andnot_ps(o.0, self.0)))
    }
}
