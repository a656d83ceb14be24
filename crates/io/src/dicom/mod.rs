//! DICOM CT: a folder of single-frame CT images, as a PACS exports them,
//! or one multi-frame (enhanced) CT file, read with dicom-rs.
//!
//! The images are grouped by SeriesInstanceUID; a folder holding several
//! series needs a choice (`--series UID|NUMBER`). The chosen series' slices
//! (a multi-frame file's frames, each placed by its functional groups) are
//! ordered by Image Position (Patient) projected on the slice normal, the
//! slice step comes from the positions, the direction cosines and spacings
//! make the LPS affine (DICOM's patient frame is LPS), and each slice's
//! Rescale Slope/Intercept turns stored values into HU. Refused with a
//! message: a non-CT modality, localisers, missing slices, uneven steps,
//! gantry tilt (sheared stacks), images of different sizes or orientations,
//! multi-frame files without functional groups.
//!
//! Transfer syntaxes: see [`syntax`] (uncompressed, deflated, RLE and JPEG
//! lossless are read; JPEG baseline is refused because 8 bits cannot hold
//! HU; JPEG-LS, JPEG 2000, JPEG XL, HTJ2K and video are not decoded), and
//! [`pixels`] for who decodes what.

mod choose;
mod frames;
mod geometry;
mod lengths;
mod pixels;
mod scan;
mod syntax;

use std::path::Path;

use dicom_object::DefaultDicomObject;
use nalgebra::Matrix4;

pub use choose::{Chosen, choose, implausible};
pub use scan::{Series, Slice, scan};

use super::nifti::{MAX_AXIS, NiftiRead, ReadOptions, SPACING_MM};
use coapt_base::{Error, Result};
use coapt_geom::Volume;

/// The refusal of a folder without DICOM images (`other` files in it).
pub fn no_images(dir: &Path, other: usize) -> Error {
    Error::bad_input(
        dir,
        format!(
            "holds no DICOM images ({other} other file{} looked at); coapt reads a CT as {}",
            if other == 1 { "" } else { "s" },
            super::volume_file::ACCEPTED
        ),
    )
}

/// A series checked to be one regular CT grid, ready to decode.
pub struct Plan {
    pub series: Series,
    /// How the series was chosen among those in the folder.
    pub chosen: Chosen,
    /// Slice indices into `series.slices`, in grid order (k).
    order: Vec<usize>,
    pub dims: [usize; 3],
    pub affine_lps: Matrix4<f64>,
}

/// Scan `dir`, choose the series `pick`, and check everything but the
/// pixels: a CT, no localiser, single-frame, one regular grid, within the
/// size and spacing limits for voxels of `bytes_per_voxel`.
pub fn plan(
    dir: &Path,
    pick: Option<&str>,
    opts: &ReadOptions,
    bytes_per_voxel: usize,
) -> Result<Plan> {
    let (series, other) = scan(dir, opts.max_bytes)?;
    if series.is_empty() {
        return Err(no_images(dir, other));
    }
    let (s, chosen) = choose(dir, &series, pick)?;
    let bad = |p: String| Error::bad_input(dir, format!("series {}: {p}", s.uid));
    if s.modality != "CT" {
        return Err(bad(format!(
            "modality is {:?}, not CT; coapt segments contrast CT angiograms",
            s.modality
        )));
    }
    if s.localiser {
        return Err(bad(
            "holds localiser (scout) images, not a volume; choose the CT series".into(),
        ));
    }
    if let Some((path, p)) = s.problems.first() {
        return Err(Error::bad_input(
            path,
            format!("image of series {}: {p}", s.uid),
        ));
    }
    if dir.is_file() && s.slices.len() == 1 && s.slices[0].frame.is_none() {
        return Err(Error::bad_input(
            dir,
            "is a single-frame DICOM image (one slice); give coapt the folder that holds its \
             series",
        ));
    }
    let (order, affine) = geometry::grid(&s.slices).map_err(bad)?;
    let (cols, rows, n) = (
        s.slices[order[0]].columns as usize,
        s.slices[order[0]].rows as usize,
        order.len(),
    );
    let dims = [cols, rows, n];
    if let Some(a) = (0..3).find(|&a| dims[a] == 0 || dims[a] as u64 > MAX_AXIS) {
        return Err(bad(format!(
            "its grid is {cols}×{rows}×{n}: axis {} is 0 or more than {MAX_AXIS}",
            a + 1
        )));
    }
    for c in 0..3 {
        let d = affine.fixed_view::<3, 1>(0, c).norm();
        if !(SPACING_MM.0..=SPACING_MM.1).contains(&d) {
            return Err(bad(format!(
                "voxel spacing along axis {} is {d:e} mm; a CT's lies in {}–{} mm",
                c + 1,
                SPACING_MM.0,
                SPACING_MM.1
            )));
        }
    }
    coapt_geom::volume::check_affine(&affine).map_err(|e| bad(e.to_string()))?;
    let bytes = (cols * rows) as u128 * n as u128 * bytes_per_voxel as u128;
    if bytes > opts.max_bytes as u128 {
        return Err(bad(format!(
            "{cols}×{rows}×{n} voxels take {bytes} bytes, above the limit of {} bytes; \
             raise it with the environment variable {}=<bytes> if the series is genuine",
            opts.max_bytes,
            super::nifti::MAX_BYTES_ENV
        )));
    }
    Ok(Plan {
        series: s.clone(),
        chosen,
        order,
        dims,
        affine_lps: affine,
    })
}

