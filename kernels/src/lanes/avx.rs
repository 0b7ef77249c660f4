//! Eight lanes of `__m256`, AVX2 + FMA.

use core::arch::x86_64::*;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

use super::proof::proven;
use super::sse::{reduce_max128, reduce_min128};
use super::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// The AVX2 + FMA token: eight `f32` lanes in an `__m256`.
///
/// It can only be made by [`Avx::try_new`] (run-time detection) or [`Avx::new_unchecked`] (a
/// promise), so holding one proves the CPU runs AVX2 and FMA.
#[derive(Clone, Copy, Debug)]
pub struct Avx {
    _proof: (),
}

impl Avx {
    /// The token, if this CPU supports AVX2 and FMA (and POPCNT, LZCNT, BMI1 and BMI2, which
    /// every such CPU has).
    #[cfg(feature = "std")]
    #[inline]
    #[must_use]
    pub fn try_new() -> Option<Self> {
        Isa::Avx2.is_available().then_some(Avx { _proof: () })
    }

    /// The token, without checking the CPU.
    ///
    /// # Safety
    ///
    /// The CPU running the program must support AVX2, FMA, POPCNT, LZCNT, BMI1 and BMI2: every
    /// operation made through this token executes such instructions.
    #[must_use]
    pub const unsafe fn new_unchecked() -> Self {
        Avx { _proof: () }
    }
}

/// Eight `f32` lanes of an `__m256`. Made only through an [`Avx`] token.
#[derive(Clone, Copy, Debug)]
pub struct AvxF32(__m256);

/// Eight lanes of an `__m256` comparison result: each lane all ones (set) or all zeros (clear).
/// Made only through an [`Avx`] token or by comparing [`AvxF32`]s.
#[derive(Clone, Copy, Debug)]
pub struct AvxMask(__m256);

/// Eight `u32` counters in an `__m256i`. Made only through an [`Avx`] token.
#[derive(Clone, Copy, Debug)]
pub struct AvxCount(__m256i);

/// The `#[target_feature]` entry point: `task` and everything it inlines compile for AVX2 + FMA
/// (256-bit `ymm` instructions, VEX encoding, `vfmadd`) and the bit instructions (POPCNT, LZCNT,
/// BMI1, BMI2).
///
/// # Safety
///
/// The CPU must support AVX2, FMA and the bit instructions (an [`Avx`] token proves it).
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
unsafe fn enter_avx2_fma<T: LaneTask>(lanes: Avx, task: T) -> T::Output {
    task.run(lanes)
}

// Every method below is a safe function that calls AVX, AVX2 or FMA intrinsics through `proven!`:
// sound because an `Avx`, `AvxF32` or `AvxMask` can only exist after an `Avx` token was made.

impl Lanes for Avx {
    const WIDTH: usize = 8;
    const ISA: Isa = Isa::Avx2;
    type F32 = AvxF32;
    type Mask = AvxMask;
    type Count = AvxCount;
    type UpTo8 = Avx;

    #[inline(always)]
    fn splat(self, x: f32) -> AvxF32 {
        AvxF32(proven!(_mm256_set1_ps(x)))
    }
    #[inline(always)]
    fn load(self, src: &[f32]) -> AvxF32 {
        let src = &src[..8];
        // SAFETY: the token proves AVX; `src` holds 8 `f32`s and `loadu` needs no alignment.
        AvxF32(unsafe { _mm256_loadu_ps(src.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, v: AvxF32, dst: &mut [f32]) {
        let dst = &mut dst[..8];
        // SAFETY: the token proves AVX; `dst` holds 8 `f32`s and `storeu` needs no alignment.
        unsafe { _mm256_storeu_ps(dst.as_mut_ptr(), v.0) }
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> AvxMask {
        AvxMask(proven!({
            let lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bit);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bit))
        }))
    }
    #[inline(always)]
    fn zero_counts(self) -> AvxCount {
        AvxCount(proven!(_mm256_setzero_si256()))
    }
    #[inline(always)]
    fn up_to_8(self) -> Self {
        self
    }
    #[inline(always)]
    fn run<T: LaneTask>(self, task: T) -> T::Output {
        // SAFETY: `self` exists, so the CPU supports AVX2 and FMA.
        unsafe { enter_avx2_fma(self, task) }
    }
}

impl Add for AvxF32 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_add_ps(self.0, o.0)))
    }
}

