//! Running a [`LaneTask`] on an ISA chosen at run time.

#[cfg(target_arch = "x86_64")]
use super::{Avx, Sse};
use super::{Isa, LaneTask, Lanes, Portable, Scalar};

/// Runs `task` on `isa`: makes the token (detecting the CPU) and calls [`Lanes::run`].
///
/// Returns `None`, without running anything, when this CPU (or target) does not support `isa`.
/// [`Isa::Scalar`] and [`Isa::Portable`] always run.
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
