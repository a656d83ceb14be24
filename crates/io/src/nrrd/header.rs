//! The NRRD header: `NRRD000N` magic, `field: value` lines, a blank line
//! before attached data (none in a detached `.nhdr`).

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Matrix4, Vector3};

use crate::nifti::{DataType, Endian};
use crate::raw_voxels::{self, Encoding, Layout, Start};
use coapt_base::{Error, Result};

/// Parse the header of `path` into a validated [`Layout`].
pub fn layout(path: &Path, max_bytes: u64) -> Result<Layout> {
    let (lines, end) = raw_voxels::header_lines(path, true, |_| false)?;
    parse(path, &lines, end, max_bytes).map_err(|p| Error::bad_input(path, p))
}

/// What the NRRD spaces coapt reads mean in LPS: the sign of x and of y.
fn space_signs(space: &str) -> Option<(&'static str, f64, f64)> {
    Some(match space.to_ascii_lowercase().as_str() {
        "left-posterior-superior" | "lps" => ("LPS", 1.0, 1.0),
        "right-anterior-superior" | "ras" => ("RAS", -1.0, -1.0),
        "left-anterior-superior" | "las" => ("LAS", 1.0, -1.0),
        _ => return None,
    })
}

fn parse(
    path: &Path,
    lines: &[String],
    end: u64,
    max_bytes: u64,
) -> std::result::Result<Layout, String> {
    let magic = lines.first().map(String::as_str).unwrap_or("");
    let version = magic
        .strip_prefix("NRRD000")
        .and_then(|v| v.parse::<u8>().ok())
        .ok_or_else(|| format!("not a NRRD file: it starts with {magic:?}, not \"NRRD000N\""))?;
    if !(1..=5).contains(&version) {
        return Err(format!(
            "NRRD format version {version} is not one coapt knows (1–5)"
        ));
    }
    let mut fields: HashMap<String, String> = HashMap::new();
    for (n, line) in lines.iter().enumerate().skip(1) {
        if line.starts_with('#') {
            continue;
        }
        // `key:=value` pairs are free-form metadata; fields use ": ".
        let field = line.find(": ");
        let kv = line.find(":=");
        if kv.is_some_and(|k| field.is_none_or(|f| k < f)) {
            continue;
        }
        let Some(colon) = field else {
            return Err(format!(
                "header line {} ({line:?}) is neither a \"field: value\" line nor a comment; \
                 the header is corrupt",
                n + 1
            ));
        };
        let name = line[..colon].trim().to_ascii_lowercase();
        // "datafile" is the old spelling of "data file".
        let name = if name == "datafile" {
            "data file".to_string()
        } else {
            name
        };
        if fields
            .insert(name.clone(), line[colon + 2..].trim().to_string())
            .is_some()
        {
            return Err(format!("field \"{name}\" is given twice"));
        }
    }
    let get = |k: &str| fields.get(k).map(String::as_str);
    let need = |k: &str| get(k).ok_or_else(|| format!("required field \"{k}\" is missing"));

    let dimension = need("dimension")?;
    if dimension != "3" {
        return Err(format!(
            "dimension is {dimension}; coapt needs one 3-D scalar volume"
        ));
    }
    let sizes: Vec<&str> = need("sizes")?.split_whitespace().collect();
    if sizes.len() != 3 {
        return Err(format!(
            "sizes has {} entries ({:?}); a 3-D volume needs 3",
            sizes.len(),
            sizes.join(" ")
        ));
    }
    let mut dims = [0usize; 3];
    for (a, s) in sizes.iter().enumerate() {
        dims[a] = s
            .parse::<usize>()
            .map_err(|_| format!("sizes entry {} is {s:?}, not a whole number ≥ 1", a + 1))?;
    }
    let datatype = data_type(need("type")?)?;
    let encoding = match need("encoding")?.to_ascii_lowercase().as_str() {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        other => {
            return Err(format!(
                "encoding \"{other}\" is not supported: coapt reads raw and gzip NRRD data \
                 (3D Slicer writes gzip); re-save the volume with one of them"
            ));
        }
    };
    let endian = match get("endian") {
        Some("little") => Endian::Little,
        Some("big") => Endian::Big,
        Some(other) => return Err(format!("endian is {other:?}; expected little or big")),
        None if datatype.bytes() == 1 => Endian::Little,
        None => {
            return Err(format!(
                "required field \"endian\" is missing ({} data has more than one byte per \
                 voxel, so the byte order matters)",
                datatype.name()
            ));
        }
    };
    if let Some(units) = get("space units") {
        let all_mm = units
            .split('"')
            .skip(1)
            .step_by(2)
            .all(|u| u.is_empty() || u == "mm");
        if !all_mm {
            return Err(format!(
                "space units are {units}; coapt reads millimetres (\"mm\") only"
            ));
        }
    }
    let (space_name, sx, sy) = match get("space") {
        Some(s) => space_signs(s).ok_or_else(|| {
            format!(
                "space \"{s}\" is not one coapt reads: left-posterior-superior (LPS), \
                 right-anterior-superior (RAS) or left-anterior-superior (LAS)"
            )
        })?,
        None => {
            return Err(
                "no \"space\" field: without it the volume's orientation in the patient is \
                 unknown; coapt needs space (LPS, RAS or LAS), space directions and space \
                 origin, as 3D Slicer writes them"
                    .into(),
            );
        }
    };
    let directions = vectors(need("space directions")?, "space directions")?;
    if directions.len() != 3 {
        return Err(format!(
            "space directions has {} vectors; a 3-D volume needs 3",
            directions.len()
        ));
    }
    let origin = vectors(need("space origin")?, "space origin")?;
    if origin.len() != 1 {
        return Err("space origin must be one vector \"(x,y,z)\"".into());
    }
    // Columns: the world step of one voxel along each index axis, in the
    // file's space; then into LPS by the space's signs.
    let flip = Vector3::new(sx, sy, 1.0);
    let mut affine = Matrix4::identity();
    for (c, d) in directions.iter().enumerate() {
        let d = d.component_mul(&flip);
        affine.fixed_view_mut::<3, 1>(0, c).copy_from(&d);
    }
    affine
        .fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&origin[0].component_mul(&flip));

    let skip = |k: &str| -> std::result::Result<i64, String> {
        match get(k) {
            None => Ok(0),
            Some(v) => v
                .parse::<i64>()
                .ok()
                .filter(|&n| n >= -1)
                .ok_or_else(|| format!("{k} is {v:?}; expected a whole number ≥ -1")),
        }
    };
    if skip("line skip")? != 0 {
        return Err(
            "line skip is not supported; re-save the volume without it (3D Slicer never \
             writes it)"
                .into(),
        );
    }
    let byte_skip = skip("byte skip")?;
    let (data_file, start) = match get("data file") {
        Some(name) => raw_voxels::detached(path, "data file", name, byte_skip)?,
        None => {
            if byte_skip != 0 {
                return Err(
                    "byte skip in a NRRD with attached data is not supported; re-save the \
                     volume without it"
                        .into(),
                );
            }
            (path.to_path_buf(), Start::At(end))
        }
    };
    let layout = Layout {
        format: "NRRD",
        dims,
        datatype,
        endian,
        affine_lps: affine,
        file_space: space_name.to_string(),
        data_file,
        start,
        encoding,
    };
    layout.validate(max_bytes)?;
    Ok(layout)
}

