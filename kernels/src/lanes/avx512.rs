//! Sixteen lanes of `__m512`, AVX-512F/BW/DQ/VL, with masks in `__mmask16` registers.

use core::arch::x86_64::*;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

use super::avx::Avx;
use super::proof::proven;
use super::sse::{reduce_max128, reduce_min128};
use super::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// The AVX-512 token: sixteen `f32` lanes in an `__m512`, comparison results in an `__mmask16`.
///
/// It can only be made by [`Avx512::try_new`] (run-time detection) or
/// [`Avx512::new_unchecked`] (a promise), so holding one proves the CPU runs AVX-512F, BW, DQ
/// and VL (and AVX2, FMA, POPCNT, LZCNT, BMI1 and BMI2, which every such CPU has).
#[derive(Clone, Copy, Debug)]
pub struct Avx512 {
    _proof: (),
}

impl Avx512 {
    /// The token, if this CPU supports AVX-512F/BW/DQ/VL and the AVX2 token's features.
    #[cfg(feature = "std")]
    #[inline]
    pub fn try_new() -> Option<Self> {
        Isa::Avx512.is_available().then_some(Avx512 { _proof: () })
    }

    /// The token, without checking the CPU.
    ///
    /// # Safety
    ///
    /// The CPU running the program must support AVX-512F, AVX-512BW, AVX-512DQ, AVX-512VL, AVX2,
    /// FMA, POPCNT, LZCNT, BMI1 and BMI2: every operation made through this token executes such
    /// instructions.
    pub const unsafe fn new_unchecked() -> Self {
        Avx512 { _proof: () }
    }
}

/// Sixteen `f32` lanes of an `__m512`. Made only through an [`Avx512`] token.
#[derive(Clone, Copy, Debug)]
pub struct Avx512F32(__m512);

/// Sixteen lanes of a comparison result, one bit each in an `__mmask16`. Made only through an
/// [`Avx512`] token or by comparing [`Avx512F32`]s.
#[derive(Clone, Copy, Debug)]
pub struct Avx512Mask(__mmask16);

/// Sixteen `u32` counters in an `__m512i`. Made only through an [`Avx512`] token.
#[derive(Clone, Copy, Debug)]
pub struct Avx512Count(__m512i);

/// The `#[target_feature]` entry point: `task` and everything it inlines compile for AVX-512
/// (512-bit `zmm` instructions, EVEX encoding, mask registers, `vfmadd`).
///
/// # Safety
///
/// The CPU must support AVX-512F/BW/DQ/VL, AVX2, FMA and the bit instructions (an [`Avx512`]
/// token proves it).
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2,avx512f,avx512bw,avx512dq,avx512vl")]
unsafe fn enter_avx512<T: LaneTask>(lanes: Avx512, task: T) -> T::Output {
    task.run(lanes)
}

// Every method below is a safe function that calls AVX-512 (or AVX, FMA) intrinsics through
// `proven!`: sound because an `Avx512`, `Avx512F32`, `Avx512Mask` or `Avx512Count` can only exist
// after an `Avx512` token was made.

impl Lanes for Avx512 {
    const WIDTH: usize = 16;
    const ISA: Isa = Isa::Avx512;
    type F32 = Avx512F32;
    type Mask = Avx512Mask;
    type Count = Avx512Count;
    type UpTo8 = Avx;

    #[inline(always)]
    fn splat(self, x: f32) -> Avx512F32 {
        Avx512F32(proven!(_mm512_set1_ps(x)))
    }
    #[inline(always)]
    fn load(self, src: &[f32]) -> Avx512F32 {
        let src = &src[..16];
        // SAFETY: the token proves AVX-512F; `src` holds 16 `f32`s and `loadu` needs no
        // alignment.
        Avx512F32(unsafe { _mm512_loadu_ps(src.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, v: Avx512F32, dst: &mut [f32]) {
        let dst = &mut dst[..16];
        // SAFETY: the token proves AVX-512F; `dst` holds 16 `f32`s and `storeu` needs no
        // alignment.
        unsafe { _mm512_storeu_ps(dst.as_mut_ptr(), v.0) }
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> Avx512Mask {
        // The truncation drops the bits at or above `WIDTH`.
        Avx512Mask(bits as __mmask16)
    }
    #[inline(always)]
    fn zero_counts(self) -> Avx512Count {
        Avx512Count(proven!(_mm512_setzero_si512()))
    }
    #[inline(always)]
    fn up_to_8(self) -> Avx {
        // SAFETY: `self` exists, so the CPU supports AVX2 and FMA, all an `Avx` promises.
        unsafe { Avx::new_unchecked() }
    }
    #[inline(always)]
    fn run<T: LaneTask>(self, task: T) -> T::Output {
        // SAFETY: `self` exists, so the CPU supports AVX-512F/BW/DQ/VL, AVX2 and FMA.
        unsafe { enter_avx512(self, task) }
    }
}

impl Add for Avx512F32 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_add_ps(self.0, o.0)))
    }
}

