//! SIMD lanes: the one place in kdbeam that touches `std::arch`.
//!
//! A [`Lanes`] value is a zero-sized *token* that proves the CPU supports an instruction set:
//! [`Scalar`] and [`Portable`] always exist, [`Sse`] (SSE4.1), [`Avx`] (AVX2 + FMA) and
//! [`Avx512`] (AVX-512F/BW/DQ/VL) only after run-time detection (or an `unsafe` promise).
//! Vectors ([`Lanes::F32`]) and masks ([`Lanes::Mask`]) can only be made through a token, so
//! holding one is proof that its instructions may run; that is what makes their safe operator
//! impls sound.
//!
//! Kernels are written once, generic over `L: Lanes`, and marked `#[inline(always)]`. A kernel is
//! instantiated per ISA by [`Lanes::run`], which enters a `#[target_feature]` function and calls a
//! [`LaneTask`] inside it: everything inlined there is compiled for that ISA, whatever the build
//! flags (this is how Embree instantiates one templated kernel per width and ISA, and how the
//! memchr crate dispatches at run time). [`Dispatch`] is an ISA checked once, on which tasks then
//! run without asking the CPU again.

use core::fmt::Debug;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

#[cfg(target_arch = "x86_64")]
mod avx;
#[cfg(target_arch = "x86_64")]
mod avx512;
mod dispatch;
mod isa;
mod mxcsr;
mod portable;
mod prefetch;
#[cfg(target_arch = "x86_64")]
mod proof;
mod scalar;
#[cfg(target_arch = "x86_64")]
mod sse;
mod truncate;
mod tsc;

#[cfg(target_arch = "x86_64")]
pub use avx::{Avx, AvxCount, AvxF32, AvxMask};
#[cfg(target_arch = "x86_64")]
pub use avx512::{Avx512, Avx512Count, Avx512F32, Avx512Mask};
pub use dispatch::{Dispatch, IsaError};
pub use isa::{Isa, ParseIsaError};
pub use mxcsr::with_flush_to_zero;
pub use portable::{Portable, PortableCount, PortableF32, PortableMask};
pub use prefetch::prefetch;
pub use scalar::Scalar;
#[cfg(target_arch = "x86_64")]
pub use sse::{Sse, SseCount, SseF32, SseMask};
pub use truncate::truncate_to_i32;
pub use tsc::tsc;

/// The widest [`Lanes::WIDTH`] of any ISA ([`Isa::Avx512`]'s 16): buffers that every ISA reads
/// in whole vectors are padded to a multiple of it.
pub const MAX_WIDTH: usize = 16;

/// An instruction set and width, as a token that proves the CPU supports it.
///
/// Every method is `#[inline(always)]` in every implementation, so that generic kernels compile
/// to the ISA of the `#[target_feature]` function they are inlined into.
pub trait Lanes: Copy + Debug + Send + Sync + 'static {
    /// Number of `f32` lanes in [`Self::F32`].
    const WIDTH: usize;
    /// Which instruction set this is.
    const ISA: Isa;
    /// A vector of `WIDTH` `f32` lanes.
    type F32: LaneF32<Mask = Self::Mask>;
    /// A vector of `WIDTH` booleans, as produced by comparisons.
    type Mask: LaneMask;
    /// A vector of `WIDTH` counters of set mask lanes.
    type Count: LaneCount<Mask = Self::Mask, F32 = Self::F32>;
    /// The widest lanes of this CPU with at most 8 of them, for data laid out 8 wide (the
    /// children of a wide kd-tree node): `Self` up to 8 lanes, AVX2 under AVX-512.
    type UpTo8: Lanes;

    /// All lanes equal to `x`.
    fn splat(self, x: f32) -> Self::F32;
    /// Lanes `src[0..WIDTH]`. Panics if `src.len() < WIDTH`.
    fn load(self, src: &[f32]) -> Self::F32;
    /// Writes the lanes to `dst[0..WIDTH]`. Panics if `dst.len() < WIDTH`.
    fn store(self, v: Self::F32, dst: &mut [f32]);
    /// Mask whose lane `i` is set when bit `i` of `bits` is; bits at or above `WIDTH` are ignored.
    fn mask_from_bits(self, bits: u32) -> Self::Mask;
    /// Counters at zero in every lane.
    fn zero_counts(self) -> Self::Count;
    /// The token of [`Lanes::UpTo8`], which holding `self` proves the CPU runs.
    fn up_to_8(self) -> Self::UpTo8;
    /// Runs `task` compiled for this ISA (inside a `#[target_feature]` function where needed).
    fn run<T: LaneTask>(self, task: T) -> T::Output;
}

