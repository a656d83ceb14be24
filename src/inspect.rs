//! `coapt info` and `coapt convert`: look inside any artifact and hand it to
//! other tools in the format they want.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{Value as Json, json};

use crate::geom::{Frame, PolyData, TriMesh};
use crate::io::{dicom, markups, nifti, nrrd, ply, stl, volume_file, vtp};
use crate::{Error, Result};

/// File formats coapt reads, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// A volume in any format [`volume_file`] reads.
    Volume,
    /// NRRD, as an output (volumes are read whatever their format).
    Nrrd,
    Vtp,
    Stl,
    Ply,
    Landmarks,
}

/// The format a file's name asks for (as an output; inputs: [`input_format`]).
pub fn format_of(path: &Path) -> Option<Format> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    Some(if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        Format::Volume
    } else if name.ends_with(".nrrd") {
        Format::Nrrd
    } else if name.ends_with(".nhdr") || name.ends_with(".mha") || name.ends_with(".mhd") {
        Format::Volume
    } else if name.ends_with(".vtp") {
        Format::Vtp
    } else if name.ends_with(".stl") {
        Format::Stl
    } else if name.ends_with(".ply") {
        Format::Ply
    } else if name.ends_with(".json") || name.ends_with(".fcsv") {
        Format::Landmarks
    } else {
        return None;
    })
}

/// The format of an input: a directory or a file whose name says nothing
/// is judged by the volume reader, which recognises content and, if it is
/// no volume either, lists what it reads.
fn input_format(path: &Path) -> Result<Format> {
    match format_of(path) {
        Some(Format::Nrrd) => Ok(Format::Volume),
        Some(f) if !path.is_dir() => Ok(f),
        _ => match volume_file::sniff(path) {
            Ok(_) => Ok(Format::Volume),
            Err(Error::BadInput { problem, .. }) if !path.is_dir() => Err(Error::bad_input(
                path,
                format!(
                    "unknown format: expected a volume, .vtp, .mrk.json, .fcsv or .json \
                     (landmarks); as a volume it {problem}"
                ),
            )),
            Err(e) => Err(e),
        },
    }
}

/// A description of the file, as text or JSON.
pub fn describe(path: &Path, as_json: bool) -> Result<String> {
    if !path.exists() {
        return Err(Error::bad_input(path, "not found"));
    }
    let info = match input_format(path)? {
        Format::Volume | Format::Nrrd
            if volume_file::sniff(path).is_ok_and(|f| f == volume_file::Format::Dicom) =>
        {
            describe_dicom_folder(path)?
        }
        Format::Volume | Format::Nrrd => describe_volume(path)?,
        Format::Vtp => describe_polydata(&vtp::read(path)?),
        Format::Landmarks => describe_landmarks(path)?,
        Format::Stl | Format::Ply => {
            return Err(Error::bad_input(
                path,
                "coapt writes STL and PLY for hand-off but does not read them",
            ));
        }
    };
    if as_json {
        Ok(serde_json::to_string_pretty(&info).expect("JSON value serialises"))
    } else {
        Ok(to_text(&info, 0))
    }
}

fn describe_volume(path: &Path) -> Result<Json> {
    let opts = nifti::ReadOptions::default();
    let h = volume_file::read_header(path, &opts)?;
    let v = volume_file::read::<f32>(path, &opts)?;
    let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for &x in v.as_slice() {
        let x = x as f64;
        lo = lo.min(x);
        hi = hi.max(x);
        sum += x;
    }
    let a = v.affine();
    let rows: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| a[(r, c)]).collect())
        .collect();
    Ok(json!({
        "file": path.display().to_string(),
        "format": h.format,
        "datatype": format!("{:?}", h.datatype),
        "encoding": h.encoding,
        "data_file": h.data_file.map(|p| p.display().to_string()),
        "dims": v.dims(),
        "spacing_mm": v.spacing(),
        "transform": h.transform,
        "frame": "LPS",
        "affine_voxel_to_lps": rows,
        "right_handed": v.is_right_handed(),
        "origin_mm": [v.origin().x, v.origin().y, v.origin().z],
        "value_min": lo,
        "value_max": hi,
        "value_mean": sum / v.len() as f64,
    }))
}

