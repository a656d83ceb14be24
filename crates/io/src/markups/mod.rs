//! Landmark files: 3D Slicer Markups JSON, legacy Slicer `.fcsv`, plain JSON.
//!
//! Every reader returns the points in LPS millimetres (`frame = Lps`), in file
//! order, checked by [`Landmarks::sanity_check`]. Labels are trimmed and
//! matched exactly; whether C1–C3 are present is the caller's business
//! ([`Landmarks::require`]). Writers are atomic and print floats in shortest
//! round-trip form, so write → read gives back the same bits (LPS ↔ RAS is a
//! sign flip, which is exact too).
//!
//! # 3D Slicer Markups JSON (`.mrk.json`)
//! Schema 1.0.3 as written by Slicer 4.11–5.x. Control points are taken from
//! every point-list markup (`"type": "Fiducial"`); other markup types (lines,
//! curves, planes…) are ignored. Per markup, `coordinateSystem` is `"LPS"`
//! (also when absent: Slicer's default) or `"RAS"`, case-insensitive, and
//! `coordinateUnits` is absent or `"mm"`. Control points whose
//! `positionStatus` is `"undefined"`, `"missing"` or `"preview"`, or that have
//! no `position`, are skipped (Slicer keeps placeholders for unplaced points).
//!
//! # Legacy `.fcsv`
//! `#` lines are headers. `# CoordinateSystem = 0 | 1 | RAS | LPS` (0 = RAS,
//! 1 = LPS; 2 = IJK is refused); without that line the file is RAS, as Slicer
//! ≤ 4.10 wrote it. `# columns = …` gives the column order; without it the
//! order is `id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID`.
//! Data lines are CSV; a field containing commas is quoted (`""` inside quotes
//! is a literal quote).
//!
//! # Plain JSON (any other `.json` without a `"markups"` key)
//! ```json
//! {"coordinate_system": "LPS",
//!  "points": [{"label": "C1", "position_mm": [12.5, -3.0, 40.25]}, …]}
//! ```
//! or, shorter, with labels as keys (read back in label order):
//! ```json
//! {"coordinate_system": "LPS", "points": {"C1": [12.5, -3.0, 40.25], …}}
//! ```
//! `coordinate_system` is `"LPS"` or `"RAS"`, `"LPS"` when absent; units are mm.
//! [`write_plain_json`] writes the list form, in LPS.

mod fcsv;
mod mrk_json;
mod plain;

#[cfg(test)]
mod tests;

use std::path::Path;

use serde_json::Value;

use coapt_base::{Error, Result};
use coapt_geom::{Frame, Landmarks, Point3};

pub use fcsv::{read_fcsv, write_fcsv};
pub use mrk_json::{encode_mrk_json, encode_mrk_json_described, read_mrk_json, write_mrk_json};
pub use plain::{read_plain_json, write_plain_json};

/// Read a landmark file, choosing the format from the name: `.mrk.json` →
/// Slicer markups, `.fcsv` → legacy Slicer, other `.json` → Slicer markups if
/// it has a `"markups"` key, plain JSON otherwise.
pub fn read(path: &Path) -> Result<Landmarks> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if name.ends_with(".mrk.json") {
        read_mrk_json(path)
    } else if name.ends_with(".fcsv") {
        read_fcsv(path)
    } else if name.ends_with(".json") {
        let root = read_json(path)?;
        let points = if root.get("markups").is_some() {
            mrk_json::decode(&root)
        } else {
            plain::decode(&root)
        };
        finish(path, points)
    } else {
        Err(Error::bad_input(
            path,
            "unknown landmark file type: name it .mrk.json (3D Slicer markups), \
             .fcsv (legacy Slicer) or .json (plain landmarks)",
        ))
    }
}

/// One point as found in a file; `lps` holds LPS once its decoder returns.
#[derive(Debug)]
struct RawPoint {
    label: String,
    lps: [f64; 3],
    /// Where it came from ("markup 1, control point 3", "line 7"), for messages.
    origin: String,
}

fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    // Slicer on Windows may write a byte-order mark.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
    String::from_utf8(bytes.to_vec()).map_err(|e| {
        Error::bad_input(
            path,
            format!("not UTF-8 text ({e}): re-save the file as UTF-8"),
        )
    })
}

