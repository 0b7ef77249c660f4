//! Run-time ISA dispatch: one generic task, entered through the token of the ISA asked for.

#[cfg(target_arch = "x86_64")]
use kdbeam_kernels::lanes::{Avx, Sse};
use kdbeam_kernels::lanes::{Portable, Scalar};
use kdbeam_kernels::{Isa, LaneTask, Lanes};

/// Runs `task` on `isa`. An ISA this CPU lacks (which [`super::Tracer`] never passes: it checks
/// when the ISA is chosen) runs on [`Scalar`] rather than faulting.
#[inline]
pub(crate) fn run_on<T: LaneTask>(isa: Isa, task: T) -> T::Output {
    match isa {
        Isa::Scalar => Scalar.run(task),
        Isa::Portable => Portable.run(task),
        #[cfg(target_arch = "x86_64")]
        Isa::Sse => match Sse::try_new() {
            Some(sse) => sse.run(task),
            None => Scalar.run(task),
        },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => match Avx::try_new() {
            Some(avx) => avx.run(task),
            None => Scalar.run(task),
        },
        #[cfg(not(target_arch = "x86_64"))]
        Isa::Sse | Isa::Avx2 => Scalar.run(task),
    }
}