/// The series a folder holds (UID, number, description, modality, images,
/// spacing) and, when one is chosen (the only one, or `--series`), the
/// volume it reads as.
fn describe_dicom_folder(path: &Path) -> Result<Json> {
    let (series, other) = dicom::scan(path, nifti::ReadOptions::default().max_bytes)?;
    if series.is_empty() {
        return Err(dicom::no_images(path, other));
    }
    let list: Vec<Json> = series
        .iter()
        .map(|s| {
            let first = s.slices.first();
            json!({
                "uid": s.uid,
                "number": s.number,
                "description": s.description,
                "modality": s.modality,
                "images": s.slices.len() + s.problems.len(),
                "localiser": s.localiser,
                "transfer_syntax": s.transfer_syntax,
                "pixel_spacing_mm": first.map(|f| f.pixel_spacing),
                "rows_columns": first.map(|f| [f.rows, f.columns]),
            })
        })
        .collect();
    let mut info = json!({
        "file": path.display().to_string(),
        "format": if path.is_dir() { "DICOM folder" } else { "DICOM file" },
        "other_files": other,
        "series": list,
    });
    let pick = volume_file::series_choice();
    match dicom::choose(path, &series, pick) {
        Ok((s, chosen)) => {
            info["chosen"] = json!({"uid": s.uid, "number": s.number, "how": chosen.describe()});
            info["volume"] = describe_volume(path)?;
        }
        // A wrong --series is an error; several plausible series a note.
        Err(e) if pick.is_some() => return Err(e),
        Err(_) => {
            info["note"] = json!("several series: choose one with --series UID|NUMBER");
        }
    }
    Ok(info)
}

fn describe_polydata(pd: &PolyData) -> Json {
    let arrays = |a: &crate::geom::Attributes| -> Vec<Json> {
        a.iter()
            .map(|d| json!({"name": d.name, "type": d.values.vtk_type(), "components": d.components}))
            .collect()
    };
    let mut info = json!({
        "format": "VTK XML PolyData",
        "frame": pd.field_data.get_str("frame").unwrap_or("LPS (not recorded)"),
        "points": pd.points.len(),
        "lines": pd.lines.len(),
        "triangles": pd.triangles.len(),
        "point_data": arrays(&pd.point_data),
        "cell_data": arrays(&pd.cell_data),
        "field_data": arrays(&pd.field_data),
    });
    if !pd.triangles.is_empty() && pd.lines.is_empty() {
        if let Ok(mesh) = TriMesh::from_polydata(pd.clone()) {
            let topo = mesh.topology();
            let (mut emin, mut emax, mut amin) = (f64::INFINITY, 0.0f64, f64::INFINITY);
            for t in 0..mesh.triangles.len() {
                let q = mesh.quality(t);
                emin = emin.min(q.min_edge);
                emax = emax.max(q.max_edge);
                amin = amin.min(q.min_angle);
            }
            let closed = topo.boundary_edges == 0 && topo.nonmanifold_edges == 0;
            info["mesh"] = json!({
                "area_mm2": mesh.total_area(),
                "closed": closed,
                "enclosed_volume_mm3": if closed { json!(mesh.signed_volume()) } else { Json::Null },
                "euler_characteristic": topo.euler_characteristic,
                "components": topo.components,
                "boundary_edges": topo.boundary_edges,
                "edge_min_mm": emin,
                "edge_max_mm": emax,
                "min_angle_deg": amin.to_degrees(),
                "consistent": mesh.sanity_check().is_ok(),
            });
        }
    }
    info
}

fn describe_landmarks(path: &Path) -> Result<Json> {
    let lm = markups::read(path)?;
    let points: Vec<Json> = lm
        .points
        .iter()
        .map(|(l, p)| json!({"label": l, "position_mm": [p.x, p.y, p.z]}))
        .collect();
    let missing: Vec<&str> = ["C1", "C2", "C3"]
        .into_iter()
        .filter(|l| lm.get(l).is_none())
        .collect();
    Ok(json!({
        "format": "landmarks",
        "frame": "LPS",
        "points": points,
        "missing_required": missing,
    }))
}

