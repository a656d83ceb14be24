//! Finding the series in a folder: every file's header (up to the pixel
//! data, which is not read here), grouped by SeriesInstanceUID.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::file::ReadPreamble;
use dicom_object::{DefaultDicomObject, OpenFileOptions};

use coapt_base::{Error, Result};

/// Files looked at in one folder tree; a CT series has some hundreds, a
/// whole study some thousands.
const MAX_FILES: usize = 100_000;
/// Sub-folder depth searched (PACS exports nest patient/study/series).
const MAX_DEPTH: usize = 6;

/// What one image (or one frame of a multi-frame image) says about its
/// place in a volume.
#[derive(Debug, Clone)]
pub struct Slice {
    pub path: PathBuf,
    /// The frame (0-based) of a multi-frame file; `None` for a single-frame
    /// image.
    pub frame: Option<u32>,
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
}

impl Slice {
    /// The file, and the frame in it when it has several, for messages.
    pub fn place(&self) -> String {
        match self.frame {
            None => self.path.display().to_string(),
            Some(f) => format!("{} (frame {})", self.path.display(), f + 1),
        }
    }
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
    /// The first image's SOP Class UID (CT Image Storage, Enhanced CT,
    /// Secondary Capture…).
    pub sop_class: String,
    /// Some image has no Pixel Data (a dose report, a presentation state).
    pub without_pixels: bool,
    /// DICOM files holding the series' images.
    pub files: usize,
    pub transfer_syntax: String,
    pub slices: Vec<Slice>,
    /// Images whose geometry could not be read, and why.
    pub problems: Vec<(PathBuf, String)>,
}

impl Series {
    /// Images (frames of multi-frame files counted one by one), readable or not.
    pub fn images(&self) -> usize {
        self.slices.len() + self.problems.len()
    }

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
            "number {n}, UID {}{desc}, {} {} image{}{}{}",
            self.uid,
            self.modality,
            self.images(),
            if self.images() == 1 { "" } else { "s" },
            if self.files == 1 && self.slices.len() > 1 {
                " in one multi-frame file"
            } else {
                ""
            },
            if self.localiser { ", localiser" } else { "" }
        )
    }
}

/// A DICOM file's header, after [`super::lengths::check`] has bounded what
/// parsing it can allocate, and whether it holds Pixel Data; `Ok(None)` for
/// a file that is not DICOM (no `DICM` marker). `max_bytes` bounds the file
/// (and an inflated data set).
pub fn open_checked(
    path: &Path,
    max_bytes: u64,
    until_pixels: bool,
) -> Result<Option<(DefaultDicomObject, bool)>> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::read(path, e))?
        .len();
    let mut head = [0u8; 132];
    let n = std::fs::File::open(path)
        .and_then(|mut f| crate::nifti::read_full(&mut f, &mut head))
        .map_err(|e| Error::read(path, e))?;
    if n < 132 || &head[128..132] != b"DICM" {
        return Ok(None);
    }
    if len > max_bytes {
        return Err(Error::bad_input(
            path,
            format!(
                "a DICOM file of {len} bytes, above the limit of {max_bytes} bytes for one file"
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    let has_pixels = super::lengths::check(&bytes, max_bytes)
        .map_err(|p| Error::bad_input(path, format!("corrupt DICOM file: {p}")))?;
    let mut opts = OpenFileOptions::new().read_preamble(ReadPreamble::Always);
    if until_pixels {
        opts = opts.read_until(tags::PIXEL_DATA);
    }
    opts.open_file(path)
        .map(|obj| Some((obj, has_pixels)))
        .map_err(|e| Error::bad_input(path, format!("not a readable DICOM file: {e}")))
}

/// The series in `dir` (sub-folders included; or `dir` itself, a single
/// multi-frame file), in SeriesNumber order, and how many files were not
/// DICOM. Every DICOM file's element lengths are checked first (see
/// [`super::lengths`]).
pub fn scan(dir: &Path, max_bytes: u64) -> Result<(Vec<Series>, usize)> {
    let mut files = Vec::new();
    if dir.is_dir() {
        walk(dir, 0, &mut files)?;
    } else {
        files.push(dir.to_path_buf());
    }
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
        let Some((obj, has_pixels)) = open_checked(&path, max_bytes, true)? else {
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
        let ts = obj
            .meta()
            .transfer_syntax()
            .trim_end_matches('\0')
            .to_string();
        let s = by_uid.entry(uid.clone()).or_insert_with(|| Series {
            uid,
            number: text(&obj, tags::SERIES_NUMBER).trim().parse().ok(),
            description: text(&obj, tags::SERIES_DESCRIPTION),
            modality: text(&obj, tags::MODALITY),
            localiser: false,
            sop_class: obj
                .meta()
                .media_storage_sop_class_uid()
                .trim_end_matches('\0')
                .to_string(),
            without_pixels: false,
            files: 0,
            transfer_syntax: ts.clone(),
            slices: Vec::new(),
            problems: Vec::new(),
        });
        s.files += 1;
        s.without_pixels |= !has_pixels;
        if let Some(why) = super::syntax::refusal(&ts) {
            s.problems.push((path, why));
            continue;
        }
        match super::frames::slices_of(&obj, &path) {
            Ok((slices, localiser)) => {
                s.localiser |= localiser;
                s.slices.extend(slices);
            }
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