/// The NRRD type names (teem's synonyms included).
fn data_type(name: &str) -> std::result::Result<DataType, String> {
    Ok(match name {
        "signed char" | "int8" | "int8_t" => DataType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => DataType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            DataType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => DataType::U16,
        "int" | "signed int" | "int32" | "int32_t" => DataType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => DataType::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => DataType::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            DataType::U64
        }
        "float" => DataType::F32,
        "double" => DataType::F64,
        other => {
            return Err(format!(
                "type \"{other}\" is not supported: coapt reads scalar volumes (int8, uint8, \
                 int16, uint16, int32, uint32, int64, uint64, float, double)"
            ));
        }
    })
}

/// `(x,y,z) (x,y,z) …` as vectors; `none` (a non-spatial axis) is refused,
/// since all three axes of a CT are spatial.
fn vectors(text: &str, field: &str) -> std::result::Result<Vec<Vector3<f64>>, String> {
    let mut out = Vec::new();
    let mut rest = text.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            let _ = r;
            return Err(format!(
                "{field} has \"none\" for an axis: coapt needs all three axes spatial"
            ));
        }
        let body = rest
            .strip_prefix('(')
            .and_then(|r| r.split_once(')'))
            .ok_or_else(|| format!("{field} \"{text}\" is not a list of \"(x,y,z)\" vectors"))?;
        let nums: Vec<f64> = body
            .0
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| {
                format!(
                    "{field} \"({})\" holds a value that is not a number",
                    body.0
                )
            })?;
        if nums.len() != 3 {
            return Err(format!(
                "{field} vector \"({})\" has {} components; a 3-D space needs 3",
                body.0,
                nums.len()
            ));
        }
        if nums.iter().any(|v| !v.is_finite()) {
            return Err(format!(
                "{field} vector \"({})\" has a non-finite component",
                body.0
            ));
        }
        out.push(Vector3::new(nums[0], nums[1], nums[2]));
        rest = body.1.trim_start();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(fields: &[&str]) -> Vec<String> {
        std::iter::once("NRRD0004")
            .chain(fields.iter().copied())
            .map(String::from)
            .collect()
    }

    const GOOD: [&str; 8] = [
        "type: short",
        "dimension: 3",
        "space: right-anterior-superior",
        "sizes: 4 5 6",
        "space directions: (0.5,0,0) (0,0.6,0) (0,0,0.8)",
        "encoding: gzip",
        "endian: little",
        "space origin: (10,20,30)",
    ];

    fn parse_with(replace: &str, with: Option<&str>) -> std::result::Result<Layout, String> {
        let fields: Vec<&str> = GOOD
            .iter()
            .filter_map(|f| {
                if f.starts_with(replace) {
                    with
                } else {
                    Some(*f)
                }
            })
            .collect();
        parse(Path::new("x.nrrd"), &header(&fields), 200, 1 << 30)
    }

    #[test]
    fn ras_becomes_lps_with_x_and_y_negated() {
        let l = parse_with("#", None).unwrap();
        assert_eq!(l.dims, [4, 5, 6]);
        assert_eq!(l.datatype, DataType::I16);
        assert_eq!(l.encoding, Encoding::Gzip);
        assert_eq!(l.start, Start::At(200));
        assert_eq!(l.file_space, "RAS");
        let a = l.affine_lps;
        assert_eq!(a[(0, 0)], -0.5);
        assert_eq!(a[(1, 1)], -0.6);
        assert_eq!(a[(2, 2)], 0.8);
        assert_eq!((a[(0, 3)], a[(1, 3)], a[(2, 3)]), (-10.0, -20.0, 30.0));
    }

    #[test]
    fn las_negates_y_only_and_lps_nothing() {
        let l = parse_with("space:", Some("space: left-anterior-superior")).unwrap();
        assert_eq!((l.affine_lps[(0, 3)], l.affine_lps[(1, 3)]), (10.0, -20.0));
        let l = parse_with("space:", Some("space: LPS")).unwrap();
        assert_eq!((l.affine_lps[(0, 0)], l.affine_lps[(1, 3)]), (0.5, 20.0));
    }

    #[test]
    fn key_value_pairs_and_comments_are_skipped() {
        let mut f: Vec<&str> = GOOD.to_vec();
        f.push("# a comment: with a colon");
        f.push("DICOM_Series:=1.2.3: odd");
        f.push("kinds: domain domain domain");
        assert!(parse(Path::new("x.nrrd"), &header(&f), 0, 1 << 30).is_ok());
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases: [(&str, Option<&str>, &str); 14] = [
            ("sizes", None, "\"sizes\" is missing"),
            ("sizes", Some("sizes: 4 5"), "needs 3"),
            ("sizes", Some("sizes: 4 -5 6"), "not a whole number"),
            ("sizes", Some("sizes: 4 0 6"), "must be ≥ 1"),
            ("sizes", Some("sizes: 4 500000 6"), "corrupt"),
            ("type", Some("type: block"), "not supported"),
            ("encoding", Some("encoding: bzip2"), "raw and gzip"),
            ("endian", None, "\"endian\" is missing"),
            ("space:", None, "no \"space\" field"),
            ("space:", Some("space: scanner-xyz"), "not one coapt reads"),
            (
                "space directions",
                Some("space directions: (0.5,0,0) (0,0,0) (0,0,0.8)"),
                "singular",
            ),
            (
                "space directions",
                Some("space directions: (1e-5,0,0) (0,0.6,0) (0,0,0.8)"),
                "spacing along axis 1",
            ),
            (
                "space origin",
                Some("space origin: (1,nan,3)"),
                "non-finite",
            ),
            ("dimension", Some("dimension: 4"), "3-D"),
        ];
        for (field, with, words) in cases {
            let e = parse_with(field, with).unwrap_err();
            assert!(e.contains(words), "{field} → {with:?}: {e}");
        }
    }

    #[test]
    fn huge_sizes_are_refused_by_the_byte_limit() {
        let e = parse_with("sizes", Some("sizes: 90000 90000 90000")).unwrap_err();
        assert!(e.contains("above the limit"), "{e}");
    }

    #[test]
    fn detached_data_with_byte_skip() {
        let l = parse_with("encoding", Some("data file: ct.raw"))
            .map(|_| ())
            .unwrap_err();
        // encoding is required even with a data file.
        assert!(l.contains("\"encoding\" is missing"), "{l}");
        let mut f: Vec<&str> = GOOD.to_vec();
        f[5] = "encoding: raw";
        f.push("data file: sub/ct.raw");
        f.push("byte skip: -1");
        let l = parse(Path::new("/d/x.nhdr"), &header(&f), 0, 1 << 30).unwrap();
        assert_eq!(l.data_file, Path::new("/d/sub/ct.raw"));
        assert_eq!(l.start, Start::FromEnd);
    }
}
