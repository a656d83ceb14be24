//! Per-process scratch files: the readers take paths (they pick the format
//! and a detached header's data file by name), so each input is written to
//! a file under the name the reader expects.

use std::path::PathBuf;

fn root() -> PathBuf {
    std::env::temp_dir().join(format!("coapt-fuzz-{}", std::process::id()))
}

pub fn file(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = root();
    let _ = std::fs::create_dir_all(&dir);
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("scratch file");
    p
}

/// An empty directory of this name (emptied if an earlier input left files).
#[allow(dead_code)]
pub fn dir(name: &str) -> PathBuf {
    let d = root().join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}
