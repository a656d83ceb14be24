//! Facts about this run for the manifest: version, commit, time, memory, hashes.

use std::io::Read;
use std::path::Path;

use coapt_base::{Error, Result};

/// coapt's version.
pub fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

/// The git commit coapt was built from, when built from a checkout.
pub fn git_commit() -> Option<&'static str> {
    option_env!("COAPT_GIT_COMMIT").filter(|s| !s.is_empty())
}

/// Version and commit in one string, e.g. "0.1.0 (3a4e287c…)".
pub fn version_line() -> String {
    match git_commit() {
        Some(c) => format!("{} ({c})", version()),
        None => version().to_string(),
    }
}

/// blake3 of a file's content, hex.
pub fn hash_file(path: &Path) -> Result<(String, u64)> {
    hash_files(std::slice::from_ref(&path.to_path_buf()))
}

/// blake3 of the files' contents one after the other, hex, and their total
/// size; one file hashes as [`hash_file`].
pub fn hash_files(paths: &[std::path::PathBuf]) -> Result<(String, u64)> {
    let mut h = blake3::Hasher::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut n = 0u64;
    for path in paths {
        let mut f = std::fs::File::open(path).map_err(|e| Error::read(path, e))?;
        loop {
            let k = f.read(&mut buf).map_err(|e| Error::read(path, e))?;
            if k == 0 {
                break;
            }
            h.update(&buf[..k]);
            n += k as u64;
        }
    }
    Ok((h.finalize().to_hex().to_string(), n))
}

/// Where `coapt convert` records what `output` was made from:
/// `OUTPUT.provenance.json` beside it.
pub fn sidecar_path(output: &Path) -> std::path::PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    name.push(".provenance.json");
    output.with_file_name(name)
}

/// The record of a conversion (format `coapt-provenance/1`): coapt's
/// version, the input (its format, its files' hashes one by one and
/// together as the manifest hashes it, and for DICOM the series read), and
/// the output's hash. No time stamp, so converting the same input again
/// writes the same bytes. Paths as in the manifest: relative to the
/// output's folder when inside it, else absolute.
pub fn conversion(input: &Path, format: &str, output: &Path) -> Result<serde_json::Value> {
    use super::manifest::{FileRecord, display_path};
    let base = output.parent().unwrap_or(Path::new(""));
    let (files, series) = coapt_io::volume_file::source(input);
    let each = files
        .iter()
        .map(|f| {
            let r = FileRecord::of(f, base)?;
            Ok(serde_json::json!({"path": r.path, "blake3": r.blake3, "bytes": r.bytes}))
        })
        .collect::<Result<Vec<_>>>()?;
    let whole = FileRecord::of_source(input, base, &files, series)?;
    let out = FileRecord::of(output, base)?;
    Ok(serde_json::json!({
        "format": "coapt-provenance/1",
        "command": "convert",
        "coapt_version": version(),
        "git_commit": git_commit(),
        "input": {
            "path": display_path(input, base),
            "format": format,
            "blake3": whole.blake3,
            "bytes": whole.bytes,
            "dicom_series": whole.dicom_series,
            "files": each,
        },
        "output": {
            "path": out.path,
            "blake3": out.blake3,
            "bytes": out.bytes,
        },
    }))
}

/// Current UTC time as RFC 3339 ("2026-11-21T07:10:00Z").
pub fn now_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    format_utc(secs)
}

/// Seconds since the Unix epoch → RFC 3339 UTC (civil-from-days, Hinnant).
pub fn format_utc(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Peak resident memory of this process so far, MB (Linux; `None` elsewhere).
/// Start a new peak: Linux resets VmHWM to the current resident size when
/// "5" is written to clear_refs, so a stage run after a heavier one in the
/// same process records its own peak, not its predecessor's. Elsewhere (or
/// when refused: returns false) the peak stays the process's so far.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_memory_starts_again_after_a_reset() {
        {
            // Large enough for its own mapping, returned to the system on drop.
            let v = vec![1u8; 600 << 20];
            std::hint::black_box(&v);
        }
        let Some(high) = peak_rss_mb() else {
            return; // no /proc here: nothing to reset either
        };
        assert!(high > 600.0, "{high}");
        if reset_peak_rss() {
            let after = peak_rss_mb().unwrap();
            assert!(
                after < high - 300.0,
                "peak {high} MB, after reset {after} MB"
            );
        }
    }

    #[test]
    fn utc_formatting() {
        assert_eq!(format_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(format_utc(1_795_245_000), "2026-11-21T07:10:00Z");
    }
}
