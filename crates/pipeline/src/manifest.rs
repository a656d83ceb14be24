//! `manifest.json`: per stage, what went in, what came out, with which
//! parameters and version, when and how long — and whether it ran or was
//! skipped, and why.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::provenance;
use coapt_base::{Error, Result};
use coapt_io::write_atomic;

pub const FILE_NAME: &str = "manifest.json";

/// A file and its content hash.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileRecord {
    /// Relative to the run directory when inside it, else absolute.
    pub path: String,
    pub blake3: String,
    pub bytes: u64,
    /// A DICOM input: the series read, beside the hash of its files (a
    /// folder's hash alone does not say which series of a study it was).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dicom_series: Option<SeriesRecord>,
}

/// The DICOM series an input was read from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SeriesRecord {
    pub series_instance_uid: String,
    pub series_number: Option<i64>,
    pub series_description: String,
    pub slices: usize,
    /// DICOM files hashed together into `blake3`.
    pub files: usize,
    /// How it was chosen among the folder's series.
    pub chosen: String,
}

impl FileRecord {
    pub fn of(path: &Path, run_dir: &Path) -> Result<FileRecord> {
        let (blake3, bytes) = provenance::hash_file(path)?;
        Ok(FileRecord {
            path: display_path(path, run_dir),
            blake3,
            bytes,
            dicom_series: None,
        })
    }

    /// As [`FileRecord::of`], but a volume header whose voxels live in a
    /// separate file (.nhdr, .mhd) is hashed together with that file, so a
    /// changed data file makes the stage run again; a DICOM series' files
    /// are hashed together, and the series named.
    pub fn of_input(path: &Path, run_dir: &Path) -> Result<FileRecord> {
        let (files, series) = coapt_io::volume_file::source(path);
        Self::of_source(path, run_dir, &files, series)
    }

    /// [`FileRecord::of_input`] from what [`coapt_io::volume_file::source`]
    /// found (so a caller that needs the files too scans a folder once).
    pub fn of_source(
        path: &Path,
        run_dir: &Path,
        files: &[PathBuf],
        series: Option<coapt_io::volume_file::SeriesSource>,
    ) -> Result<FileRecord> {
        let (blake3, bytes) = provenance::hash_files(files)?;
        Ok(FileRecord {
            path: display_path(path, run_dir),
            blake3,
            bytes,
            dicom_series: series.map(|s| SeriesRecord {
                series_instance_uid: s.uid,
                series_number: s.number,
                series_description: s.description,
                slices: s.slices,
                files: files.len(),
                chosen: s.chosen,
            }),
        })
    }
}

pub fn display_path(path: &Path, run_dir: &Path) -> String {
    let rel = path.strip_prefix(run_dir).ok().map(Path::to_path_buf);
    match rel {
        Some(r) => r.to_string_lossy().into_owned(),
        None => std::path::absolute(path)
            .unwrap_or_else(|_| path.to_path_buf())
            .to_string_lossy()
            .into_owned(),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    Ran,
    Skipped,
}

/// One stage's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageRecord {
    pub stage: String,
    pub status: Status,
    /// Why it ran (what changed) or why it was skipped.
    pub reason: String,
    pub inputs: BTreeMap<String, FileRecord>,
    pub outputs: BTreeMap<String, FileRecord>,
    /// Resolved parameters in canonical text ("25 HU").
    pub params: BTreeMap<String, String>,
    pub coapt_version: String,
    pub git_commit: Option<String>,
    pub command_line: Vec<String>,
    pub threads: usize,
    /// When the stage last ran (RFC 3339 UTC).
    pub started: String,
    pub seconds: f64,
    pub peak_rss_mb: Option<f64>,
    /// When a skip decision was last made, if the latest event was a skip.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checked: Option<String>,
    /// Stage-specific summary (counts, timings, findings).
    pub summary: serde_json::Value,
}

/// The whole run directory's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Manifest {
    pub coapt_version: String,
    pub git_commit: Option<String>,
    /// The run config, when the directory was made by `coapt run`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<FileRecord>,
    pub stages: Vec<StageRecord>,
}

impl Manifest {
    /// Load `dir/manifest.json`; a missing file is an empty manifest, an
    /// unreadable one is an error naming it (never silently overwritten).
    pub fn load(dir: &Path) -> Result<Manifest> {
        let path = dir.join(FILE_NAME);
        match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| {
                Error::bad_input(
                    &path,
                    format!("not a coapt manifest ({e}); delete it or use another run directory"),
                )
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Manifest::default()),
            Err(e) => Err(Error::read(&path, e)),
        }
    }

    pub fn stage(&self, name: &str) -> Option<&StageRecord> {
        self.stages.iter().find(|s| s.stage == name)
    }

    /// Insert or replace a stage's record, keeping `order` (chain order).
    pub fn put(&mut self, record: StageRecord, order: &[&str]) {
        self.stages.retain(|s| s.stage != record.stage);
        self.stages.push(record);
        let rank = |n: &str| order.iter().position(|o| *o == n).unwrap_or(usize::MAX);
        self.stages.sort_by_key(|s| rank(&s.stage));
    }

    pub fn save(&mut self, dir: &Path) -> Result<PathBuf> {
        self.coapt_version = provenance::version().to_string();
        self.git_commit = provenance::git_commit().map(str::to_string);
        let path = dir.join(FILE_NAME);
        let text = serde_json::to_string_pretty(self).expect("manifest serialises");
        write_atomic(&path, |w| {
            use std::io::Write;
            w.write_all(text.as_bytes())?;
            w.write_all(b"\n")
        })?;
        Ok(path)
    }
}
