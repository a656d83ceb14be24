//! Legacy 3D Slicer fiducial list (`.fcsv`).

use std::io::Write;
use std::path::Path;

use super::{RawPoint, check_for_writing, finish, finite3, read_text};
use crate::write_atomic;
use coapt_base::Result;
use coapt_geom::{Frame, Landmarks};

const DEFAULT_COLUMNS: &str = "id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID";

/// Read an .fcsv file; points in LPS.
pub fn read_fcsv(path: &Path) -> Result<Landmarks> {
    finish(path, decode(&read_text(path)?))
}

/// Write `lm` as a Slicer 4.11-style .fcsv with coordinates in `frame`.
pub fn write_fcsv(path: &Path, lm: &Landmarks, frame: Frame) -> Result<()> {
    check_for_writing(path, lm)?;
    let lm = lm.to_frame(frame);
    let mut text = format!(
        "# Markups fiducial file version = 4.11\n# CoordinateSystem = {}\n# columns = {DEFAULT_COLUMNS}\n",
        frame.name()
    );
    for (i, (label, p)) in lm.points.iter().enumerate() {
        // `{}` on f64 is the shortest text that parses back to the same bits.
        text.push_str(&format!(
            "{},{},{},{},0,0,0,1,1,1,0,{},,\n",
            i + 1,
            p.x,
            p.y,
            p.z,
            quote(label)
        ));
    }
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Where the fields we need sit in a data line.
struct Columns {
    x: usize,
    y: usize,
    z: usize,
    label: usize,
}

impl Columns {
    fn parse(spec: &str) -> Result<Columns, String> {
        let names: Vec<String> = spec
            .split(',')
            .map(|c| c.trim().to_ascii_lowercase())
            .collect();
        let find = |n: &str| {
            names.iter().position(|c| c == n).ok_or_else(|| {
                format!(
                    "the columns header \"{}\" has no '{n}' column: expected e.g. \"{DEFAULT_COLUMNS}\"",
                    spec.trim()
                )
            })
        };
        Ok(Columns {
            x: find("x")?,
            y: find("y")?,
            z: find("z")?,
            label: find("label")?,
        })
    }

    fn needed(&self) -> usize {
        self.x.max(self.y).max(self.z).max(self.label) + 1
    }
}

/// Points of an .fcsv text, converted to LPS.
pub(super) fn decode(text: &str) -> Result<Vec<RawPoint>, String> {
    // Without a CoordinateSystem line the file predates Slicer 4.11: RAS.
    let mut frame = Frame::Ras;
    let mut cols = Columns::parse(DEFAULT_COLUMNS)?;
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(header) = line.strip_prefix('#') {
            if let Some((key, value)) = header.split_once('=') {
                match key.trim().to_ascii_lowercase().as_str() {
                    "coordinatesystem" => frame = parse_code(line_no, value)?,
                    "columns" => {
                        cols = Columns::parse(value).map_err(|m| format!("line {line_no}: {m}"))?
                    }
                    _ => {}
                }
            }
            continue;
        }
        points.push(decode_line(line_no, line, &cols)?);
    }
    for p in &mut points {
        p.lps = frame.convert(Frame::Lps, p.lps);
    }
    Ok(points)
}

fn parse_code(line_no: usize, value: &str) -> Result<Frame, String> {
    match value.trim().to_ascii_uppercase().as_str() {
        "0" | "RAS" => Ok(Frame::Ras),
        "1" | "LPS" => Ok(Frame::Lps),
        "2" | "IJK" => Err(format!(
            "line {line_no}: CoordinateSystem = {} means IJK voxel indices, which coapt cannot place \
             in the world without the volume: re-export the points from Slicer in LPS or RAS",
            value.trim()
        )),
        other => Err(format!(
            "line {line_no}: unknown CoordinateSystem \"{other}\": expected 0 (RAS), 1 (LPS), RAS or LPS"
        )),
    }
}

/// One data line; coordinates still in the file's frame.
fn decode_line(line_no: usize, line: &str, cols: &Columns) -> Result<RawPoint, String> {
    let origin = format!("line {line_no}");
    let fields = split_csv(line).map_err(|m| format!("{origin}: {m}"))?;
    if fields.len() < cols.needed() {
        return Err(format!(
            "{origin} has {} fields, the columns header asks for at least {}: \
             is a label with a comma missing its quotes?",
            fields.len(),
            cols.needed()
        ));
    }
    let label = fields[cols.label].trim().to_string();
    let who = if label.is_empty() {
        origin.clone()
    } else {
        format!("control point '{label}' ({origin})")
    };
    let raw = [&fields[cols.x], &fields[cols.y], &fields[cols.z]].map(|f| f.trim());
    let shown = format!("[{}]", raw.join(", "));
    let parsed: Option<Vec<f64>> = raw.iter().map(|f| f.parse::<f64>().ok()).collect();
    let p = match parsed {
        Some(v) => finite3(&who, &shown, [v[0], v[1], v[2]])?,
        None => {
            return Err(format!(
                "{who}: position {shown} is not three numbers: write x, y, z in mm"
            ));
        }
    };
    if label.is_empty() {
        return Err(format!(
            "{origin}: the point has no label: name every point (C1, C2, C3, optionally N1, N2, N3)"
        ));
    }
    Ok(RawPoint {
        label,
        lps: p,
        origin,
    })
}

/// Split one CSV line; quoted fields may hold commas, `""` is a literal quote.
fn split_csv(line: &str) -> Result<Vec<String>, String> {
    let mut fields = Vec::new();
    let mut chars = line.chars().peekable();
    loop {
        let mut field = String::new();
        if chars.peek() == Some(&'"') {
            chars.next();
            loop {
                match chars.next() {
                    None => return Err("a quoted field has no closing quote".to_string()),
                    Some('"') if chars.peek() == Some(&'"') => {
                        chars.next();
                        field.push('"');
                    }
                    Some('"') => break,
                    Some(c) => field.push(c),
                }
            }
            // Anything between the closing quote and the next comma is kept, as spreadsheets do.
            while let Some(&c) = chars.peek() {
                if c == ',' {
                    break;
                }
                field.push(c);
                chars.next();
            }
        } else {
            while let Some(&c) = chars.peek() {
                if c == ',' {
                    break;
                }
                field.push(c);
                chars.next();
            }
        }
        fields.push(field);
        if chars.next().is_none() {
            return Ok(fields);
        }
    }
}

/// Quote a label for CSV when it needs it (Slicer does the same).
fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quoting() {
        assert_eq!(
            split_csv("a,\"b,c\",,\"d\"\"e\"").unwrap(),
            ["a", "b,c", "", "d\"e"]
        );
        assert_eq!(split_csv("").unwrap(), [""]);
        assert!(split_csv("a,\"b").is_err());
        for s in ["plain", "with,comma", "q\"uote"] {
            assert_eq!(split_csv(&format!("x,{}", quote(s))).unwrap()[1], s);
        }
    }
}