fn read_json(path: &Path) -> Result<Value> {
    // serde_json is built with `float_roundtrip`, so numbers read back exactly.
    let text = read_text(path)?;
    serde_json::from_str(&text).map_err(|e| {
        // Some tools write NaN/Infinity, which JSON does not have; say so.
        let hint = if text.contains("NaN")
            || text.contains("Infinity")
            || e.to_string().contains("out of range")
        {
            " (JSON has no NaN or Infinity: every coordinate must be a finite number)"
        } else {
            ""
        };
        Error::bad_input(path, format!("malformed JSON: {e}{hint}"))
    })
}

/// Turn decoded points into checked LPS landmarks, naming `path` in any error.
fn finish(path: &Path, points: Result<Vec<RawPoint>, String>) -> Result<Landmarks> {
    let points = points.map_err(|m| Error::bad_input(path, m))?;
    for (i, p) in points.iter().enumerate() {
        if let Some(first) = points[..i].iter().find(|q| q.label == p.label) {
            return Err(Error::bad_input(
                path,
                format!(
                    "duplicate label '{}' ({} and {}): landmark labels must be unique; rename or delete one",
                    p.label, first.origin, p.origin
                ),
            ));
        }
    }
    let mut lm = Landmarks::new(Frame::Lps);
    for p in points {
        lm.push(p.label, Point3::from(p.lps));
    }
    lm.sanity_check().map_err(|e| e.in_file(path))?;
    Ok(lm)
}

/// `v` as three finite numbers; `who` names the point in the message.
fn position3(who: &str, v: &Value) -> Result<[f64; 3], String> {
    let nums: Option<Vec<f64>> = v
        .as_array()
        .and_then(|a| a.iter().map(Value::as_f64).collect());
    match nums {
        None => Err(format!(
            "{who}: position {} is not three numbers: write it as [x, y, z] in mm",
            show(v)
        )),
        Some(n) if n.len() != 3 => Err(format!(
            "{who}: position {} has {} numbers, expected three: write it as [x, y, z] in mm",
            show(v),
            n.len()
        )),
        Some(n) => finite3(who, &show(v), [n[0], n[1], n[2]]),
    }
}

/// Farther from the scanner's origin than this (mm) no patient lies: a point
/// ×1e300 was read, and then judged as an anatomy ("N1 and N2 both lie
/// between C3 and C1").
pub const MAX_COORDINATE_MM: f64 = 1e5;

fn finite3(who: &str, shown: &str, p: [f64; 3]) -> Result<[f64; 3], String> {
    if p.iter()
        .all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE_MM)
    {
        Ok(p)
    } else if p.iter().all(|c| c.is_finite()) {
        Err(format!(
            "{who}: position {shown} lies more than {} m from the scanner's origin: coordinates are in mm",
            MAX_COORDINATE_MM / 1000.0
        ))
    } else {
        Err(format!(
            "{who}: position {shown} has a non-finite coordinate: every coordinate must be a finite number of mm"
        ))
    }
}

/// A JSON value as a person would write it (`[1.0, "abc", 3]`), cut if long.
fn show(v: &Value) -> String {
    let s = match v {
        Value::Array(a) => format!("[{}]", a.iter().map(show).collect::<Vec<_>>().join(", ")),
        other => other.to_string(),
    };
    if s.chars().count() > 80 {
        format!("{}…", s.chars().take(80).collect::<String>())
    } else {
        s
    }
}

/// "control point 'C2'" or, for a point without a usable label, its place.
fn describe(label: &str, origin: &str) -> String {
    if label.is_empty() {
        origin.to_string()
    } else {
        format!("control point '{label}'")
    }
}

/// Parse a coordinate-system name from a file.
fn parse_frame(what: &str, v: &Value) -> Result<Frame, String> {
    v.as_str().and_then(Frame::parse).ok_or_else(|| {
        format!(
            "{what}: unknown coordinate system {}: expected \"LPS\" or \"RAS\"",
            show(v)
        )
    })
}

/// Refuse (rather than mis-read) a landmark set that cannot be written faithfully.
fn check_for_writing(path: &Path, lm: &Landmarks) -> Result<()> {
    lm.sanity_check().map_err(|e| match e {
        Error::Value(m) => Error::usage(format!("{}: refusing to write: {m}", path.display())),
        other => other,
    })
}
