fn main() {
    default_sigpipe();
    std::process::exit(coapt::cli::main());
}

/// Rust starts with SIGPIPE ignored, so `coapt info mesh.vtp | head` would
/// panic printing to the closed pipe; a command-line tool should stop
/// quietly there, as cat and grep do.
#[cfg(unix)]
fn default_sigpipe() {
    unsafe extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13;
    const SIG_DFL: usize = 0;
    // SAFETY: restoring the default disposition of one signal, before any
    // thread exists; no handler code of ours is involved.
    unsafe {
        signal(SIGPIPE, SIG_DFL);
    }
}

#[cfg(not(unix))]
fn default_sigpipe() {}
