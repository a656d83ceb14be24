//! The `segment` stage: declaration and file output.

use serde_json::{Value as Json, json};

use super::stage_params::SegmentStageParams;
use super::{SegmentParams, segment};
use coapt_base::{Error, Result};
use coapt_geom::landmarks::Landmarks;
use coapt_geom::{Point3, Volume};
use coapt_io::{Transaction, markups, nifti, volume_file};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};

pub static SPEC: StageSpec = StageSpec {
    name: "segment",
    about: "Segment the aortic root and ascending aorta (Hough seed, isoperimetric distance tree, opening, VAJ cut)",
    inputs: &[
        Port {
            name: "ct",
            flag: "ct",
            file: "ct.nii.gz",
            kind: ArtifactKind::Volume,
            required: true,
            help: "contrast CT angiogram (HU)",
        },
        Port {
            name: "landmarks",
            flag: "landmarks",
            file: "landmarks.mrk.json",
            kind: ArtifactKind::SomeLandmarks,
            required: false,
            help: "optional, any of the valve's points: commissures C1–C3 seed the segmentation and bound its region, nadirs N1–N3 give the VAJ plane",
        },
    ],
    outputs: &[
        Port {
            name: "mask",
            flag: "out",
            file: "mask.nii.gz",
            kind: ArtifactKind::Mask,
            required: true,
            help: "aortic lumen from the VAJ up, uint8 0/1 on a cropped grid with its own exact affine",
        },
        Port {
            name: "segment_report",
            flag: "report",
            file: "segment.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "seed, radius, blood HU, threshold, chosen cut and why, volumes, timings",
        },
    ],
    out_dir: None,
    params: &[Param {
        name: "debug_dir",
        kind: ParamKind::Path,
        default: None,
        help: "write PNG slices with the mask contour and the top slice's circleness map here",
    }],
    check: |p| SegmentStageParams::try_from(p).map(|_| ()),
    run,
};

/// Smallest extent of a CT along any of its axes that can hold a root (mm).
const MIN_EXTENT_MM: f64 = 20.0;

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let sp = SegmentStageParams::try_from(params)?;
    let t0 = std::time::Instant::now();
    let ct_path = io.input("ct").expect("required input");
    let ct = volume_file::read_ct(ct_path)?;
    // A root is some 30 mm tall and wide: a scan narrower than that along
    // any axis cannot hold one (a 112 × 112 × 1 image made a one-slice
    // "aorta").
    let extent: Vec<f64> = ct
        .dims()
        .iter()
        .zip(ct.spacing())
        .map(|(&n, s)| n as f64 * s)
        .collect();
    if let Some(k) = (0..3).find(|&k| extent[k] < MIN_EXTENT_MM) {
        return Err(Error::bad_input(
            ct_path,
            format!(
                "the CT covers {:.1} mm along its axis {} ({} voxels of {:.2} mm); an aortic root needs at least {MIN_EXTENT_MM} mm in every direction",
                extent[k],
                k + 1,
                ct.dims()[k],
                ct.spacing()[k]
            ),
        ));
    }
    let lm = match io.input("landmarks") {
        Some(p) => {
            let lm = markups::read(p)?;
            check_commissures(&ct, &lm).map_err(|e| Error::bad_input(p, e))?;
            Some(lm)
        }
        None => None,
    };
    let read_s = t0.elapsed().as_secs_f64();
    progress.set(0.1);
    let seg = segment(&ct, lm.as_ref(), &SegmentParams::default())?;
    progress.set(0.9);
    let t1 = std::time::Instant::now();
    let mut report = serde_json::to_value(&seg.report).expect("report serialises");
    if let Json::Object(m) = &mut report {
        m.insert("frame".into(), json!("LPS"));
    }
    let text = serde_json::to_string_pretty(&report).expect("report serialises") + "\n";
    let mut tx = Transaction::new();
    tx.write(io.output("mask"), |w| nifti::encode(w, &seg.mask, true))?;
    tx.write_bytes(io.output("segment_report"), text.as_bytes())?;
    tx.commit()?;
    // Debug images are not artifacts of the chain: written after the
    // outputs, outside the transaction.
    let debug = match &sp.debug_dir {
        Some(d) => super::debug_png::write_all(d, &seg.work, &seg)?,
        None => Vec::new(),
    };
    progress.set(1.0);
    let r = &seg.report;
    Ok(json!({
        "read_s": read_s,
        "segment_s": r.timings_s.iter().map(|t| t.1).sum::<f64>(),
        "write_s": t1.elapsed().as_secs_f64(),
        "timings_s": r.timings_s,
        "mask_ml": r.volumes_ml.final_mask,
        "threshold_hu": r.threshold_hu,
        "blood_hu": r.blood_hu,
        "debug_images": debug,
    }))
}

/// How far outside the CT's box a commissure may lie (mm): a point placed on
/// the wall of a root cut by the edge of the scan is still this scan's.
const LANDMARK_OUTSIDE_MM: f64 = 20.0;

/// The commissures must span a circle and lie on this scan: otherwise the
/// landmarks file is the bad input (it said exit 1 "the computation failed").
fn check_commissures(ct: &Volume<i16>, lm: &Landmarks) -> std::result::Result<(), String> {
    let Ok(c) = lm.require(&["C1", "C2", "C3"]) else {
        return Ok(());
    };
    let c: [Point3; 3] = [c[0], c[1], c[2]];
    // The CT's box in its own index space, so oblique grids are judged alike.
    let d = ct.dims();
    let sp = ct.spacing();
    for (label, p) in ["C1", "C2", "C3"].iter().zip(&c) {
        let ijk = ct.world_to_index(p);
        let outside = (0..3)
            .map(|k| {
                let hi = d[k] as f64 - 1.0;
                (if ijk[k] < 0.0 {
                    -ijk[k]
                } else {
                    (ijk[k] - hi).max(0.0)
                }) * sp[k]
            })
            .fold(0.0, f64::max);
        if !(outside <= LANDMARK_OUTSIDE_MM) {
            return Err(format!(
                "{label} at ({:.1}, {:.1}, {:.1}) mm (LPS) lies {outside:.1} mm outside the CT's field of view: are the landmarks from this scan?",
                p.x, p.y, p.z
            ));
        }
    }
    if super::anchor::circumcircle(&c).is_none() {
        return Err(
            "the three commissures C1–C3 are collinear (or two coincide): their circle, which seeds the segmentation, is undefined; place each on the root wall at its commissure"
                .into(),
        );
    }
    Ok(())
}
