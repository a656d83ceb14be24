//! A hint to back large fresh buffers with 2 MiB pages.
//!
//! A CT's isosurface fills tens of MB of fresh memory; on 4 KiB pages the
//! kernel takes one fault per page (thousands per extraction, a fifth of its
//! time, and they do not get faster with a second thread). Where transparent
//! huge pages are in "madvise" mode they are used only for ranges that ask.

use std::mem::MaybeUninit;

/// Huge-page size on x86-64 and the usual arm64 configuration.
const HUGE: usize = 2 << 20;

/// Ask for huge pages under the whole 2 MiB pages of `buf`, before its first
/// touch. Only a hint: on failure or elsewhere than Linux nothing changes,
/// and the contents are never affected.
pub(super) fn advise_huge_pages<T>(buf: &mut [MaybeUninit<T>]) {
    let start = buf.as_mut_ptr() as usize;
    let end = start + std::mem::size_of_val(buf);
    let (lo, hi) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
    if hi > lo {
        madvise_hugepage(lo, hi - lo);
    }
}

#[cfg(target_os = "linux")]
fn madvise_hugepage(addr: usize, len: usize) {
    unsafe extern "C" {
        fn madvise(addr: *mut std::ffi::c_void, len: usize, advice: i32) -> i32;
    }
    const MADV_HUGEPAGE: i32 = 14;
    // SAFETY: [addr, addr + len) lies inside one live allocation we hold
    // mutably, page-aligned; MADV_HUGEPAGE only changes how later faults are
    // served, never the memory's contents. The result is ignored: a refused
    // hint leaves ordinary pages.
    unsafe {
        madvise(addr as *mut std::ffi::c_void, len, MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn madvise_hugepage(_addr: usize, _len: usize) {}
