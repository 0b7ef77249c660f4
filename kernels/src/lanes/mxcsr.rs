//! Flush-to-zero and denormals-are-zero for foreign SIMD code, through the MXCSR register.
//!
//! Embree's tutorials set both modes on every thread that traces, because a denormal operand
//! slows an SSE/AVX instruction down by a hundred cycles or more. Rust code assumes the default
//! floating-point environment, so the modes are switched on only around a closure and restored
//! afterwards, even when the closure panics.

/// Runs `f` with the flush-to-zero (FTZ) and denormals-are-zero (DAZ) bits of this thread's
/// MXCSR set, then restores the register as it was.
///
/// Only this thread is affected: call it on every worker thread that runs the foreign code.
/// While `f` runs, every SSE/AVX result that would be denormal is 0 and every denormal input is
/// read as 0 (with the sign kept), in Rust code as in foreign code; copies are unaffected. So
/// `f` should do little more than move data and call the foreign library: float arithmetic
/// inside it may differ from the same arithmetic outside.
///
/// On targets other than x86-64 it just runs `f`. The register is restored when `f` unwinds.
#[inline]
pub fn with_flush_to_zero<R>(f: impl FnOnce() -> R) -> R {
    let _restore = imp::FlushToZero::enter();
    f()
}

#[cfg(target_arch = "x86_64")]
mod imp {
    use core::arch::asm;

    /// MXCSR bit 15: results that would be denormal are flushed to zero.
    const FTZ: u32 = 1 << 15;
    /// MXCSR bit 6: denormal operands are read as zero.
    const DAZ: u32 = 1 << 6;

    /// The MXCSR value to restore when dropped.
    pub(super) struct FlushToZero(u32);

    impl FlushToZero {
        /// Saves MXCSR and sets FTZ and DAZ.
        #[inline]
        pub(super) fn enter() -> Self {
            let saved = read();
            write(saved | FTZ | DAZ);
            FlushToZero(saved)
        }
    }

    impl Drop for FlushToZero {
        #[inline]
        fn drop(&mut self) {
            write(self.0);
        }
    }

    #[inline]
    fn read() -> u32 {
        let mut csr = 0u32;
        // SAFETY: `stmxcsr` stores the 4-byte MXCSR to the given address, which is a live,
        // writable, 4-byte aligned local; SSE (and so MXCSR) is part of the x86-64 baseline.
        unsafe {
            asm!("stmxcsr [{p}]", p = in(reg) &mut csr, options(nostack, preserves_flags));
        }
        csr
    }

    #[inline]
    fn write(csr: u32) {
        // SAFETY: `ldmxcsr` loads MXCSR from a live, 4-byte aligned local. The value is one read
        // from MXCSR, possibly with FTZ and DAZ added; every x86-64 CPU supports both bits (DAZ
        // is only missing from some 32-bit Pentium 4s), so no reserved bit is set and the
        // instruction cannot fault.
        unsafe {
            asm!("ldmxcsr [{p}]", p = in(reg) &csr, options(nostack, preserves_flags));
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    /// Nothing to save on this target.
    pub(super) struct FlushToZero;

    impl FlushToZero {
        /// Does nothing.
        #[inline]
        pub(super) fn enter() -> Self {
            FlushToZero
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::with_flush_to_zero;
    use core::hint::black_box;

    /// Half the smallest normal `f32` is denormal: exact without FTZ, 0 with it.
    fn half_smallest_normal() -> f32 {
        black_box(black_box(f32::MIN_POSITIVE) * black_box(0.5))
    }

    #[test]
    fn denormal_results_are_flushed_inside_and_kept_outside() {
        assert_eq!(half_smallest_normal(), f32::MIN_POSITIVE / 2.0);
        assert_eq!(with_flush_to_zero(half_smallest_normal), 0.0);
        assert_eq!(half_smallest_normal(), f32::MIN_POSITIVE / 2.0);
    }

    #[test]
    fn denormal_inputs_read_as_zero_inside() {
        let denormal = f32::from_bits(1);
        let doubled = || black_box(black_box(denormal) * black_box(2.0));
        assert_eq!(with_flush_to_zero(doubled), 0.0);
        assert_eq!(doubled(), f32::from_bits(2));
    }

    #[cfg(feature = "std")]
    #[test]
    fn mode_is_restored_after_a_panic() {
        let caught = std::panic::catch_unwind(|| with_flush_to_zero(|| panic!("inside")));
        assert!(caught.is_err());
        assert_eq!(half_smallest_normal(), f32::MIN_POSITIVE / 2.0);
    }
}
