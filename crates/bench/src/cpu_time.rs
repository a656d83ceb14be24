//! CPU time of the calling thread, for benchmarks on shared machines.

/// CPU seconds the calling thread has run. In a one-thread pool the worker
/// does all the work, so this is the work's cost whatever else the machine
/// runs (wall time on a shared machine includes the other processes' turns).
#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
pub fn thread_cpu_s() -> Option<f64> {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec in the 64-bit Linux layout
    // (time_t and long are both 64 bits), and the clock id is a constant the
    // kernel defines.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.sec as f64 + ts.nsec as f64 * 1e-9)
}

#[cfg(not(all(target_os = "linux", target_pointer_width = "64")))]
pub fn thread_cpu_s() -> Option<f64> {
    None
}
