//! Where each slice of a DICOM file lies: a single-frame image's own
//! attributes, or every frame of a multi-frame (enhanced) CT image from its
//! functional groups — the frame's item of the Per-frame Functional Groups
//! Sequence first, then the Shared Functional Groups Sequence, each in the
//! sub-sequence the standard puts the attribute in (Plane Position, Plane
//! Orientation, Pixel Measures, Pixel Value Transformation).

use std::path::Path;

use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;
use dicom_object::mem::InMemElement;

use super::scan::Slice;

/// Where one frame's attributes are looked up.
struct Lookup<'a> {
    top: &'a InMemDicomObject,
    /// The frame's per-frame item, then the shared item (multi-frame only).
    groups: [Option<&'a InMemDicomObject>; 2],
}

impl<'a> Lookup<'a> {
    /// `tag` from the functional group sequence `seq` (per-frame before
    /// shared), else from the top level of the data set.
    fn get(&self, seq: Tag, tag: Tag) -> Option<&'a InMemElement> {
        self.groups
            .iter()
            .flatten()
            .find_map(|g| first_item(g, seq).and_then(|item| item.get(tag)))
            .or_else(|| self.top.get(tag))
    }
}

fn first_item(obj: &InMemDicomObject, seq: Tag) -> Option<&InMemDicomObject> {
    obj.get(seq)?.items()?.first()
}

/// The slices `obj` (read from `path`) holds — one per frame — and whether
/// it is a localiser (ImageType, or an enhanced frame's Frame Type, says
/// LOCALIZER); or why its geometry cannot be read.
pub fn slices_of(obj: &InMemDicomObject, path: &Path) -> Result<(Vec<Slice>, bool), String> {
    let frames = match obj.get(tags::NUMBER_OF_FRAMES) {
        None => 1,
        Some(e) => e
            .to_int::<u32>()
            .ok()
            .filter(|&n| n >= 1)
            .ok_or("Number of Frames is not a whole number ≥ 1")?,
    };
    let mut localiser = upper_text(obj.get(tags::IMAGE_TYPE)).contains("LOCALIZER");
    let per_frame = obj
        .get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .and_then(|e| e.items());
    let Some(per_frame) = per_frame else {
        if frames > 1 {
            // Without functional groups nothing says where frame 2 lies
            // (Image Position (Patient) is the first frame's).
            return Err(format!(
                "has {frames} frames but no Per-frame Functional Groups Sequence, so where \
                 each frame lies is unknown; coapt reads enhanced (and legacy converted \
                 enhanced) CT multi-frame images and single-frame series: export the series \
                 as single-frame images, or convert it with dcm2niix"
            ));
        }
        let top = Lookup {
            top: obj,
            groups: [None, None],
        };
        return Ok((vec![slice(&top, path, None)?], localiser));
    };
    if per_frame.len() != frames as usize {
        return Err(format!(
            "Number of Frames is {frames} but the Per-frame Functional Groups Sequence has {} \
             items: the file is inconsistent",
            per_frame.len()
        ));
    }
    let shared = first_item(obj, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
    let mut out = Vec::with_capacity(per_frame.len());
    for (f, item) in per_frame.iter().enumerate() {
        let look = Lookup {
            top: obj,
            groups: [Some(item), shared],
        };
        let frame_type = upper_text(look.get(tags::CT_IMAGE_FRAME_TYPE_SEQUENCE, tags::FRAME_TYPE));
        localiser |= frame_type.contains("LOCALIZER");
        out.push(slice(&look, path, Some(f as u32)).map_err(|p| format!("frame {}: {p}", f + 1))?);
    }
    Ok((out, localiser))
}

fn upper_text(e: Option<&InMemElement>) -> String {
    e.and_then(|e| e.to_str().ok())
        .map(|s| s.to_ascii_uppercase())
        .unwrap_or_default()
}

fn numbers(e: Option<&InMemElement>, name: &str, n: usize) -> Result<Vec<f64>, String> {
    let e = e.ok_or_else(|| format!("{name} is missing"))?;
    let v = e
        .to_multi_float64()
        .map_err(|_| format!("{name} is not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{name} must hold {n} finite numbers, has {v:?}"));
    }
    Ok(v)
}

fn slice(look: &Lookup, path: &Path, frame: Option<u32>) -> Result<Slice, String> {
    let p = numbers(
        look.get(tags::PLANE_POSITION_SEQUENCE, tags::IMAGE_POSITION_PATIENT),
        "Image Position (Patient)",
        3,
    )?;
    let o = numbers(
        look.get(
            tags::PLANE_ORIENTATION_SEQUENCE,
            tags::IMAGE_ORIENTATION_PATIENT,
        ),
        "Image Orientation (Patient)",
        6,
    )?;
    let sp = numbers(
        look.get(tags::PIXEL_MEASURES_SEQUENCE, tags::PIXEL_SPACING),
        "Pixel Spacing",
        2,
    )?;
    let int = |tag, name: &str| -> Result<u32, String> {
        look.top
            .get(tag)
            .ok_or_else(|| format!("{name} is missing"))?
            .to_int::<u32>()
            .map_err(|_| format!("{name} is not a whole number"))
    };
    let rescale = |tag, default: f64| -> Result<f64, String> {
        match look.get(tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, tag) {
            None => Ok(default),
            Some(e) => e
                .to_float64()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| "Rescale Slope/Intercept is not a number".to_string()),
        }
    };
    Ok(Slice {
        path: path.to_path_buf(),
        frame,
        position: [p[0], p[1], p[2]],
        orientation: [o[0], o[1], o[2], o[3], o[4], o[5]],
        pixel_spacing: [sp[0], sp[1]],
        rows: int(tags::ROWS, "Rows")?,
        columns: int(tags::COLUMNS, "Columns")?,
        slope: rescale(tags::RESCALE_SLOPE, 1.0)?,
        intercept: rescale(tags::RESCALE_INTERCEPT, 0.0)?,
    })
}
