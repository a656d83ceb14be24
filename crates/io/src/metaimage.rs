//! MetaImage volumes (.mha with attached data, .mhd with a detached data
//! file), as ITK, ITK-SNAP and SimpleITK write them.
//!
//! The header is `Key = Value` lines ending with `ElementDataFile`; the data
//! follow it (`LOCAL`) or live in the named file. MetaImage's world frame is
//! LPS, as ITK's: `Offset` is the world position of voxel [0, 0, 0], and
//! `TransformMatrix` lists the direction of index axis 0, then of axis 1,
//! then of axis 2 (ITK's `GetDirection(i)`, i.e. the direction matrix's
//! columns), each scaled by its `ElementSpacing`. `AnatomicalOrientation` is
//! a label derived from that matrix; ITK does not read it, nor does coapt.
//! `CompressedData = True` is a zlib (or gzip) stream.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Matrix4;

use super::nifti::{DataType, Endian};
use super::raw_voxels::{self, Encoding, Layout, Start};
use coapt_base::{Error, Result};

/// Parse the header of `path` into a validated [`Layout`].
pub fn layout(path: &Path, max_bytes: u64) -> Result<Layout> {
    let (lines, end) = raw_voxels::header_lines(path, false, |l| {
        key_of(l).is_some_and(|k| k == "ElementDataFile")
    })?;
    parse(path, &lines, end, max_bytes).map_err(|p| Error::bad_input(path, p))
}

fn key_of(line: &str) -> Option<&str> {
    line.split_once('=').map(|(k, _)| k.trim())
}

/// Whether `first_line` starts a MetaImage header (content sniffing).
pub fn looks_like(first_line: &str) -> bool {
    matches!(
        key_of(first_line),
        Some("ObjectType" | "NDims" | "ObjectSubType" | "Comment")
    )
}

