//! Finding the series in a folder: every file's header (up to the pixel
//! data, which is not read here), grouped by SeriesInstanceUID.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::file::ReadPreamble;
use dicom_object::{DefaultDicomObject, OpenFileOptions};

use crate::{Error, Result};

/// Files looked at in one folder tree; a CT series has some hundreds, a
/// whole study some thousands.
const MAX_FILES: usize = 100_000;
/// Sub-folder depth searched (PACS exports nest patient/study/series).
const MAX_DEPTH: usize = 6;

/// What one image's header says about its place in a volume.
#[derive(Debug, Clone)]
pub struct Slice {
    pub path: PathBuf,
    /// Image Position (Patient): the centre of the first pixel, LPS mm.
    pub position: [f64; 3],
    /// Image Orientation (Patient): row direction (along a row, i.e. with
    /// the column index), then column direction.
    pub orientation: [f64; 6],
    /// Pixel Spacing: between rows, then between columns (mm).
    pub pixel_spacing: [f64; 2],
    pub rows: u32,
    pub columns: u32,
    pub slope: f64,
    pub intercept: f64,
    pub frames: u32,
}

/// One series as found in the folder.
#[derive(Debug, Clone)]
pub struct Series {
    pub uid: String,
    pub number: Option<i64>,
    pub description: String,
    pub modality: String,
    /// Some image is a localiser (scout, topogram).
    pub localiser: bool,
    pub transfer_syntax: String,
    pub slices: Vec<Slice>,
    /// Images whose geometry could not be read, and why.
    pub problems: Vec<(PathBuf, String)>,
}

impl Series {
    /// "3 (1.2.840…): CTA 0.6 mm ART" for messages.
    pub fn label(&self) -> String {
        let n = self
            .number
            .map(|n| n.to_string())
            .unwrap_or_else(|| "-".into());
        let desc = if self.description.is_empty() {
            String::new()
        } else {
            format!(" \"{}\"", self.description)
        };
        format!(
            "number {n}, UID {}{desc}, {} {} image{}{}",
            self.uid,
            self.modality,
            self.slices.len() + self.problems.len(),
            if self.slices.len() + self.problems.len() == 1 {
                ""
            } else {
                "s"
            },
            if self.localiser { ", localiser" } else { "" }
        )
    }
}

