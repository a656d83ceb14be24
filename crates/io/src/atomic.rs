//! Atomic output: every artifact is written to a temporary file in its own
//! directory and renamed into place only when complete, so a failed or
//! interrupted stage never leaves a half-written artifact behind.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use coapt_base::{Error, Result};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A set of outputs written to temporary files and renamed together by
/// [`Transaction::commit`]. Dropping an uncommitted transaction (on error or
/// panic) deletes its temporary files.
#[derive(Debug, Default)]
pub struct Transaction {
    staged: Vec<(PathBuf, PathBuf)>,
}

impl Transaction {
    pub fn new() -> Self {
        Self::default()
    }

    /// Write `path`'s future content through `fill` into a temporary sibling.
    pub fn write<F>(&mut self, path: &Path, fill: F) -> Result<()>
    where
        F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
    {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(|e| Error::write(path, e))?;
        let name = path
            .file_name()
            .ok_or_else(|| Error::usage(format!("{}: not a file name", path.display())))?;
        let tmp = dir.join(format!(
            ".{}.tmp-{}-{}",
            name.to_string_lossy(),
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        // Register first so the temp file is removed even if writing fails.
        self.staged.push((tmp.clone(), path.to_path_buf()));
        let file = File::create(&tmp).map_err(|e| Error::write(path, e))?;
        let mut w = BufWriter::with_capacity(1 << 20, file);
        fill(&mut w).map_err(|e| Error::write(path, e))?;
        w.flush().map_err(|e| Error::write(path, e))?;
        w.get_ref().sync_all().map_err(|e| Error::write(path, e))?;
        Ok(())
    }

    /// Removes the temporaries a killed run of coapt left beside `path`
    /// (`.NAME.tmp-PID-N` of a process that no longer runs; only where
    /// /proc tells which do). Returns how many went.
    pub fn remove_stale(path: &Path) -> usize {
        let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else {
            return 0;
        };
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        let proc = Path::new("/proc/self");
        if !proc.exists() {
            return 0;
        }
        let prefix = format!(".{}.tmp-", name.to_string_lossy());
        let Ok(entries) = std::fs::read_dir(dir) else {
            return 0;
        };
        let mut n = 0;
        for e in entries.flatten() {
            let f = e.file_name().to_string_lossy().into_owned();
            let Some(rest) = f.strip_prefix(&prefix) else {
                continue;
            };
            let Some((pid, count)) = rest.split_once('-') else {
                continue;
            };
            let (Ok(pid), Ok(_)) = (pid.parse::<u32>(), count.parse::<u64>()) else {
                continue;
            };
            if !Path::new("/proc").join(pid.to_string()).exists()
                && std::fs::remove_file(e.path()).is_ok()
            {
                n += 1;
            }
        }
        n
    }

    /// Write bytes already in memory.
    pub fn write_bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.write(path, |w| w.write_all(bytes))
    }

    /// Paths this transaction will create.
    pub fn targets(&self) -> impl Iterator<Item = &Path> {
        self.staged.iter().map(|(_, p)| p.as_path())
    }

    /// Rename every staged file into place.
    pub fn commit(mut self) -> Result<()> {
        let staged = std::mem::take(&mut self.staged);
        for (i, (tmp, path)) in staged.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                for (t, _) in &staged[i..] {
                    let _ = std::fs::remove_file(t);
                }
                return Err(Error::write(path, e));
            }
        }
        Ok(())
    }
}

impl Drop for Transaction {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Write one file atomically.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    let mut t = Transaction::new();
    t.write(path, fill)?;
    t.commit()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scratch::{Scratch, scratch};

    fn tmpdir(tag: &str) -> Scratch {
        scratch(&format!("atomic-{tag}"))
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let d = tmpdir("fail");
        let p = d.join("out.bin");
        let r = write_atomic(&p, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    }

    #[test]
    fn transaction_all_or_nothing() {
        let d = tmpdir("tx");
        {
            let mut t = Transaction::new();
            t.write_bytes(&d.join("a"), b"A").unwrap();
            t.write_bytes(&d.join("b"), b"B").unwrap();
            // dropped without commit
        }
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        let mut t = Transaction::new();
        t.write_bytes(&d.join("a"), b"A").unwrap();
        t.write_bytes(&d.join("sub/b"), b"B").unwrap();
        t.commit().unwrap();
        assert_eq!(std::fs::read(d.join("a")).unwrap(), b"A");
        assert_eq!(std::fs::read(d.join("sub/b")).unwrap(), b"B");
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2);
    }
}
