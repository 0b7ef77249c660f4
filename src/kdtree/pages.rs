//! Large build buffers on transparent huge pages.
//!
//! A build writes most of its bytes (the triangle blocks above all) into memory it has just
//! allocated, and the first write to each 4 KiB page is a page fault in which the kernel clears
//! the page: on a large mesh, a large share of a fresh build's time. A buffer of at least
//! [`ADVISED_MIN_BYTES`] is therefore marked `MADV_HUGEPAGE` before it is written, so that a
//! Linux kernel whose transparent huge pages are in `madvise` or `always` mode backs it with
//! 2 MiB pages where it can: one fault where there were 512. Embree's allocator makes the same
//! request of its large allocations. Elsewhere, or where the kernel declines, nothing changes.
//! Only memory a reservation newly allocates is marked: a rebuild into buffers already large
//! enough makes no system call.

/// Buffers smaller than this are not marked: they hold no whole huge page, or few.
const ADVISED_MIN_BYTES: usize = 4 << 20;

/// Reserves room for at least `additional` more elements in `v` ([`Vec::reserve`]), and asks
/// for the room to be backed by huge pages when it is newly allocated and large.
pub(crate) fn reserve<T>(v: &mut Vec<T>, additional: usize) {
    let capacity = v.capacity();
    v.reserve(additional);
    if v.capacity() != capacity {
        advise_spare(v);
    }
}

/// [`reserve`] with [`Vec::reserve_exact`].
pub(crate) fn reserve_exact<T>(v: &mut Vec<T>, additional: usize) {
    let capacity = v.capacity();
    v.reserve_exact(additional);
    if v.capacity() != capacity {
        advise_spare(v);
    }
}

/// Replaces `out` with `len` copies of `zero`, written in parallel, so that every thread
/// faults in its share of the pages rather than the one that reads them next.
#[cfg(feature = "parallel")]
pub(crate) fn zeroed<T: Copy + Send + Sync>(out: &mut Vec<T>, len: usize, zero: T) {
    use rayon::prelude::*;
    out.clear();
    reserve(out, len);
    out.par_extend(rayon::iter::repeat_n(zero, len));
}

/// Marks the pages wholly inside `v`'s spare capacity `MADV_HUGEPAGE`, if there are
/// [`ADVISED_MIN_BYTES`] of it. The crate's only call into the system, hence its only `unsafe`.
#[allow(unsafe_code)]
fn advise_spare<T>(v: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        let spare = v.spare_capacity_mut();
        let bytes = std::mem::size_of_val(spare);
        if bytes < ADVISED_MIN_BYTES {
            return;
        }
        // SAFETY: `sysconf` reads a constant of the system.
        let page = usize::try_from(unsafe { libc::sysconf(libc::_SC_PAGESIZE) }).unwrap_or(0);
        if !page.is_power_of_two() {
            return;
        }
        let start = spare.as_mut_ptr() as usize;
        let (first, end) = (start.next_multiple_of(page), (start + bytes) & !(page - 1));
        if first < end {
            // SAFETY: `first..end` lies inside `v`'s allocation, which `v` owns and which
            // nothing else refers to while `v` is borrowed mutably; `MADV_HUGEPAGE` changes
            // only which pages the kernel backs it with, never its contents or its mapping. An
            // error (a kernel without transparent huge pages) leaves it as it was.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `VmFlags` of the mapping of `/proc/self/smaps` that holds `address`.
    #[cfg(target_os = "linux")]
    fn vm_flags_at(address: usize) -> Option<String> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            let range = line
                .split_whitespace()
                .next()
                .and_then(|r| r.split_once('-'));
            if let Some((lo, hi)) = range {
                if let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
                {
                    inside = (lo..hi).contains(&address);
                    continue;
                }
            }
            if let Some(flags) = line.strip_prefix("VmFlags:") {
                if inside {
                    return Some(flags.to_owned());
                }
            }
        }
        None
    }

    #[test]
    fn a_large_reservation_is_advised_and_reservations_keep_their_contents() {
        let mut large: Vec<u64> = Vec::new();
        reserve(&mut large, 4 * ADVISED_MIN_BYTES / 8);
        assert!(large.capacity() >= 4 * ADVISED_MIN_BYTES / 8);
        let mut small: Vec<u64> = vec![1, 2, 3];
        reserve_exact(&mut small, 10);
        assert_eq!((small.capacity(), &small[..]), (13, &[1, 2, 3][..]));
        #[cfg(target_os = "linux")]
        {
            if !std::path::Path::new("/sys/kernel/mm/transparent_hugepage/enabled").exists() {
                eprintln!("skipped the huge-page check: this kernel has no transparent huge pages");
                return;
            }
            // An address in the middle of the reservation, inside a whole advised page.
            let middle = large.spare_capacity_mut().as_ptr() as usize + 2 * ADVISED_MIN_BYTES;
            let flags = vm_flags_at(middle).expect("the reservation is mapped");
            assert!(
                flags.split_whitespace().any(|f| f == "hg"),
                "VmFlags:{flags}"
            );
        }
    }
}
