//! A per-process scratch file: the readers take paths (they pick the format
//! and a detached header's data file by name), so each input is written to
//! a file in memory-backed /dev/shm under the name the reader expects.

use std::path::PathBuf;

pub fn file(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("coapt-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("scratch file");
    p
}
