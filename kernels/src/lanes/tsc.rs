//! The time-stamp counter, for benchmarks that report cycles.

/// The CPU's time-stamp counter (`RDTSC`), or `None` on targets other than x86-64.
///
/// These are *reference* cycles: the counter ticks at a constant rate (the CPU's nominal
/// frequency on every x86-64 CPU of the last fifteen years), whatever the core's actual clock
/// under turbo or power saving, so one reference cycle is a fixed unit of wall time. `RDTSC` is
/// not serialising: instructions around it may be reordered across it by a few dozen cycles,
/// which is noise for intervals of millions of cycles and the wrong tool for shorter ones.
/// Readings on different cores are only comparable where the OS keeps the counters in sync
/// (Linux does on invariant-TSC CPUs).
#[inline]
#[must_use]
pub fn tsc() -> Option<u64> {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: RDTSC exists on every x86-64 CPU and has no preconditions.
        Some(unsafe { core::arch::x86_64::_rdtsc() })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        None
    }
}