/// A computation generic over the lanes, run per ISA by [`Lanes::run`].
///
/// Implementations must mark `run` `#[inline(always)]`, and so must every generic kernel it calls:
/// code that is not inlined into the `#[target_feature]` entry point is compiled for the baseline
/// ISA and calls each intrinsic out of line.
pub trait LaneTask {
    /// What the task returns.
    type Output;
    /// Runs the task on `lanes`.
    fn run<L: Lanes>(self, lanes: L) -> Self::Output;
}

/// A vector of `f32` lanes. Arithmetic is IEEE 754 per lane, never fused unless
/// [`LaneF32::mul_add`] is called.
pub trait LaneF32:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The mask type comparisons produce.
    type Mask: LaneMask;

    /// `self * a + b`: one rounding where the ISA has FMA (AVX2 + FMA, AVX-512), two elsewhere.
    ///
    /// Never use it where two computations must round identically on every ISA (the watertight
    /// edge functions of two triangles sharing an edge).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// Lane-wise `if self < o { self } else { o }`: returns `o` when either is NaN (x86 `minps`).
    fn min(self, o: Self) -> Self;
    /// Lane-wise `if self > o { self } else { o }`: returns `o` when either is NaN (x86 `maxps`).
    fn max(self, o: Self) -> Self;
    /// Lane-wise absolute value (clears the sign bit, so NaN stays NaN).
    fn abs(self) -> Self;
    /// Ordered `<` (false when either lane is NaN).
    fn lt(self, o: Self) -> Self::Mask;
    /// Ordered `<=`.
    fn le(self, o: Self) -> Self::Mask;
    /// Ordered `>`.
    fn gt(self, o: Self) -> Self::Mask;
    /// Ordered `>=`.
    fn ge(self, o: Self) -> Self::Mask;
    /// Ordered `==`.
    fn eq(self, o: Self) -> Self::Mask;
    /// Lanes that are NaN.
    fn is_nan(self) -> Self::Mask;
    /// Lane-wise `if m { a } else { b }`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Lane-wise `if m { self } else { +0.0 }`: one `and` on x86 where [`LaneF32::select`] is a
    /// blend (summing `one.masked(m)` counts the set lanes).
    fn masked(self, m: Self::Mask) -> Self;
    /// Lane `i`. Panics if `i >= WIDTH`.
    fn extract(self, i: usize) -> f32;
    /// Smallest lane, ignoring NaN lanes (`+inf` when every lane is NaN).
    fn reduce_min(self) -> f32;
    /// Largest lane, ignoring NaN lanes (`-inf` when every lane is NaN).
    fn reduce_max(self) -> f32;
    /// Bit `i` set when lane `i` has its sign bit set: negative numbers, `-0.0`, `-inf` and
    /// NaNs with the sign bit (x86 `movemask` on the floats themselves).
    fn sign_bits(self) -> u32;
}

/// A vector of `WIDTH` integer counters, one per lane, for counting the set lanes of many masks
/// (as the kd-tree build counts the boxes on each side of 8 planes at once).
pub trait LaneCount: Copy + Debug {
    /// The masks it counts.
    type Mask: LaneMask;
    /// The vector its counts convert to.
    type F32: LaneF32<Mask = Self::Mask>;

    /// Adds 1 to each lane where `m` is set (wrapping at 2³²): one integer subtraction on x86,
    /// where a set lane is all ones, −1.
    fn add_set(self, m: Self::Mask) -> Self;
    /// The counts as `f32` (exact up to 2²⁴; beyond, rounded to nearest as `i32 as f32`).
    fn to_f32(self) -> Self::F32;
}

/// A vector of booleans, one per lane. `!m` only sets the `WIDTH` real lanes.
pub trait LaneMask:
    Copy
    + Debug
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
{
    /// Bit `i` set when lane `i` is (x86 `movemask`).
    fn bits(self) -> u32;
    /// Is any lane set?
    #[inline(always)]
    fn any(self) -> bool {
        self.bits() != 0
    }
    /// Is no lane set?
    #[inline(always)]
    fn none(self) -> bool {
        self.bits() == 0
    }
    /// `self & !o`, in one instruction where the ISA has it.
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        self & !o
    }
}