/// Indented text rendering of a JSON description.
fn to_text(v: &Json, indent: usize) -> String {
    let pad = " ".repeat(indent);
    let mut s = String::new();
    match v {
        Json::Object(m) => {
            for (k, x) in m {
                match x {
                    Json::Object(_) => {
                        let _ = write!(s, "{pad}{k}:\n{}", to_text(x, indent + 2));
                    }
                    Json::Array(a) if a.iter().any(|e| e.is_object()) => {
                        let _ = writeln!(s, "{pad}{k}:");
                        for e in a {
                            let _ = writeln!(s, "{pad}  - {}", e);
                        }
                    }
                    _ => {
                        let _ = writeln!(s, "{pad}{k}: {x}");
                    }
                }
            }
        }
        other => {
            let _ = writeln!(s, "{pad}{other}");
        }
    }
    s
}

/// Convert `input` into the format `output`'s name asks for. Writes atomically.
pub fn convert(input: &Path, output: &Path, frame: Frame) -> Result<()> {
    if !input.exists() {
        return Err(Error::bad_input(input, "not found"));
    }
    let from = input_format(input)?;
    let to = format_of(output).ok_or_else(|| {
        Error::usage(format!(
            "{}: unknown output format (.nii, .nii.gz, .nrrd, .vtp, .stl, .ply, .mrk.json, .fcsv, .json)",
            output.display()
        ))
    })?;
    match (from, to) {
        (Format::Volume, Format::Volume | Format::Nrrd) => {
            let name = output.to_string_lossy().to_ascii_lowercase();
            if !(name.ends_with(".nii") || name.ends_with(".nii.gz") || name.ends_with(".nrrd")) {
                return Err(Error::usage(format!(
                    "{}: coapt writes volumes as .nii, .nii.gz or .nrrd",
                    output.display()
                )));
            }
            convert_volume(input, output, to == Format::Nrrd)
        }
        (Format::Vtp, Format::Vtp) => {
            vtp::write(output, &vtp::read(input)?, &vtp::WriteOptions::default())
        }
        (Format::Vtp, Format::Stl) => stl::write(output, &vtp::read_mesh(input)?),
        (Format::Vtp, Format::Ply) => ply::write(output, &vtp::read_mesh(input)?),
        (Format::Landmarks, Format::Landmarks) => {
            let lm = markups::read(input)?;
            let name = output.to_string_lossy().to_ascii_lowercase();
            if name.ends_with(".mrk.json") {
                markups::write_mrk_json(output, &lm, frame)
            } else if name.ends_with(".fcsv") {
                markups::write_fcsv(output, &lm, frame)
            } else {
                markups::write_plain_json(output, &lm)
            }
        }
        _ => Err(Error::usage(format!(
            "cannot convert {} to {}: formats do not match",
            input.display(),
            output.display()
        ))),
    }
}

/// A volume of any readable format into NIfTI or NRRD, keeping its voxel
/// type where the writers have it (uint8, int16) and float32 otherwise;
/// beside it, `OUTPUT.provenance.json` says what it was made from.
fn convert_volume(input: &Path, output: &Path, to_nrrd: bool) -> Result<()> {
    let opts = nifti::ReadOptions::default();
    let h = volume_file::read_header(input, &opts)?;
    write_volume(input, output, to_nrrd, &h, &opts)?;
    let record = crate::pipeline::provenance::conversion(input, &h.format, output);
    let sidecar = crate::pipeline::provenance::sidecar_path(output);
    // Both or neither: a volume without its record would pass for one made
    // from nothing in particular.
    record
        .and_then(|r| {
            crate::io::write_atomic(&sidecar, |w| {
                use std::io::Write;
                w.write_all(serde_json::to_string_pretty(&r).expect("JSON").as_bytes())?;
                w.write_all(b"\n")
            })
        })
        .inspect_err(|_| {
            let _ = std::fs::remove_file(output);
        })
}

fn write_volume(
    input: &Path,
    output: &Path,
    to_nrrd: bool,
    h: &volume_file::VolumeHeader,
    opts: &nifti::ReadOptions,
) -> Result<()> {
    macro_rules! write_as {
        ($t:ty) => {{
            let v = volume_file::read::<$t>(input, opts)?;
            if to_nrrd {
                nrrd::write(output, &v)
            } else {
                nifti::write(output, &v)
            }
        }};
    }
    match h.datatype {
        nifti::DataType::U8 => write_as!(u8),
        nifti::DataType::I16 | nifti::DataType::I8 => write_as!(i16),
        _ => write_as!(f32),
    }
}