/// A DICOM file's header, after [`super::lengths::check`] has bounded what
/// parsing it can allocate; `Ok(None)` for a file that is not DICOM (no
/// `DICM` marker). `max_bytes` bounds the file (and an inflated data set).
pub fn open_checked(
    path: &Path,
    max_bytes: u64,
    until_pixels: bool,
) -> Result<Option<DefaultDicomObject>> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::read(path, e))?
        .len();
    let mut head = [0u8; 132];
    let n = std::fs::File::open(path)
        .and_then(|mut f| crate::io::nifti::read_full(&mut f, &mut head))
        .map_err(|e| Error::read(path, e))?;
    if n < 132 || &head[128..132] != b"DICM" {
        return Ok(None);
    }
    if len > max_bytes {
        return Err(Error::bad_input(
            path,
            format!(
                "a DICOM file of {len} bytes, above the limit of {max_bytes} bytes for one image"
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    super::lengths::check(&bytes, max_bytes)
        .map_err(|p| Error::bad_input(path, format!("corrupt DICOM file: {p}")))?;
    let mut opts = OpenFileOptions::new().read_preamble(ReadPreamble::Always);
    if until_pixels {
        opts = opts.read_until(tags::PIXEL_DATA);
    }
    opts.open_file(path)
        .map(Some)
        .map_err(|e| Error::bad_input(path, format!("not a readable DICOM file: {e}")))
}

/// The series in `dir` (sub-folders included), in SeriesNumber order, and
/// how many files were not DICOM. Every DICOM file's element lengths are
/// checked first (see [`super::lengths`]).
pub fn scan(dir: &Path, max_bytes: u64) -> Result<(Vec<Series>, usize)> {
    let mut files = Vec::new();
    walk(dir, 0, &mut files)?;
    if files.len() > MAX_FILES {
        return Err(Error::bad_input(
            dir,
            format!("holds more than {MAX_FILES} files; point coapt at the folder of one series"),
        ));
    }
    files.sort();
    let mut by_uid: BTreeMap<String, Series> = BTreeMap::new();
    let mut other = 0;
    for path in files {
        let Some(obj) = open_checked(&path, max_bytes, true)? else {
            // Notes, thumbnails…: not DICOM.
            other += 1;
            continue;
        };
        if obj
            .element_opt(tags::SERIES_INSTANCE_UID)
            .ok()
            .flatten()
            .is_none()
            || obj
                .meta()
                .media_storage_sop_class_uid()
                .starts_with("1.2.840.10008.1.3.10")
        {
            other += 1;
            continue;
        }
        let uid = text(&obj, tags::SERIES_INSTANCE_UID);
        let s = by_uid.entry(uid.clone()).or_insert_with(|| Series {
            uid,
            number: text(&obj, tags::SERIES_NUMBER).trim().parse().ok(),
            description: text(&obj, tags::SERIES_DESCRIPTION),
            modality: text(&obj, tags::MODALITY),
            localiser: false,
            transfer_syntax: obj
                .meta()
                .transfer_syntax()
                .trim_end_matches('\0')
                .to_string(),
            slices: Vec::new(),
            problems: Vec::new(),
        });
        let image_type = text(&obj, tags::IMAGE_TYPE).to_ascii_uppercase();
        if image_type.contains("LOCALIZER") {
            s.localiser = true;
        }
        match slice(&obj, &path) {
            Ok(sl) => s.slices.push(sl),
            Err(p) => s.problems.push((path, p)),
        }
    }
    let mut series: Vec<Series> = by_uid.into_values().collect();
    series.sort_by(|a, b| a.number.cmp(&b.number).then(a.uid.cmp(&b.uid)));
    Ok((series, other))
}

fn walk(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::read(dir, e))?;
    for e in entries {
        let e = e.map_err(|e| Error::read(dir, e))?;
        let path = e.path();
        let ty = e.file_type().map_err(|e| Error::read(&path, e))?;
        if ty.is_dir() && depth < MAX_DEPTH {
            walk(&path, depth + 1, out)?;
        } else if ty.is_file() {
            out.push(path);
        }
        if out.len() > MAX_FILES {
            return Ok(());
        }
    }
    Ok(())
}

/// An attribute as trimmed text ("" when absent or unreadable).
fn text(obj: &DefaultDicomObject, tag: dicom_core::Tag) -> String {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim_matches([' ', '\0']).to_string())
        .unwrap_or_default()
}

fn numbers(
    obj: &DefaultDicomObject,
    tag: dicom_core::Tag,
    name: &str,
    n: usize,
) -> std::result::Result<Vec<f64>, String> {
    let e = obj
        .element_opt(tag)
        .ok()
        .flatten()
        .ok_or_else(|| format!("{name} is missing"))?;
    let v = e
        .to_multi_float64()
        .map_err(|_| format!("{name} is not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{name} must hold {n} finite numbers, has {v:?}"));
    }
    Ok(v)
}

fn slice(obj: &DefaultDicomObject, path: &Path) -> std::result::Result<Slice, String> {
    let p = numbers(
        obj,
        tags::IMAGE_POSITION_PATIENT,
        "Image Position (Patient)",
        3,
    )?;
    let o = numbers(
        obj,
        tags::IMAGE_ORIENTATION_PATIENT,
        "Image Orientation (Patient)",
        6,
    )?;
    let sp = numbers(obj, tags::PIXEL_SPACING, "Pixel Spacing", 2)?;
    let int = |tag, name: &str| -> std::result::Result<u32, String> {
        obj.element_opt(tag)
            .ok()
            .flatten()
            .ok_or_else(|| format!("{name} is missing"))?
            .to_int::<u32>()
            .map_err(|_| format!("{name} is not a whole number"))
    };
    let opt = |tag, default: f64| -> std::result::Result<f64, String> {
        match obj.element_opt(tag).ok().flatten() {
            None => Ok(default),
            Some(e) => e
                .to_float64()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| "Rescale Slope/Intercept is not a number".to_string()),
        }
    };
    let frames = match obj.element_opt(tags::NUMBER_OF_FRAMES).ok().flatten() {
        None => 1,
        Some(e) => e.to_int::<u32>().unwrap_or(0),
    };
    Ok(Slice {
        path: path.to_path_buf(),
        position: [p[0], p[1], p[2]],
        orientation: [o[0], o[1], o[2], o[3], o[4], o[5]],
        pixel_spacing: [sp[0], sp[1]],
        rows: int(tags::ROWS, "Rows")?,
        columns: int(tags::COLUMNS, "Columns")?,
        slope: opt(tags::RESCALE_SLOPE, 1.0)?,
        intercept: opt(tags::RESCALE_INTERCEPT, 0.0)?,
        frames,
    })
}
