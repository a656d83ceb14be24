//! The `surface` stage: declaration and file output.

use serde_json::{Value as Json, json};

use super::{SurfaceParams, surface_from_mask};
use coapt_base::Result;
use coapt_base::units::Kind;
use coapt_geom::Frame;
use coapt_io::{Transaction, nifti, vtp};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};

pub static SPEC: StageSpec = StageSpec {
    name: "surface",
    about: "Closed, outward wall mesh of the aortic lumen from its mask (marching cubes + Taubin, optional remeshing)",
    inputs: &[Port {
        name: "mask",
        flag: "mask",
        file: "mask.nii.gz",
        kind: ArtifactKind::Mask,
        required: true,
        help: "aortic lumen, uint8 (inside: value > iso)",
    }],
    outputs: &[
        Port {
            name: "surface",
            flag: "out",
            file: "aorta.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "wall mesh, LPS mm; cell data region (0 wall, 1 cut cap, 2 border cap)",
        },
        Port {
            name: "surface_report",
            flag: "report",
            file: "surface.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "counts, area, enclosed volume, smoothing volume change, remeshing statistics, timings",
        },
    ],
    out_dir: None,
    params: &[
        Param {
            name: "iso",
            kind: ParamKind::Float {
                min: 0.0,
                max: 255.0,
            },
            default: Some("0.5"),
            help: "iso level on the (blurred) mask",
        },
        Param {
            name: "blur",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("0 mm"),
            help: "Gaussian pre-blur σ of the binary mask (0 mm: none)",
        },
        Param {
            name: "smooth",
            kind: ParamKind::Int { min: 0, max: 1000 },
            default: Some("20"),
            help: "Taubin λ|μ iterations (λ 0.5, μ −0.53)",
        },
        Param {
            name: "keep_all",
            kind: ParamKind::Bool,
            default: Some("false"),
            help: "keep every connected component, not only the largest",
        },
        Param {
            name: "target_edge",
            kind: ParamKind::Quantity(Kind::Length),
            default: None,
            help: "isotropic remeshing to this edge length after smoothing, caps kept (default: off)",
        },
    ],
    check: |p| SurfaceParams::try_from(p).map(|_| ()),
    run,
};

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let sp = SurfaceParams::try_from(params)?;
    let path = io.input("mask").expect("required input");
    let t0 = std::time::Instant::now();
    let mask = nifti::read_u8(path)?;
    let read_s = t0.elapsed().as_secs_f64();
    progress.set(0.2);
    let (mesh, report) = surface_from_mask(&mask, &sp)?;
    progress.set(0.9);
    let mut summary = serde_json::to_value(&report).expect("report serialises");
    if let Json::Object(m) = &mut summary {
        m.insert("frame".into(), json!(Frame::Lps.name()));
        m.insert("read_s".into(), json!(read_s));
    }
    let text = serde_json::to_string_pretty(&summary).expect("report serialises") + "\n";
    let pd = mesh.to_polydata();
    let mut tx = Transaction::new();
    tx.write(io.output("surface"), |w| {
        vtp::encode(w, &pd, &vtp::WriteOptions::default())
    })?;
    tx.write_bytes(io.output("surface_report"), text.as_bytes())?;
    tx.commit()?;
    progress.set(1.0);
    Ok(summary)
}