/// Read the series `pick` of the folder (or multi-frame file) `dir` as `T`.
pub fn read<T: NiftiRead>(dir: &Path, pick: Option<&str>, opts: &ReadOptions) -> Result<Volume<T>> {
    let plan = plan(dir, pick, opts, std::mem::size_of::<T>())?;
    let per = plan.dims[0] * plan.dims[1];
    let mut out = vec![T::default(); per * plan.dims[2]];
    // A multi-frame file's frames come one after the other: open it once.
    let mut open: Option<(&Path, DefaultDicomObject)> = None;
    for (k, &i) in plan.order.iter().enumerate() {
        let sl = &plan.series.slices[i];
        if open.as_ref().map(|(p, _)| *p) != Some(sl.path.as_path()) {
            let (obj, _) = scan::open_checked(&sl.path, opts.max_bytes, false)?
                .ok_or_else(|| Error::bad_input(&sl.path, "is no longer a DICOM file"))?;
            open = Some((&sl.path, obj));
        }
        let (_, obj) = open.as_ref().expect("opened above");
        decode_slice(sl, obj, &mut out[k * per..(k + 1) * per], k)?;
    }
    Volume::from_fortran_vec(plan.dims, plan.affine_lps, out).map_err(|e| e.in_file(dir))
}

/// One image's (or frame's) pixels, rescaled to HU, into `out` (row after
/// row).
fn decode_slice<T: NiftiRead>(
    sl: &Slice,
    obj: &DefaultDicomObject,
    out: &mut [T],
    k: usize,
) -> Result<()> {
    let bad = |p: String| Error::bad_input(&sl.path, p);
    let ts = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches('\0')
        .to_string();
    if let Some(why) = syntax::refusal(&ts) {
        return Err(bad(why));
    }
    let px = pixels::decode(obj, sl, &ts).map_err(|e| {
        let at = sl
            .frame
            .map(|f| format!(" of frame {}", f + 1))
            .unwrap_or_default();
        bad(format!(
            "cannot decode the pixel data{at} (transfer syntax {ts}): {e}; the file is damaged, \
             or encoded in a way coapt's decoders do not cover: convert the series with \
             dcm2niix or `gdcmconv --raw`"
        ))
    })?;
    if px.raw.len() != out.len() {
        return Err(bad(format!(
            "pixel data hold {} samples where {} pixels are needed",
            px.raw.len(),
            out.len()
        )));
    }
    let cols = sl.columns as usize;
    // Bits above Bits Stored carry nothing (or an overlay): mask them, and
    // sign-extend signed values from their top stored bit.
    let unused = 64 - px.bits_stored;
    let fix = |raw: u64| -> f64 {
        if px.signed {
            (((raw << unused) as i64) >> unused) as f64
        } else {
            ((raw << unused) >> unused) as f64
        }
    };
    for (idx, (o, &raw)) in out.iter_mut().zip(&px.raw).enumerate() {
        let stored = fix(raw);
        let v = stored * sl.slope + sl.intercept;
        *o = T::from_f64(v).ok_or_else(|| {
            bad(format!(
                "pixel [{}, {}] of slice {k} is {v} after Rescale Slope/Intercept, but reading \
                 as {} needs {}",
                idx % cols,
                idx / cols,
                T::DATATYPE.name(),
                T::RANGE
            ))
        })?;
    }
    Ok(())
}