impl Sub for AvxF32 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_sub_ps(self.0, o.0)))
    }
}

impl Mul for AvxF32 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_mul_ps(self.0, o.0)))
    }
}

impl Div for AvxF32 {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_div_ps(self.0, o.0)))
    }
}

impl Neg for AvxF32 {
    type Output = Self;
    /// Flips the sign bit (so `-(+0) = -0` and NaN stays NaN), as scalar negation does.
    #[inline(always)]
    fn neg(self) -> Self {
        AvxF32(proven!(_mm256_xor_ps(self.0, _mm256_set1_ps(-0.0))))
    }
}

impl LaneF32 for AvxF32 {
    type Mask = AvxMask;

    /// `self * a + b` **fused** (`vfmadd`): one rounding, so it may differ from the other ISAs in
    /// the last bit (and is exact where they overflow or cancel).
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        AvxF32(proven!(_mm256_fmadd_ps(self.0, a.0, b.0)))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_min_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        AvxF32(proven!(_mm256_max_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        AvxF32(proven!(_mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn le(self, o: Self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn is_nan(self) -> AvxMask {
        AvxMask(proven!(_mm256_cmp_ps::<_CMP_UNORD_Q>(self.0, self.0)))
    }
    #[inline(always)]
    fn masked(self, m: AvxMask) -> Self {
        AvxF32(proven!(_mm256_and_ps(m.0, self.0)))
    }
    #[inline(always)]
    fn select(m: AvxMask, a: Self, b: Self) -> Self {
        AvxF32(proven!(_mm256_blendv_ps(b.0, a.0, m.0)))
    }
    #[inline(always)]
    fn extract(self, i: usize) -> f32 {
        bytemuck::cast::<__m256, [f32; 8]>(self.0)[i]
    }
    /// Smallest non-NaN lane; when the smallest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        let halves = proven!({
            let lo = _mm256_castps256_ps128(self.0);
            // Each half first replaces its own NaN lanes, so `minps` never sees a NaN here.
            let hi = _mm256_extractf128_ps::<1>(self.0);
            let inf = _mm_set1_ps(f32::INFINITY);
            _mm_min_ps(_mm_min_ps(lo, inf), _mm_min_ps(hi, inf))
        });
        reduce_min128(halves)
    }
    /// Largest non-NaN lane; when the largest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        let halves = proven!({
            let lo = _mm256_castps256_ps128(self.0);
            let hi = _mm256_extractf128_ps::<1>(self.0);
            let ninf = _mm_set1_ps(f32::NEG_INFINITY);
            _mm_max_ps(_mm_max_ps(lo, ninf), _mm_max_ps(hi, ninf))
        });
        reduce_max128(halves)
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        proven!(_mm256_movemask_ps(self.0)) as u32
    }
}

impl LaneCount for AvxCount {
    type Mask = AvxMask;
    type F32 = AvxF32;

    #[inline(always)]
    fn add_set(self, m: AvxMask) -> Self {
        AvxCount(proven!(_mm256_sub_epi32(self.0, _mm256_castps_si256(m.0))))
    }
    #[inline(always)]
    fn to_f32(self) -> AvxF32 {
        AvxF32(proven!(_mm256_cvtepi32_ps(self.0)))
    }
}

impl BitAnd for AvxMask {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        AvxMask(proven!(_mm256_and_ps(self.0, o.0)))
    }
}

impl BitOr for AvxMask {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        AvxMask(proven!(_mm256_or_ps(self.0, o.0)))
    }
}

impl BitXor for AvxMask {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, o: Self) -> Self {
        AvxMask(proven!(_mm256_xor_ps(self.0, o.0)))
    }
}

impl Not for AvxMask {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        let ones = proven!(_mm256_castsi256_ps(_mm256_set1_epi32(-1)));
        AvxMask(proven!(_mm256_xor_ps(self.0, ones)))
    }
}

impl LaneMask for AvxMask {
    #[inline(always)]
    fn bits(self) -> u32 {
        proven!(_mm256_movemask_ps(self.0)) as u32
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        AvxMask(proven!(_mm256_andnot_ps(o.0, self.0)))
    }
}