fn parse(
    path: &Path,
    lines: &[String],
    end: u64,
    max_bytes: u64,
) -> std::result::Result<Layout, String> {
    let mut fields: HashMap<&str, &str> = HashMap::new();
    for (n, line) in lines.iter().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let Some((k, v)) = line.split_once('=') else {
            return Err(format!(
                "header line {} ({line:?}) is not \"Key = Value\"; the header is corrupt",
                n + 1
            ));
        };
        // Synonyms MetaIO accepts for the same field.
        let k = match k.trim() {
            "Position" | "Origin" => "Offset",
            "Rotation" | "Orientation" => "TransformMatrix",
            "ElementByteOrderMSB" => "BinaryDataByteOrderMSB",
            k => k,
        };
        if fields.insert(k, v.trim()).is_some() {
            return Err(format!("{k} is given twice"));
        }
    }
    let get = |k: &str| fields.get(k).copied();
    let need = |k: &str| get(k).ok_or_else(|| format!("required field {k} is missing"));
    let flag = |k: &str, default: bool| -> std::result::Result<bool, String> {
        match get(k).map(str::to_ascii_lowercase).as_deref() {
            None => Ok(default),
            Some("true" | "1") => Ok(true),
            Some("false" | "0") => Ok(false),
            Some(v) => Err(format!("{k} is {v:?}; expected True or False")),
        }
    };
    if let Some(t) = get("ObjectType") {
        if t != "Image" {
            return Err(format!(
                "ObjectType is {t:?}; coapt reads MetaImage volumes (ObjectType = Image)"
            ));
        }
    }
    let ndims = need("NDims")?;
    if ndims != "3" {
        return Err(format!(
            "NDims is {ndims}; coapt needs one 3-D scalar volume"
        ));
    }
    if let Some(c) = get("ElementNumberOfChannels") {
        if c != "1" {
            return Err(format!(
                "ElementNumberOfChannels is {c}; coapt needs a scalar volume (1 channel)"
            ));
        }
    }
    let dim_sizes = numbers(need("DimSize")?, "DimSize", 3)?;
    let mut dims = [0usize; 3];
    for (a, &d) in dim_sizes.iter().enumerate() {
        if d.fract() != 0.0 || d < 0.0 || d > u32::MAX as f64 {
            return Err(format!(
                "DimSize entry {} is {d}, not a whole number ≥ 1",
                a + 1
            ));
        }
        dims[a] = d as usize;
    }
    let datatype = element_type(need("ElementType")?)?;
    if !flag("BinaryData", true)? {
        return Err(
            "BinaryData = False (ASCII voxel values) is not supported; re-save the volume as \
             binary (ITK's default)"
                .into(),
        );
    }
    let endian = if flag("BinaryDataByteOrderMSB", false)? {
        Endian::Big
    } else {
        Endian::Little
    };
    let encoding = if flag("CompressedData", false)? {
        Encoding::Zlib
    } else {
        Encoding::Raw
    };
    let spacing = numbers(
        get("ElementSpacing").ok_or(
            "required field ElementSpacing is missing: without it the voxel size is unknown",
        )?,
        "ElementSpacing",
        3,
    )?;
    // MetaIO's defaults: identity directions, origin at 0.
    let m = match get("TransformMatrix") {
        Some(t) => numbers(t, "TransformMatrix", 9)?,
        None => vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    };
    let origin = match get("Offset") {
        Some(o) => numbers(o, "Offset", 3)?,
        None => vec![0.0; 3],
    };
    let mut affine = Matrix4::identity();
    for axis in 0..3 {
        for r in 0..3 {
            affine[(r, axis)] = m[3 * axis + r] * spacing[axis];
        }
        affine[(axis, 3)] = origin[axis];
    }
    let header_size = match get("HeaderSize") {
        None => 0,
        Some(v) => v
            .parse::<i64>()
            .ok()
            .filter(|&n| n >= -1)
            .ok_or_else(|| format!("HeaderSize is {v:?}; expected a whole number ≥ -1"))?,
    };
    let file = need("ElementDataFile")?;
    if lines
        .last()
        .and_then(|l| key_of(l))
        .is_none_or(|k| k != "ElementDataFile")
    {
        return Err("ElementDataFile must be the header's last line".into());
    }
    let (data_file, start) = match file {
        "LOCAL" | "Local" | "local" => {
            if header_size != 0 {
                return Err(
                    "HeaderSize with attached (LOCAL) data is not supported; re-save the volume \
                     without it"
                        .into(),
                );
            }
            (path.to_path_buf(), Start::At(end))
        }
        f => raw_voxels::detached(path, "ElementDataFile", f, header_size)?,
    };
    let layout = Layout {
        format: "MetaImage",
        dims,
        datatype,
        endian,
        affine_lps: affine,
        file_space: "LPS".into(),
        data_file,
        start,
        encoding,
    };
    layout.validate(max_bytes)?;
    Ok(layout)
}

fn element_type(name: &str) -> std::result::Result<DataType, String> {
    Ok(match name {
        "MET_CHAR" => DataType::I8,
        "MET_UCHAR" => DataType::U8,
        "MET_SHORT" => DataType::I16,
        "MET_USHORT" => DataType::U16,
        // MetaIO's LONG is 4 bytes, whatever the platform's long.
        "MET_INT" | "MET_LONG" => DataType::I32,
        "MET_UINT" | "MET_ULONG" => DataType::U32,
        "MET_LONG_LONG" => DataType::I64,
        "MET_ULONG_LONG" => DataType::U64,
        "MET_FLOAT" => DataType::F32,
        "MET_DOUBLE" => DataType::F64,
        other => {
            return Err(format!(
                "ElementType {other} is not supported: coapt reads scalar volumes (MET_CHAR, \
                 MET_UCHAR, MET_SHORT, MET_USHORT, MET_INT, MET_UINT, MET_LONG, MET_ULONG, \
                 MET_LONG_LONG, MET_ULONG_LONG, MET_FLOAT, MET_DOUBLE)"
            ));
        }
    })
}

