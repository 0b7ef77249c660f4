//! One lane of plain `f32`: the reference implementation of [`Lanes`].

use super::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// The scalar ISA: `F32 = f32`, `Mask = bool`. Always available.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scalar;

impl Lanes for Scalar {
    const WIDTH: usize = 1;
    const ISA: Isa = Isa::Scalar;
    type F32 = f32;
    type Mask = bool;
    type Count = u32;
    type UpTo8 = Scalar;

    #[inline(always)]
    fn splat(self, x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn load(self, src: &[f32]) -> f32 {
        src[0]
    }
    #[inline(always)]
    fn store(self, v: f32, dst: &mut [f32]) {
        dst[0] = v;
    }
    #[inline(always)]
    fn mask_from_bits(self, bits: u32) -> bool {
        bits & 1 != 0
    }
    #[inline(always)]
    fn zero_counts(self) -> u32 {
        0
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

impl LaneCount for u32 {
    type Mask = bool;
    type F32 = f32;

    #[inline(always)]
    fn add_set(self, m: bool) -> u32 {
        self.wrapping_add(u32::from(m))
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as i32 as f32
    }
}

impl LaneF32 for f32 {
    type Mask = bool;

    #[inline(always)]
    fn mul_add(self, a: f32, b: f32) -> f32 {
        // Two roundings, as on every ISA without FMA (and `libm`-free in `no_std`).
        self * a + b
    }
    #[inline(always)]
    fn min(self, o: f32) -> f32 {
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::from_bits(self.to_bits() & 0x7fff_ffff)
    }
    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn is_nan(self) -> bool {
        self.is_nan()
    }
    #[inline(always)]
    fn masked(self, m: bool) -> f32 {
        if m {
            self
        } else {
            0.0
        }
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn extract(self, i: usize) -> f32 {
        assert!(i == 0, "lane index out of range");
        self
    }
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        if self.is_nan() {
            f32::INFINITY
        } else {
            self
        }
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        if self.is_nan() {
            f32::NEG_INFINITY
        } else {
            self
        }
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        self.is_sign_negative() as u32
    }
}

impl LaneMask for bool {
    #[inline(always)]
    fn bits(self) -> u32 {
        self as u32
    }
}
