//! Cache prefetch hints.

/// Asks the CPU to start loading the cache line that holds the start of `value` into every
/// cache level, and returns at once. Only a hint: it changes no value, and a CPU may ignore it.
///
/// For loads whose addresses are known well before their data is needed, as when the kd-tree
/// build notes the triangles a split will clip and clips them afterwards. A no-op on targets
/// other than x86-64.
///
/// ```
/// let far = vec![7u32; 1 << 20];
/// kdbeam_kernels::lanes::prefetch(&far[1 << 19]);
/// assert_eq!(far[1 << 19], 7); // a hint changes nothing
/// ```
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: `prefetch` is SSE, part of the x86-64 baseline, and never faults: it reads
        // nothing into the program and the address comes from a live reference.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
