//! The CT as users hand it over: one entry point for every volume format
//! coapt reads, chosen by the file's content (and, for headers whose data
//! live elsewhere, its name).
//!
//! | format | files | read by |
//! |---|---|---|
//! | NIfTI-1/2 | `.nii`, `.nii.gz` | [`super::nifti`] |
//! | NRRD | `.nrrd` (attached), `.nhdr` + data file | [`super::nrrd`] |
//! | MetaImage | `.mha` (attached), `.mhd` + data file | [`super::metaimage`] |
//! | DICOM | a folder holding a CT series, or one multi-frame CT file | [`super::dicom`] |
//!
//! Every reader validates its header in full (sizes, byte limit, spacing
//! bounds, a usable affine) before it allocates, and returns the volume with
//! its voxel→world affine in LPS.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use nalgebra::Matrix4;

use super::nifti::{self, DataType, NiftiRead, ReadOptions};
use super::raw_voxels::{self, Layout};
use super::{dicom, metaimage, nrrd};
use coapt_base::{Error, Result};
use coapt_geom::Volume;

/// The volume formats coapt reads, for messages that list them.
pub const ACCEPTED: &str = "NIfTI-1/2 (.nii, .nii.gz), NRRD (.nrrd, or .nhdr with its data \
    file), MetaImage (.mha, or .mhd with its data file), a folder holding a DICOM CT series or \
    a multi-frame (enhanced) DICOM CT file";

/// The DICOM series chosen with `--series` (UID or SeriesNumber), for
/// folders that hold several. Set once by the command line.
static SERIES: OnceLock<String> = OnceLock::new();

/// Choose the DICOM series read from folders that hold several; a second,
/// different choice in the same process (`--series` and a run config's
/// `series`) is refused with the first.
pub fn set_series(pick: &str) -> std::result::Result<(), String> {
    match SERIES.get_or_init(|| pick.to_string()) {
        p if p == pick => Ok(()),
        p => Err(p.clone()),
    }
}

/// The series chosen with `--series`, if any.
pub fn series_choice() -> Option<&'static str> {
    SERIES.get().map(String::as_str)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Nifti,
    Nrrd,
    MetaImage,
    /// A folder holding a DICOM series, or one multi-frame DICOM file.
    Dicom,
}

/// A volume's header, validated: everything but the voxels.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeHeader {
    /// "NIfTI-1", "NIfTI-2", "NRRD", "MetaImage".
    pub format: String,
    pub dims: [usize; 3],
    pub datatype: DataType,
    /// Voxel index → world LPS millimetres.
    pub affine_lps: Matrix4<f64>,
    /// Where the affine came from: the NIfTI transform used (sform, qform,
    /// pixdim), or the NRRD/MetaImage file's own space (LPS, RAS, LAS).
    pub transform: String,
    /// The file holding the voxels, when it is not the header itself.
    pub data_file: Option<PathBuf>,
    /// How the voxel data are encoded (raw, gzip, zlib).
    pub encoding: String,
}

/// The format of `path`: a folder is a DICOM series; a file is judged by
/// its content, and by its name only when the content is not recognisable
/// (so a corrupt `.nhdr` gets the NRRD reader's message, not a generic one).
pub fn sniff(path: &Path) -> Result<Format> {
    if path.is_dir() {
        return Ok(Format::Dicom);
    }
    let mut head = Vec::with_capacity(512);
    File::open(path)
        .map_err(|e| Error::read(path, e))?
        .take(512)
        .read_to_end(&mut head)
        .map_err(|e| Error::read(path, e))?;
    if head.starts_with(b"NRRD000") {
        return Ok(Format::Nrrd);
    }
    if head.len() >= 132 && &head[128..132] == b"DICM" {
        // A multi-frame (enhanced) CT file is a whole series; a lone
        // single-frame image is refused by the DICOM reader, naming it.
        return Ok(Format::Dicom);
    }
    let first_line = head
        .split(|&b| b == b'\n')
        .next()
        .and_then(|l| std::str::from_utf8(l).ok())
        .unwrap_or("");
    if metaimage::looks_like(first_line) {
        return Ok(Format::MetaImage);
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let sizeof_hdr = head
        .get(..4)
        .map(|b| {
            let b: [u8; 4] = b.try_into().expect("4 bytes");
            [i32::from_le_bytes(b), i32::from_be_bytes(b)]
        })
        .is_some_and(|s| s.iter().any(|&n| n == 348 || n == 540));
    let gzip = head.starts_with(&[0x1f, 0x8b]);
    if gzip || sizeof_hdr || name.ends_with(".nii") || name.ends_with(".nii.gz") {
        return Ok(Format::Nifti);
    }
    if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        return Ok(Format::Nrrd);
    }
    if name.ends_with(".mha") || name.ends_with(".mhd") {
        return Ok(Format::MetaImage);
    }
    let what = if head.is_empty() {
        "is empty (0 bytes)".to_string()
    } else {
        "is not a volume coapt recognises".to_string()
    };
    Err(Error::bad_input(
        path,
        format!("{what}; coapt reads {ACCEPTED}"),
    ))
}

/// The layout of a NRRD or MetaImage file (validated).
fn layout(path: &Path, format: Format, opts: &ReadOptions) -> Result<Layout> {
    match format {
        Format::Nrrd => nrrd::layout(path, opts.max_bytes),
        Format::MetaImage => metaimage::layout(path, opts.max_bytes),
        Format::Nifti | Format::Dicom => unreachable!("only NRRD and MetaImage have a text layout"),
    }
}

