//! Four lanes of `wide::f32x4`, for targets other than x86-64 (NEON, wasm simd128).
//!
//! `wide` picks its backend at compile time from the build target's features, so this path needs
//! no detection. Every operation is spelled so that it means the same as [`Scalar`] on every
//! backend, instead of relying on `wide`'s own `min`/`max`/`mul_add`, whose NaN and fusing
//! behaviour depends on the backend.
//!
//! [`Scalar`]: super::Scalar

use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

use wide::{f32x4, i32x4, CmpEq, CmpGe, CmpGt, CmpLe, CmpLt};

use super::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// The portable token: four `f32` lanes in a `wide::f32x4`. Always available.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Portable;

/// Four `f32` lanes of a `wide::f32x4`.
#[derive(Clone, Copy, Debug)]
pub struct PortableF32(f32x4);

/// Four lanes of a comparison result: each lane all ones (set) or all zeros (clear).
#[derive(Clone, Copy, Debug)]
pub struct PortableMask(f32x4);

/// Four `u32` counters in a `wide::i32x4`.
#[derive(Clone, Copy, Debug)]
pub struct PortableCount(i32x4);

/// A lane with every bit set (a NaN bit pattern, only ever used as a mask).
const ONES: f32 = f32::from_bits(u32::MAX);

impl Lanes for Portable {
    const WIDTH: usize = 4;
    const ISA: Isa = Isa::Portable;
    type F32 = PortableF32;
    type Mask = PortableMask;
    type Count = PortableCount;
    type UpTo8 = Portable;

    #[inline(always)]
    fn splat(self, x: f32) -> PortableF32 {
        PortableF32(f32x4::splat(x))
    }
    #[inline(always)]
    fn load(self, src: &[f32]) -> PortableF32 {
        let s = &src[..4];
        PortableF32(f32x4::new([s[0], s[1], s[2], s[3]]))
    }
    #[inline(always)]
    fn store(self, v: PortableF32, dst: &mut [f32]) {
        dst[..4].copy_from_slice(&v.0.to_array());
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> PortableMask {
        let lane = |i: u32| if bits >> i & 1 != 0 { ONES } else { 0.0 };
        PortableMask(f32x4::new([lane(0), lane(1), lane(2), lane(3)]))
    }
    #[inline(always)]
    fn zero_counts(self) -> PortableCount {
        PortableCount(i32x4::splat(0))
    }
    #[inline(always)]
    fn up_to_8(self) -> Self {
        self
    }
    #[inline(always)]
    fn run<T: LaneTask>(self, task: T) -> T::Output {
        task.run(self)
    }
}

impl LaneCount for PortableCount {
    type Mask = PortableMask;
    type F32 = PortableF32;

    #[inline(always)]
    fn add_set(self, m: PortableMask) -> Self {
        // A set lane is all ones: −1 as an integer.
        PortableCount(self.0 - bytemuck::cast::<f32x4, i32x4>(m.0))
    }
    #[inline(always)]
    fn to_f32(self) -> PortableF32 {
        PortableF32(self.0.round_float())
    }
}

impl Add for PortableF32 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        PortableF32(self.0 + o.0)
    }
}

impl Sub for PortableF32 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        PortableF32(self.0 - o.0)
    }
}

impl Mul for PortableF32 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        PortableF32(self.0 * o.0)
    }
}

impl Div for PortableF32 {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        PortableF32(self.0 / o.0)
    }
}

impl Neg for PortableF32 {
    type Output = Self;
    /// Flips the sign bit (so `-(+0) = -0` and NaN stays NaN), as scalar negation does.
    #[inline(always)]
    fn neg(self) -> Self {
        PortableF32(self.0 ^ f32x4::splat(-0.0))
    }
}

impl LaneF32 for PortableF32 {
    type Mask = PortableMask;

    /// `self * a + b` with two roundings on every backend (never fused, unlike `wide`'s).
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Self::select(self.lt(o), self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Self::select(self.gt(o), self, o)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        PortableF32(self.0 & f32x4::splat(f32::from_bits(0x7fff_ffff)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> PortableMask {
        PortableMask(self.0.cmp_lt(o.0))
    }
    #[inline(always)]
    fn le(self, o: Self) -> PortableMask {
        PortableMask(self.0.cmp_le(o.0))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> PortableMask {
        PortableMask(self.0.cmp_gt(o.0))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> PortableMask {
        PortableMask(self.0.cmp_ge(o.0))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> PortableMask {
        PortableMask(self.0.cmp_eq(o.0))
    }
    #[inline(always)]
    fn is_nan(self) -> PortableMask {
        // Only NaN is unequal to itself.
        !PortableMask(self.0.cmp_eq(self.0))
    }
    #[inline(always)]
    fn masked(self, m: PortableMask) -> Self {
        PortableF32(m.0 & self.0)
    }
    #[inline(always)]
    fn select(m: PortableMask, a: Self, b: Self) -> Self {
        PortableF32(m.0.blend(a.0, b.0))
    }
    #[inline(always)]
    fn extract(self, i: usize) -> f32 {
        self.0.to_array()[i]
    }
    /// Smallest non-NaN lane; of zeros of both signs, the lowest lane's.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        self.0
            .to_array()
            .into_iter()
            .fold(f32::INFINITY, |m, x| if x < m { x } else { m })
    }
    /// Largest non-NaN lane; of zeros of both signs, the lowest lane's.
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        self.0
            .to_array()
            .into_iter()
            .fold(f32::NEG_INFINITY, |m, x| if x > m { x } else { m })
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        self.0.move_mask() as u32
    }
}

impl BitAnd for PortableMask {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        PortableMask(self.0 & o.0)
    }
}

impl BitOr for PortableMask {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        PortableMask(self.0 | o.0)
    }
}

impl BitXor for PortableMask {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, o: Self) -> Self {
        PortableMask(self.0 ^ o.0)
    }
}

impl Not for PortableMask {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        PortableMask(self.0 ^ f32x4::splat(ONES))
    }
}

impl LaneMask for PortableMask {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.0.move_mask() as u32
    }
}
