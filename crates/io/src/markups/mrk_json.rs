//! 3D Slicer Markups JSON (`.mrk.json`, schema 1.0.3).

use std::io::Write;
use std::path::Path;

use serde::Serialize;
use serde_json::Value;

use super::{
    RawPoint, check_for_writing, describe, finish, parse_frame, position3, read_json, show,
};
use crate::write_atomic;
use coapt_base::Result;
use coapt_geom::{Frame, Landmarks};

pub(super) const SCHEMA: &str = "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#";

/// Read a Slicer markups file; points from every point-list markup, in LPS.
pub fn read_mrk_json(path: &Path) -> Result<Landmarks> {
    let root = read_json(path)?;
    finish(path, decode(&root))
}

/// Write `lm` as one Slicer point list with coordinates in `frame`.
pub fn write_mrk_json(path: &Path, lm: &Landmarks, frame: Frame) -> Result<()> {
    check_for_writing(path, lm)?;
    let text = encode_mrk_json(lm, frame);
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// The file text for `lm` in `frame`. Non-finite coordinates would become
/// `null` (JSON has no NaN): check with `sanity_check` first, as the writer does.
pub fn encode_mrk_json(lm: &Landmarks, frame: Frame) -> String {
    encode_mrk_json_described(lm, frame, |_| String::new())
}

/// As [`encode_mrk_json`], each point with the description `describe`
/// gives its label (3D Slicer shows it beside the point; readers here
/// ignore it).
pub fn encode_mrk_json_described(
    lm: &Landmarks,
    frame: Frame,
    describe: impl Fn(&str) -> String,
) -> String {
    let lm = lm.to_frame(frame);
    let control_points = lm
        .points
        .iter()
        .enumerate()
        .map(|(i, (label, p))| ControlPoint {
            id: (i + 1).to_string(),
            label: label.clone(),
            description: describe(label),
            associated_node_id: String::new(),
            position: [p.x, p.y, p.z],
            orientation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            selected: true,
            locked: false,
            visibility: true,
            position_status: "defined",
        })
        .collect();
    let file = MrkFile {
        schema: SCHEMA,
        markups: vec![Markup {
            kind: "Fiducial",
            coordinate_system: frame.name(),
            coordinate_units: "mm",
            locked: false,
            fixed_number_of_control_points: false,
            label_format: "%N-%d",
            last_used_control_point_number: lm.points.len(),
            control_points,
            measurements: Vec::new(),
            display: Display::default(),
        }],
    };
    // Slicer indents with four spaces; keep files diff-friendly against its own.
    let mut out = Vec::new();
    let fmt = serde_json::ser::PrettyFormatter::with_indent(b"    ");
    let mut ser = serde_json::Serializer::with_formatter(&mut out, fmt);
    file.serialize(&mut ser)
        .expect("serialising plain structs to memory cannot fail");
    let mut text = String::from_utf8(out).expect("serde_json writes UTF-8");
    text.push('\n');
    text
}

/// Points of every point-list markup in `root`, converted to LPS.
pub(super) fn decode(root: &Value) -> Result<Vec<RawPoint>, String> {
    let markups = root
        .get("markups")
        .and_then(Value::as_array)
        .ok_or_else(|| {
            "not a 3D Slicer markups file: expected an object with a \"markups\" list \
         (save the point list from Slicer as .mrk.json)"
                .to_string()
        })?;
    let mut points = Vec::new();
    let mut other_types = Vec::new();
    for (mi, m) in markups.iter().enumerate() {
        let what = format!("markup {}", mi + 1);
        let kind = m.get("type").and_then(Value::as_str).unwrap_or("Fiducial");
        if !is_point_list(kind) {
            other_types.push(kind.to_string());
            continue;
        }
        decode_markup(&what, m, &mut points)?;
    }
    if !markups.is_empty() && other_types.len() == markups.len() {
        return Err(format!(
            "no point list among the markups (found type {}): landmarks must be placed \
             as a point list (\"Fiducial\") in Slicer's Markups module",
            other_types.join(", ")
        ));
    }
    Ok(points)
}

/// Slicer writes "Fiducial" for point lists (also in 5.x, where the UI says "Point List").
fn is_point_list(kind: &str) -> bool {
    let k: String = kind.chars().filter(|c| !c.is_whitespace()).collect();
    k.eq_ignore_ascii_case("fiducial") || k.eq_ignore_ascii_case("pointlist")
}

fn decode_markup(what: &str, m: &Value, points: &mut Vec<RawPoint>) -> Result<(), String> {
    if !m.is_object() {
        return Err(format!("{what} is {}, expected an object", show(m)));
    }
    let frame = match m.get("coordinateSystem") {
        None | Some(Value::Null) => Frame::Lps, // Slicer's default when the key is absent
        Some(v) => parse_frame(&format!("{what}: coordinateSystem"), v)?,
    };
    match m.get("coordinateUnits") {
        None | Some(Value::Null) => {}
        Some(Value::String(u)) if u.trim().eq_ignore_ascii_case("mm") => {}
        Some(v) => {
            return Err(format!(
                "{what}: coordinateUnits {} is not supported: coapt reads millimetres; \
                 convert the points to mm (coordinateUnits \"mm\")",
                show(v)
            ));
        }
    }
    let cps = match m.get("controlPoints") {
        None | Some(Value::Null) => return Ok(()),
        Some(Value::Array(a)) => a,
        Some(v) => {
            return Err(format!(
                "{what}: controlPoints is {}, expected a list",
                show(v)
            ));
        }
    };
    for (ci, cp) in cps.iter().enumerate() {
        let origin = format!("{what}, control point {}", ci + 1);
        if let Some(p) = decode_control_point(&origin, frame, cp)? {
            points.push(p);
        }
    }
    Ok(())
}

/// One control point; `None` for a placeholder that was never placed.
fn decode_control_point(
    origin: &str,
    frame: Frame,
    cp: &Value,
) -> Result<Option<RawPoint>, String> {
    if !cp.is_object() {
        return Err(format!("{origin} is {}, expected an object", show(cp)));
    }
    let label = match cp.get("label") {
        Some(Value::String(s)) => s.trim().to_string(),
        None | Some(Value::Null) => String::new(),
        Some(v) => return Err(format!("{origin}: label {} is not a string", show(v))),
    };
    let who = describe(&label, origin);
    match cp.get("positionStatus") {
        None | Some(Value::Null) => {}
        Some(Value::String(s)) => match s.trim().to_ascii_lowercase().as_str() {
            "defined" => {}
            // Placeholders (e.g. from a fixed point-list template) or a point
            // being placed: they have no meaningful position.
            "undefined" | "missing" | "preview" => return Ok(None),
            _ => {
                return Err(format!(
                    "{who}: unknown positionStatus \"{s}\": expected \"defined\", \"undefined\" or \"missing\""
                ));
            }
        },
        Some(v) => return Err(format!("{who}: positionStatus {} is not a string", show(v))),
    }
    let pos = match cp.get("position") {
        None | Some(Value::Null) => return Ok(None),
        Some(v) => position3(&who, v)?,
    };
    if label.is_empty() {
        return Err(format!(
            "{origin} has no label: name every point (C1, C2, C3, optionally N1, N2, N3) in Slicer's Markups module"
        ));
    }
    Ok(Some(RawPoint {
        label,
        lps: frame.convert(Frame::Lps, pos),
        origin: origin.to_string(),
    }))
}

#[derive(Serialize)]
struct MrkFile {
    #[serde(rename = "@schema")]
    schema: &'static str,
    markups: Vec<Markup>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Markup {
    #[serde(rename = "type")]
    kind: &'static str,
    coordinate_system: &'static str,
    coordinate_units: &'static str,
    locked: bool,
    fixed_number_of_control_points: bool,
    label_format: &'static str,
    last_used_control_point_number: usize,
    control_points: Vec<ControlPoint>,
    measurements: Vec<Value>,
    display: Display,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ControlPoint {
    id: String,
    label: String,
    description: String,
    #[serde(rename = "associatedNodeID")]
    associated_node_id: String,
    position: [f64; 3],
    orientation: [f64; 9],
    selected: bool,
    locked: bool,
    visibility: bool,
    position_status: &'static str,
}

/// Slicer 5's defaults for a point list, except labels shown and a colour
/// that stands out against contrast-filled blood.
#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Display {
    visibility: bool,
    opacity: f64,
    color: [f64; 3],
    selected_color: [f64; 3],
    active_color: [f64; 3],
    properties_label_visibility: bool,
    point_labels_visibility: bool,
    text_scale: f64,
    glyph_type: &'static str,
    glyph_scale: f64,
    glyph_size: f64,
    use_glyph_scale: bool,
    slice_projection: bool,
    slice_projection_use_fiducial_color: bool,
    slice_projection_outlined_behind_slice_plane: bool,
    slice_projection_color: [f64; 3],
    slice_projection_opacity: f64,
    line_thickness: f64,
    line_color_fading_start: f64,
    line_color_fading_end: f64,
    line_color_fading_saturation: f64,
    line_color_fading_hue_offset: f64,
    handles_interactive: bool,
    snap_mode: &'static str,
}

impl Default for Display {
    fn default() -> Self {
        Display {
            visibility: true,
            opacity: 1.0,
            color: [0.4, 1.0, 1.0],
            selected_color: [1.0, 0.5, 0.5],
            active_color: [0.4, 1.0, 0.0],
            properties_label_visibility: false,
            point_labels_visibility: true,
            text_scale: 3.0,
            glyph_type: "Sphere3D",
            glyph_scale: 3.0,
            glyph_size: 5.0,
            use_glyph_scale: true,
            slice_projection: false,
            slice_projection_use_fiducial_color: true,
            slice_projection_outlined_behind_slice_plane: false,
            slice_projection_color: [1.0, 1.0, 1.0],
            slice_projection_opacity: 0.6,
            line_thickness: 0.2,
            line_color_fading_start: 1.0,
            line_color_fading_end: 10.0,
            line_color_fading_saturation: 1.0,
            line_color_fading_hue_offset: 0.0,
            handles_interactive: false,
            snap_mode: "toVisibleSurface",
        }
    }
}