/// Exactly `n` finite numbers separated by white space.
fn numbers(text: &str, key: &str, n: usize) -> std::result::Result<Vec<f64>, String> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(str::parse::<f64>)
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("{key} \"{text}\" holds a value that is not a number"))?;
    if v.len() != n {
        return Err(format!(
            "{key} has {} values (\"{text}\"); a 3-D volume needs {n}",
            v.len()
        ));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{key} \"{text}\" has a non-finite value"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: [&str; 11] = [
        "ObjectType = Image",
        "NDims = 3",
        "BinaryData = True",
        "BinaryDataByteOrderMSB = False",
        "CompressedData = False",
        "TransformMatrix = 0 1 0 -1 0 0 0 0 1",
        "Offset = 10 20 30",
        "ElementSpacing = 0.5 0.6 0.8",
        "DimSize = 4 5 6",
        "ElementType = MET_SHORT",
        "ElementDataFile = LOCAL",
    ];

    fn parse_with(replace: &str, with: Option<&str>) -> std::result::Result<Layout, String> {
        let lines: Vec<String> = GOOD
            .iter()
            .filter_map(|f| {
                if f.starts_with(replace) {
                    with
                } else {
                    Some(*f)
                }
            })
            .map(String::from)
            .collect();
        parse(Path::new("/d/x.mha"), &lines, 300, 1 << 30)
    }

    #[test]
    fn transform_matrix_rows_are_the_axis_directions() {
        let l = parse_with("#", None).unwrap();
        let a = l.affine_lps;
        // Axis 0 points along +y (0.5 mm), axis 1 along −x (0.6 mm).
        assert_eq!((a[(0, 0)], a[(1, 0)], a[(2, 0)]), (0.0, 0.5, 0.0));
        assert_eq!((a[(0, 1)], a[(1, 1)], a[(2, 1)]), (-0.6, 0.0, 0.0));
        assert_eq!(a[(2, 2)], 0.8);
        assert_eq!((a[(0, 3)], a[(1, 3)], a[(2, 3)]), (10.0, 20.0, 30.0));
        assert_eq!(l.start, Start::At(300));
        assert_eq!(l.encoding, Encoding::Raw);
        assert_eq!(l.data_file, Path::new("/d/x.mha"));
    }

    #[test]
    fn detached_compressed_big_endian() {
        let l = parse_with("ElementDataFile", Some("ElementDataFile = ct.zraw")).unwrap();
        assert_eq!(l.data_file, Path::new("/d/ct.zraw"));
        let l = parse_with("CompressedData", Some("CompressedData = True")).unwrap();
        assert_eq!(l.encoding, Encoding::Zlib);
        let l = parse_with("BinaryDataByteOrderMSB", Some("ElementByteOrderMSB = True")).unwrap();
        assert_eq!(l.endian, Endian::Big);
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases: [(&str, Option<&str>, &str); 13] = [
            ("DimSize", None, "DimSize is missing"),
            ("DimSize", Some("DimSize = 4 5"), "needs 3"),
            ("DimSize", Some("DimSize = 4 5.5 6"), "not a whole number"),
            ("DimSize", Some("DimSize = 4 0 6"), "must be ≥ 1"),
            ("DimSize", Some("DimSize = 400000 5 6"), "corrupt"),
            (
                "DimSize",
                Some("DimSize = 90000 90000 90000"),
                "above the limit",
            ),
            ("ElementSpacing", None, "ElementSpacing is missing"),
            (
                "ElementSpacing",
                Some("ElementSpacing = 0.5 0 0.8"),
                "singular",
            ),
            (
                "ElementSpacing",
                Some("ElementSpacing = 0.5 500 0.8"),
                "spacing along axis 2",
            ),
            (
                "ElementType",
                Some("ElementType = MET_SHORT_ARRAY"),
                "not supported",
            ),
            ("NDims", Some("NDims = 4"), "3-D"),
            ("BinaryData ", Some("BinaryData = False"), "ASCII"),
            (
                "ElementDataFile",
                Some("ElementDataFile = LIST"),
                "several files",
            ),
        ];
        for (field, with, words) in cases {
            let e = parse_with(field, with).unwrap_err();
            assert!(e.contains(words), "{field} → {with:?}: {e}");
        }
    }
}