/// Read and validate the header only (and, for raw data, check the data
/// file holds exactly the bytes it should); no voxel allocation.
pub fn read_header(path: &Path, opts: &ReadOptions) -> Result<VolumeHeader> {
    let format = sniff(path)?;
    if format == Format::Nifti {
        let h = nifti::read_header_with(path, opts)?;
        return Ok(VolumeHeader {
            format: format!("NIfTI-{}", h.version),
            dims: h.dims,
            datatype: h.datatype,
            affine_lps: h.affine_lps,
            transform: h.transform_source.to_string(),
            data_file: None,
            encoding: if gzipped(path) { "gzip" } else { "raw" }.into(),
        });
    }
    if format == Format::Dicom {
        let p = dicom::plan(path, series_choice(), opts, 2)?;
        return Ok(VolumeHeader {
            format: "DICOM".into(),
            dims: p.dims,
            datatype: DataType::I16,
            affine_lps: p.affine_lps,
            transform: format!("series {}", p.series.uid),
            data_file: None,
            encoding: p.series.transfer_syntax.clone(),
        });
    }
    let l = layout(path, format, opts)?;
    raw_voxels::check_data(path, &l)?;
    Ok(VolumeHeader {
        format: l.format.to_string(),
        dims: l.dims,
        datatype: l.datatype,
        affine_lps: l.affine_lps,
        transform: format!("space {}", l.file_space),
        data_file: l.detached(path).then(|| l.data_file.clone()),
        encoding: l.encoding.name().into(),
    })
}

/// Whether the file starts with the gzip magic (the NIfTI reader decides
/// by content too, whatever the name says).
fn gzipped(path: &Path) -> bool {
    let mut magic = [0u8; 2];
    File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok_and(|_| magic == [0x1f, 0x8b])
}

/// Read a volume of any accepted format as `T`, converting from any stored
/// numeric type (integer targets need exact, in-range values).
pub fn read<T: NiftiRead>(path: &Path, opts: &ReadOptions) -> Result<Volume<T>> {
    match sniff(path)? {
        Format::Nifti => nifti::read_with(path, opts),
        Format::Dicom => dicom::read(path, series_choice(), opts),
        f => raw_voxels::read(path, &layout(path, f, opts)?, opts),
    }
}

/// The CT, in Hounsfield units as int16 (what every stage works on), with
/// the default limits. Integer data must hold whole values. Float data,
/// which resampling tools (SimpleITK, nibabel, 3D Slicer's resample) often
/// write with fractional HU, are rounded to the nearest HU, far below a
/// CT's noise (25–60 HU), once every value is known to be finite and
/// within int16; a NaN or an out-of-range value is refused, naming its
/// voxel.
pub fn read_ct(path: &Path) -> Result<Volume<i16>> {
    let opts = ReadOptions::default();
    let float = sniff(path)? != Format::Dicom
        && matches!(
            read_header(path, &opts)?.datatype,
            DataType::F32 | DataType::F64
        );
    if !float {
        return read(path, &opts);
    }
    let v: Volume<f32> = read(path, &opts)?;
    let hu = rounded_hu(path, &v)?;
    tracing::info!("{}: float voxel data rounded to whole HU", path.display());
    Ok(hu)
}

/// `v` rounded to whole HU, or the first voxel that is not finite or not
/// within int16 once rounded.
fn rounded_hu(path: &Path, v: &Volume<f32>) -> Result<Volume<i16>> {
    let [ni, nj, _] = v.dims();
    let fits =
        |x: f32| x.is_finite() && (f32::from(i16::MIN)..=f32::from(i16::MAX)).contains(&x.round());
    if let Some((n, x)) = v.as_slice().iter().enumerate().find(|(_, x)| !fits(**x)) {
        let at = [n % ni, (n / ni) % nj, n / (ni * nj)];
        return Err(Error::bad_input(
            path,
            format!(
                "voxel {at:?} is {x} (float data): a CT needs a finite value within -32768..=32767 HU in every voxel"
            ),
        ));
    }
    Ok(v.map(|&x| x.round() as i16))
}

/// The DICOM series a volume was read from, for provenance.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeriesSource {
    pub uid: String,
    pub number: Option<i64>,
    pub description: String,
    /// Slices (frames of a multi-frame file counted one by one).
    pub slices: usize,
    /// How it was chosen among the folder's series.
    pub chosen: String,
}

/// The files a volume is made of: the file itself and, for a NRRD or
/// MetaImage header with detached data, its data file; for a DICOM folder,
/// the chosen series' files in name order (for provenance hashes). Anything
/// unreadable is left to the reader to report.
pub fn files_of(path: &Path) -> Vec<PathBuf> {
    source(path).0
}

/// [`files_of`], and for DICOM the series they hold.
pub fn source(path: &Path) -> (Vec<PathBuf>, Option<SeriesSource>) {
    let unbounded = ReadOptions {
        max_bytes: u64::MAX,
    };
    match sniff(path) {
        Ok(Format::Dicom) => {
            if let Ok(p) = dicom::plan(path, series_choice(), &unbounded, 2) {
                let mut files: Vec<PathBuf> =
                    p.series.slices.iter().map(|s| s.path.clone()).collect();
                files.sort();
                files.dedup();
                let s = &p.series;
                let series = SeriesSource {
                    uid: s.uid.clone(),
                    number: s.number,
                    description: s.description.clone(),
                    slices: s.slices.len(),
                    chosen: p.chosen.describe(),
                };
                return (files, Some(series));
            }
        }
        Ok(f @ (Format::Nrrd | Format::MetaImage)) => {
            if let Ok(l) = layout(path, f, &unbounded) {
                if l.detached(path) {
                    return (vec![path.to_path_buf(), l.data_file], None);
                }
            }
        }
        _ => {}
    }
    (vec![path.to_path_buf()], None)
}

#[cfg(test)]
mod tests;
