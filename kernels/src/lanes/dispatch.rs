//! Running a [`LaneTask`] on an ISA chosen at run time.

#[cfg(target_arch = "x86_64")]
use super::{Avx, Sse};
use super::{Isa, LaneTask, Lanes, Portable, Scalar};

/// Runs `task` on `isa`: makes the token (detecting the CPU) and calls [`Lanes::run`].
///
/// Returns `None`, without running anything, when this CPU (or target) does not support `isa`.
/// [`Isa::Scalar`] and [`Isa::Portable`] always run.
///
/// ```
/// use kdbeam_kernels::lanes::run_on;
/// use kdbeam_kernels::{Isa, LaneF32, LaneTask, Lanes};
///
/// /// `2 · 3` in every lane, summed.
/// struct SumOfProducts;
///
/// impl LaneTask for SumOfProducts {
///     type Output = f32;
///     #[inline(always)]
///     fn run<L: Lanes>(self, l: L) -> f32 {
///         let v = l.splat(2.0) * l.splat(3.0);
///         (0..L::WIDTH).map(|i| v.extract(i)).sum()
///     }
/// }
///
/// assert_eq!(run_on(Isa::Scalar, SumOfProducts), Some(6.0));
/// let best = Isa::detect();
/// assert_eq!(run_on(best, SumOfProducts), Some(6.0 * best.width() as f32));
/// ```
pub fn run_on<T: LaneTask>(isa: Isa, task: T) -> Option<T::Output> {
    match isa {
        Isa::Scalar => Some(Scalar.run(task)),
        Isa::Portable => Some(Portable.run(task)),
        #[cfg(target_arch = "x86_64")]
        Isa::Sse => Sse::try_new().map(|l| l.run(task)),
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => Avx::try_new().map(|l| l.run(task)),
        #[cfg(not(target_arch = "x86_64"))]
        Isa::Sse | Isa::Avx2 => None,
    }
}