impl Sub for Avx512F32 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_sub_ps(self.0, o.0)))
    }
}

impl Mul for Avx512F32 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_mul_ps(self.0, o.0)))
    }
}

impl Div for Avx512F32 {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_div_ps(self.0, o.0)))
    }
}

impl Neg for Avx512F32 {
    type Output = Self;
    /// Flips the sign bit (so `-(+0) = -0` and NaN stays NaN), as scalar negation does.
    #[inline(always)]
    fn neg(self) -> Self {
        Avx512F32(proven!(_mm512_xor_ps(self.0, _mm512_set1_ps(-0.0))))
    }
}

impl LaneF32 for Avx512F32 {
    type Mask = Avx512Mask;

    /// `self * a + b` **fused** (`vfmadd`): one rounding, so it may differ from the non-FMA ISAs
    /// in the last bit (and is exact where they overflow or cancel).
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        Avx512F32(proven!(_mm512_fmadd_ps(self.0, a.0, b.0)))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_min_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Avx512F32(proven!(_mm512_max_ps(self.0, o.0)))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Avx512F32(proven!(_mm512_andnot_ps(_mm512_set1_ps(-0.0), self.0)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn le(self, o: Self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0)))
    }
    #[inline(always)]
    fn is_nan(self) -> Avx512Mask {
        Avx512Mask(proven!(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0)))
    }
    /// One zero-masking move: clear lanes become `+0.0`.
    #[inline(always)]
    fn masked(self, m: Avx512Mask) -> Self {
        Avx512F32(proven!(_mm512_maskz_mov_ps(m.0, self.0)))
    }
    #[inline(always)]
    fn select(m: Avx512Mask, a: Self, b: Self) -> Self {
        Avx512F32(proven!(_mm512_mask_blend_ps(m.0, b.0, a.0)))
    }
    #[inline(always)]
    fn extract(self, i: usize) -> f32 {
        bytemuck::cast::<[__m256; 2], [f32; 16]>(halves(self.0))[i]
    }
    /// Smallest non-NaN lane; when the smallest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        let quarters = proven!({
            // Each half first replaces its own NaN lanes, so `minps` never sees a NaN here.
            let inf = _mm256_set1_ps(f32::INFINITY);
            let [lo, hi] = halves(self.0);
            let v = _mm256_min_ps(_mm256_min_ps(lo, inf), _mm256_min_ps(hi, inf));
            _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v))
        });
        reduce_min128(quarters)
    }
    /// Largest non-NaN lane; when the largest value is a zero of both signs, which one is
    /// returned depends on the lane order.
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        let quarters = proven!({
            let ninf = _mm256_set1_ps(f32::NEG_INFINITY);
            let [lo, hi] = halves(self.0);
            let v = _mm256_max_ps(_mm256_max_ps(lo, ninf), _mm256_max_ps(hi, ninf));
            _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v))
        });
        reduce_max128(quarters)
    }
    /// `vpmovd2m` on the floats' bits: AVX-512 has no `movemask` for `zmm` registers.
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        u32::from(proven!(_mm512_movepi32_mask(_mm512_castps_si512(self.0))))
    }
}

/// The low and high eight lanes of `v`.
#[inline(always)]
fn halves(v: __m512) -> [__m256; 2] {
    // SAFETY: only called on an `Avx512F32`'s vector, which exists only after an `Avx512` token
    // proved AVX-512F and DQ; no pointer is involved.
    unsafe { [_mm512_castps512_ps256(v), _mm512_extractf32x8_ps::<1>(v)] }
}

impl LaneCount for Avx512Count {
    type Mask = Avx512Mask;
    type F32 = Avx512F32;

    /// One masked integer add of 1.
    #[inline(always)]
    fn add_set(self, m: Avx512Mask) -> Self {
        Avx512Count(proven!(_mm512_mask_add_epi32(
            self.0,
            m.0,
            self.0,
            _mm512_set1_epi32(1)
        )))
    }
    #[inline(always)]
    fn to_f32(self) -> Avx512F32 {
        Avx512F32(proven!(_mm512_cvtepi32_ps(self.0)))
    }
}

// A mask is sixteen bits: its operators are integer operations, which the compiler keeps in
// mask registers (`kandw`, `korw`, ...) or general ones as it sees fit.

impl BitAnd for Avx512Mask {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        Avx512Mask(self.0 & o.0)
    }
}

impl BitOr for Avx512Mask {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        Avx512Mask(self.0 | o.0)
    }
}

impl BitXor for Avx512Mask {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, o: Self) -> Self {
        Avx512Mask(self.0 ^ o.0)
    }
}

impl Not for Avx512Mask {
    type Output = Self;
    /// All sixteen bits of `__mmask16` are lanes, so `!` sets exactly the `WIDTH` lanes.
    #[inline(always)]
    fn not(self) -> Self {
        Avx512Mask(!self.0)
    }
}

impl LaneMask for Avx512Mask {
    #[inline(always)]
    fn bits(self) -> u32 {
        u32::from(self.0)
    }
}
