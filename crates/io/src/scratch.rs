//! Scratch directories for tests (the readers' and writers' unit tests,
//! `tests/it`): removed when the test passes and kept when it fails (its
//! files are the evidence).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

/// A fresh, empty directory `coapt-{tag}-{pid}-{n}` under the system's
/// temporary directory, unique per call.
pub fn scratch(tag: &str) -> Scratch {
    Scratch::at(std::env::temp_dir().join(format!(
        "coapt-{tag}-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    )))
}

/// See [`scratch`].
pub struct Scratch(PathBuf);

impl Scratch {
    /// `dir` emptied (or made), to be removed when the test passes.
    pub fn at(dir: PathBuf) -> Scratch {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    pub fn as_path(&self) -> &Path {
        &self.0
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_passing_tests_scratch_is_removed() {
        let kept;
        {
            let d = scratch("scratch-self");
            std::fs::write(d.join("f"), b"x").unwrap();
            kept = d.to_path_buf();
            assert!(kept.join("f").exists());
        }
        assert!(!kept.exists());
    }

    #[test]
    fn a_failing_tests_scratch_is_kept() {
        let d = std::thread::spawn(|| {
            let d = scratch("scratch-kept");
            let p = d.to_path_buf();
            std::panic::panic_any(p);
        })
        .join()
        .unwrap_err()
        .downcast::<PathBuf>()
        .unwrap();
        assert!(d.exists());
        std::fs::remove_dir_all(*d).unwrap();
    }
}
