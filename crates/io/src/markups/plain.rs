//! Plain JSON landmarks: `{"coordinate_system": …, "points": …}`.

use std::io::Write;
use std::path::Path;

use serde::Serialize;
use serde_json::Value;

use super::{RawPoint, check_for_writing, finish, parse_frame, position3, read_json, show};
use crate::write_atomic;
use coapt_base::Result;
use coapt_geom::{Frame, Landmarks};

/// Read a plain JSON landmark file (list or object form); points in LPS.
pub fn read_plain_json(path: &Path) -> Result<Landmarks> {
    let root = read_json(path)?;
    finish(path, decode(&root))
}

/// Write `lm` in the list form, in LPS.
pub fn write_plain_json(path: &Path, lm: &Landmarks) -> Result<()> {
    check_for_writing(path, lm)?;
    let lps = lm.to_frame(Frame::Lps);
    let file = PlainFile {
        coordinate_system: Frame::Lps.name(),
        points: lps
            .points
            .iter()
            .map(|(label, p)| PlainPoint {
                label,
                position_mm: [p.x, p.y, p.z],
            })
            .collect(),
    };
    let mut text = serde_json::to_string_pretty(&file)
        .expect("serialising plain structs to memory cannot fail");
    text.push('\n');
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

#[derive(Serialize)]
struct PlainFile<'a> {
    coordinate_system: &'static str,
    points: Vec<PlainPoint<'a>>,
}

#[derive(Serialize)]
struct PlainPoint<'a> {
    label: &'a str,
    position_mm: [f64; 3],
}

/// Points of a plain landmark document, converted to LPS.
pub(super) fn decode(root: &Value) -> Result<Vec<RawPoint>, String> {
    let not_landmarks = || {
        "not a landmarks file: expected 3D Slicer markups (a \"markups\" list) or plain landmarks \
         ({\"coordinate_system\": \"LPS\", \"points\": [{\"label\": \"C1\", \"position_mm\": [x, y, z]}, …]})"
            .to_string()
    };
    let obj = root.as_object().ok_or_else(not_landmarks)?;
    let frame = match obj.get("coordinate_system") {
        None | Some(Value::Null) => Frame::Lps,
        Some(v) => parse_frame("coordinate_system", v)?,
    };
    let mut points = match obj.get("points") {
        Some(Value::Array(items)) => decode_list(items)?,
        Some(Value::Object(map)) => map
            .iter()
            .map(|(label, v)| raw_point(label.trim(), format!("point \"{label}\""), v))
            .collect::<Result<_, _>>()?,
        Some(v) => {
            return Err(format!(
                "\"points\" is {}, expected a list or an object",
                show(v)
            ));
        }
        None => return Err(not_landmarks()),
    };
    for p in &mut points {
        p.lps = frame.convert(Frame::Lps, p.lps);
    }
    Ok(points)
}

fn decode_list(items: &[Value]) -> Result<Vec<RawPoint>, String> {
    items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            let origin = format!("point {} of \"points\"", i + 1);
            let label = match item.get("label") {
                Some(Value::String(s)) => s.trim(),
                _ => return Err(format!("{origin} has no \"label\" string: write {{\"label\": \"C1\", \"position_mm\": [x, y, z]}}")),
            };
            let pos = item.get("position_mm").ok_or_else(|| {
                format!("{origin} ('{label}') has no \"position_mm\": write {{\"label\": \"{label}\", \"position_mm\": [x, y, z]}}")
            })?;
            raw_point(label, origin, pos)
        })
        .collect()
}

/// A point in the file's frame (converted by the caller).
fn raw_point(label: &str, origin: String, pos: &Value) -> Result<RawPoint, String> {
    if label.is_empty() {
        return Err(format!(
            "{origin} has an empty label: name it (C1, C2, C3, N1, N2, N3)"
        ));
    }
    let lps = position3(&format!("control point '{label}'"), pos)?;
    Ok(RawPoint {
        label: label.to_string(),
        lps,
        origin,
    })
}
