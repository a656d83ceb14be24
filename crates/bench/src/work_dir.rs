//! A bench's scratch directory: the user's `--work DIR`, kept, or a fresh
//! one under the system's temporary directory, removed when the bench is
//! done with it, on every way out (an error returned half-way included).

use std::path::{Path, PathBuf};

pub struct WorkDir {
    path: PathBuf,
    temporary: bool,
}

impl WorkDir {
    /// `given`, else `<temp>/coapt-bench-<name>-<pid>`, emptied first.
    pub fn new(given: Option<&Path>, name: &str) -> WorkDir {
        match given {
            Some(p) => WorkDir {
                path: p.to_path_buf(),
                temporary: false,
            },
            None => {
                let path =
                    std::env::temp_dir().join(format!("coapt-bench-{name}-{}", std::process::id()));
                let _ = std::fs::remove_dir_all(&path);
                WorkDir {
                    path,
                    temporary: true,
                }
            }
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::WorkDir;

    #[test]
    fn a_temporary_work_dir_goes_and_a_given_one_stays() {
        let kept = std::env::temp_dir().join(format!("coapt-work-dir-kept-{}", std::process::id()));
        std::fs::create_dir_all(&kept).unwrap();
        let gone = {
            let t = WorkDir::new(None, "work-dir-test");
            std::fs::create_dir_all(t.path().join("sub")).unwrap();
            std::fs::write(t.path().join("sub/f"), b"x").unwrap();
            let g = WorkDir::new(Some(&kept), "unused");
            std::fs::write(g.path().join("f"), b"x").unwrap();
            t.path().to_path_buf()
        };
        assert!(!gone.exists(), "{} was left behind", gone.display());
        assert!(kept.join("f").exists(), "a given --work DIR was removed");
        std::fs::remove_dir_all(&kept).unwrap();
    }
}
