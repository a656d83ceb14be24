//! The `phantom` stage: declaration and file output.

use serde_json::{Value as Json, json};

use super::{PhantomParams, generate};
use coapt_base::Result;
use coapt_base::units::Kind;
use coapt_geom::Frame;
use coapt_io::{Transaction, markups, nifti, vtp};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};

pub static SPEC: StageSpec = StageSpec {
    name: "phantom",
    about: "Generate a synthetic ceCTA of an aortic root with exact ground truth",
    inputs: &[],
    outputs: &[
        Port {
            name: "ct",
            flag: "ct",
            file: "ct.nii.gz",
            kind: ArtifactKind::Volume,
            required: true,
            help: "synthetic CT, int16 HU",
        },
        Port {
            name: "truth_mask",
            flag: "truth-mask",
            file: "truth_mask.nii.gz",
            kind: ArtifactKind::Mask,
            required: true,
            help: "aortic lumen from the VAJ plane up, uint8 0/1, CT grid",
        },
        Port {
            name: "landmarks",
            flag: "landmarks",
            file: "landmarks.mrk.json",
            kind: ArtifactKind::Landmarks,
            required: true,
            help: "commissures C1–C3 and nadirs N1–N3, 3D Slicer markups in LPS",
        },
        Port {
            name: "truth",
            flag: "truth",
            file: "truth.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "every geometric parameter, the valve frame, radii and volumes",
        },
        Port {
            name: "truth_surface",
            flag: "truth-surface",
            file: "truth_surface.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "analytic lumen surface (closed; region 0 wall, 1 VAJ cap, 2 top cap)",
        },
    ],
    out_dir: Some("out"),
    params: &[
        Param {
            name: "preset",
            kind: ParamKind::Choice(&["sample", "standard", "full", "clinical"]),
            default: Some("sample"),
            help: "grid: sample 112×112×112 at 0.9×0.9×1 mm, standard 256×256×200, full 512×512×300 at 0.44×0.44×0.6 mm, clinical 128×128×160 at 1.5 mm (arch, native cusps, 20° annulus tilt, 480 HU blood, 28 HU noise, 21° valve tilt, like the real CT)",
        },
        Param {
            name: "seed",
            kind: ParamKind::Int {
                min: 0,
                max: i64::MAX,
            },
            default: Some("1"),
            help: "anatomy and noise seed; same seed, same bytes",
        },
        Param {
            name: "noise",
            kind: ParamKind::Quantity(Kind::Intensity),
            default: None,
            help: "standard deviation of the image noise [default: 25 HU; clinical 28 HU]",
        },
        Param {
            name: "tilt",
            kind: ParamKind::Quantity(Kind::Angle),
            default: None,
            help: "angle between the valve axis and the scanner's z axis [default: 35 deg; clinical 21 deg]",
        },
        Param {
            name: "spacing",
            kind: ParamKind::Lengths3,
            default: None,
            help: "voxel spacing, e.g. \"0.5, 0.5, 0.8 mm\"; keeps the preset's field of view",
        },
        Param {
            name: "contrast",
            kind: ParamKind::Bool,
            default: Some("true"),
            help: "contrast-filled blood (off: blood ~40 HU, as in a non-contrast CT)",
        },
        Param {
            name: "blood",
            kind: ParamKind::Quantity(Kind::Intensity),
            default: None,
            help: "blood-pool intensity in the aorta (other chambers vary around it) [default: 350 HU; clinical 480 HU]",
        },
        Param {
            name: "calcium",
            kind: ParamKind::Bool,
            default: Some("false"),
            help: "add annular calcium near the nadirs",
        },
        Param {
            name: "coronaries",
            kind: ParamKind::Bool,
            default: Some("true"),
            help: "the coronary arteries leaving the sinuses, in the CT and the truth",
        },
        Param {
            name: "arch",
            kind: ParamKind::Bool,
            default: Some("false"),
            help: "extend the ascending aorta into an arch and the descending aorta, all in the field of view; the truth region ends at a plane below the arch (always on in the clinical preset)",
        },
        Param {
            name: "native_cusps",
            kind: ParamKind::Bool,
            default: Some("false"),
            help: "paint the closed native cusps (thin soft-tissue sheets meeting in a Y) inside the root; the truth mask includes them (always on in the clinical preset)",
        },
        Param {
            name: "annulus_tilt",
            kind: ParamKind::Quantity(Kind::Angle),
            default: None,
            help: "tilt of the annulus (nadir) plane to the commissure plane, 0–35 deg [default: 0 deg; clinical 20 deg]",
        },
        Param {
            name: "root_rotation",
            kind: ParamKind::Quantity(Kind::Angle),
            default: Some("0 deg"),
            help: "turn of the root about its axis, counter-clockwise seen from the aorta, −180–180 deg: 0 faces the right-coronary sinus anterior, as in most patients; other angles test what does not assume it",
        },
    ],
    check: |p| PhantomParams::try_from(p).map(|_| ()),
    run,
};

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let pp = PhantomParams::try_from(params)?;
    let t0 = std::time::Instant::now();
    let ph = generate(&pp, &|f| progress.set(0.9 * f))?;
    let generate_s = t0.elapsed().as_secs_f64();

    let t1 = std::time::Instant::now();
    let mut truth = serde_json::to_value(&ph.truth).expect("truth serialises");
    if let Json::Object(m) = &mut truth {
        // Provenance (version, time) lives in the manifest, so that the
        // artifact itself depends on the inputs alone.
        m.insert("frame".into(), json!(Frame::Lps.name()));
    }
    let mut tx = Transaction::new();
    tx.write(io.output("ct"), |w| nifti::encode(w, &ph.ct, true))?;
    tx.write(io.output("truth_mask"), |w| {
        nifti::encode(w, &ph.truth_mask, true)
    })?;
    let mrk = markups::encode_mrk_json(&ph.landmarks, Frame::Lps);
    tx.write_bytes(io.output("landmarks"), mrk.as_bytes())?;
    let text = serde_json::to_string_pretty(&truth).expect("truth serialises") + "\n";
    tx.write_bytes(io.output("truth"), text.as_bytes())?;
    let surface = ph.truth_surface.to_polydata();
    tx.write(io.output("truth_surface"), |w| {
        vtp::encode(w, &surface, &vtp::WriteOptions::default())
    })?;
    tx.commit()?;
    progress.set(1.0);
    let d = ph.ct.dims();
    Ok(json!({
        "dims": d,
        "voxels": d[0] * d[1] * d[2],
        "spacing_mm": ph.ct.spacing(),
        "truth_mask_voxels": ph.truth_mask.as_slice().iter().filter(|&&v| v != 0).count(),
        "truth_surface_triangles": ph.truth_surface.triangles.len(),
        "generate_s": generate_s,
        "write_s": t1.elapsed().as_secs_f64(),
    }))
}
