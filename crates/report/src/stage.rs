//! The `report` stage: measure the closed valve, judge the criteria, write
//! `report.json` and a self-contained `report.html`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{Value as Json, json};

use super::coaptation::{self, Options as ZoneOptions};
use super::criteria::{self, Anatomy, Pressures, Thresholds};
use super::document::{self, Context, Finding, Severity};
use super::metrics::{self, Metrics};
use super::stage_params::ReportParams;
use super::{ClosedValve, Figure, case, figures, html, load, reach, symmetry, verdict, view3d};
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_geom::Point3;
use coapt_io::design_json::Design;
use coapt_io::report_json::{self, InputFile, finite};
use coapt_io::{Transaction, markups, nifti, volume_file, vtp};
use coapt_pipeline::manifest::{self, Manifest};
use coapt_pipeline::{
    ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec, provenance,
};
use indexmap::IndexMap;

const fn optional(
    name: &'static str,
    file: &'static str,
    kind: ArtifactKind,
    help: &'static str,
) -> Port {
    Port {
        name,
        flag: name,
        file,
        kind,
        required: false,
        help,
    }
}

pub static SPEC: StageSpec = StageSpec {
    name: "report",
    about: "Measure the coaptation of the closed valve, judge the surgical criteria, write report.json and report.html",
    inputs: &[
        Port {
            name: "closed",
            flag: "closed",
            file: "closed.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "closed leaflets from `coapt close`",
        },
        Port {
            name: "leaflets",
            flag: "leaflets",
            file: "leaflets.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "the placed leaflets the closure started from (boundary codes, ref_uv)",
        },
        Port {
            name: "valve",
            flag: "valve",
            file: "valve.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "valve frame: annulus plane and axis for every height",
        },
        optional(
            "log",
            "closure.json",
            ArtifactKind::Json,
            "closure log: thickness (margin), solver record",
        ),
        Port {
            name: "summary",
            flag: "placement",
            file: "leaflets.json",
            kind: ArtifactKind::Json,
            required: false,
            help: "leaflets.json from `coapt leaflets`: templates, mesh size and placement, for the case header",
        },
        optional(
            "ct",
            "ct.nii.gz",
            ArtifactKind::Volume,
            "CT, for the segmentation check figure",
        ),
        optional(
            "mask",
            "mask.nii.gz",
            ArtifactKind::Mask,
            "lumen mask, drawn on the CT",
        ),
        optional(
            "landmarks",
            "landmarks.mrk.json",
            ArtifactKind::Landmarks,
            "commissures and nadirs, drawn on the CT",
        ),
        Port {
            name: "landmarks_report",
            flag: "landmarks-report",
            file: "landmarks.json",
            kind: ArtifactKind::Json,
            required: false,
            help: "landmarks.json of `coapt landmarks` when the points were detected, not given: the case header says so, with each point's confidence",
        },
        optional(
            "paths",
            "paths.vtp",
            ArtifactKind::Polylines,
            "suture paths, drawn on the CT",
        ),
        optional(
            "surface",
            "aorta.vtp",
            ArtifactKind::Mesh,
            "lumen wall, drawn translucent around the valve in the interactive view (cropped to the root)",
        ),
        optional(
            "design",
            "design.json",
            ArtifactKind::Json,
            "leaflet-size sweep from `coapt design`: its table and charts join the report",
        ),
    ],
    outputs: &[
        Port {
            name: "report",
            flag: "json",
            file: "report.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "metrics, criteria, findings, timings, provenance (schemas/report.schema.json)",
        },
        Port {
            name: "page",
            flag: "html",
            file: "report.html",
            kind: ArtifactKind::Html,
            required: true,
            help: "one self-contained HTML page with the verdict and figures",
        },
    ],
    out_dir: Some("out"),
    params: &[
        Param {
            name: "margin",
            kind: ParamKind::Quantity(Kind::Length),
            default: None,
            help: "contact margin (default 1.8 × the thickness in closure.json)",
        },
        Param {
            name: "refine",
            kind: ParamKind::Int { min: 1, max: 16 },
            default: Some("4"),
            help: "sub-triangles per edge where a triangle is partly in contact",
        },
        Param {
            name: "column_width",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("0.5 mm"),
            help: "radial columns across a coaptation strip for its height",
        },
        Param {
            name: "hcc_radius",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("5 mm"),
            help: "distance from the axis at which h_C-C is read",
        },
        Param {
            name: "min_central_coaptation",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("4 mm"),
            help: "criterion: central coaptation height must exceed this",
        },
        Param {
            name: "min_effective_height",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("9 mm"),
            help: "criterion: effective height must exceed this",
        },
        Param {
            name: "max_regurgitant_orifice",
            kind: ParamKind::Quantity(Kind::Area),
            default: Some("1 mm2"),
            help: "criterion \"no residual regurgitation\": largest uncovered lumen area, mm² (default a tenth of ASE/EACVI mild, EROA < 10 mm²)",
        },
        Param {
            name: "max_billowing",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("1.4 mm"),
            help: "criterion \"no billowing\": deepest leaflet point below the plane of the lowest sutured points (default the seeds' group's optimal range, < 1.4 mm)",
        },
        Param {
            name: "run_dir",
            kind: ParamKind::Path,
            default: None,
            help: "run directory (default: the folder of closed.vtp): per-stage timings from its manifest.json, and the optional inputs not given (closure.json, ct, mask, …) by their file names",
        },
    ],
    check: |p| ReportParams::try_from(p)?.check(),
    run,
};

/// Thickness multiple of the contact margin (the seeds' group's convention:
/// docs/report.md, "Where leaflets touch").
const MARGIN_PER_THICKNESS: f64 = 1.8;

fn read_json(path: &Path) -> Result<Json> {
    serde_json::from_slice(&std::fs::read(path).map_err(|e| Error::read(path, e))?)
        .map_err(|e| Error::bad_input(path, format!("not JSON: {e}")))
}

/// An optional input: given, or found by its file name in the run directory.
fn optional_input(io: &StageIo, run_dir: Option<&Path>, name: &str) -> Option<PathBuf> {
    if let Some(p) = io.input(name) {
        return Some(p.to_path_buf());
    }
    let file = SPEC.input(name)?.file;
    let p = run_dir?.join(file);
    p.is_file().then_some(p)
}

fn findings(
    v: &ClosedValve,
    m: &Metrics,
    completed: bool,
    log: Option<&Json>,
    margin_note: Option<String>,
    max_billowing_mm: f64,
) -> Vec<Finding> {
    let mut f = Vec::new();
    let mut say = |severity, message: String| f.push(Finding { severity, message });
    if let Some(n) = margin_note {
        say(Severity::Warning, n);
    }
    if completed {
        say(
            Severity::Info,
            "One leaflet was closed between two contact planes (seed 001 §3.1): it is measured against those planes (through the axis, bounding its 120° sector; zone: signed distance ≤ half the margin, 0.01 R by default) and drawn with its mirror images as leaflets 2 and 3.".into(),
        );
    }
    if m.leaflets.iter().all(|l| l.coaptation_area_mm2 == 0.0) {
        say(
            Severity::Error,
            "The leaflets do not touch anywhere within the margin: no coaptation, the valve does not close.".into(),
        );
    } else if !m.closed {
        say(
            Severity::Warning,
            "No zone where all three leaflets touch: central coaptation is absent and the valve counts as not closed.".into(),
        );
    }
    match (m.regurgitant_orifice_area_mm2, m.lumen_area_mm2) {
        (Some(o), Some(l)) if l > 0.0 && o > 0.01 * l => say(
            Severity::Warning,
            format!(
                "Seen along the axis, {o:.1} mm² of the {l:.0} mm² lumen is not covered by the leaflets ({:.1} %).",
                100.0 * o / l
            ),
        ),
        (None, _) => say(
            Severity::Info,
            "The regurgitant orifice is not measured for a one-leaflet closure.".into(),
        ),
        _ => {}
    }
    for (i, l) in m.leaflets.iter().enumerate() {
        if l.billowing_mm > max_billowing_mm {
            say(
                Severity::Warning,
                format!(
                    "Leaflet {} billows {:.2} mm below the plane of the three lowest sutured points.",
                    i + 1,
                    l.billowing_mm
                ),
            );
        }
    }
    if v.ref_uv.is_none() {
        say(Severity::Info, "The leaflets carry no flat-template coordinates (ref_uv): leaflet areas are those of the placed leaflets, and no coaptation maps are drawn.".into());
    }
    if let Some(log) = log {
        if let Some(n) = log["intersecting_triangle_pairs"]
            .as_u64()
            .filter(|&n| n > 0)
        {
            say(
                Severity::Warning,
                format!(
                    "{n} pairs of triangles of different leaflets cross each other in the closed state (closure.json); heights and areas near the crossings are uncertain."
                ),
            );
        }
        if log["suturing"]["status"] == json!("stalled") {
            say(
                Severity::Warning,
                format!(
                    "Suturing (seed 001 Algorithm 1) stopped before every sutured triangle was tangent to the wall: {}. The closure started from that state.",
                    log["suturing"]["reason"]
                        .as_str()
                        .unwrap_or("no reason recorded")
                ),
            );
        }
        if log["solver"]["converged"] == json!(false) {
            say(
                Severity::Error,
                format!(
                    "The closure did not converge: {}",
                    log["solver"]["reason"]
                        .as_str()
                        .unwrap_or("no reason recorded")
                ),
            );
        }
    }
    f
}

/// Positions `x` of a one-leaflet valve, extended by the mirror images the
/// completed valve `w` holds (only leaflet 1 is measured; its images only
/// need to exist with the right count).
fn mirror_positions(one: &ClosedValve, w: &ClosedValve, x: &[Point3]) -> Vec<Point3> {
    let mut out = x.to_vec();
    out.extend_from_slice(&w.x[one.x.len()..]);
    out
}

fn timings(run_dir: Option<&Path>) -> IndexMap<String, Option<f64>> {
    let Some(dir) = run_dir.filter(|d| d.join(manifest::FILE_NAME).is_file()) else {
        return IndexMap::new();
    };
    match Manifest::load(dir) {
        Ok(m) => m
            .stages
            .iter()
            .filter(|s| s.stage != SPEC.name)
            .map(|s| (s.stage.clone(), finite(s.seconds)))
            .collect(),
        Err(_) => IndexMap::new(),
    }
}

/// The CT check figure (the CT with the mask, the landmarks, the coronary
/// ostia the landmarks stage saw and the suture paths), when the CT is at
/// hand.
fn ct_figure(
    io: &StageIo,
    run_dir: Option<&Path>,
    detection: Option<&Json>,
    v: &ClosedValve,
) -> Result<Option<Figure>> {
    let Some(ct_path) = optional_input(io, run_dir, "ct") else {
        return Ok(None);
    };
    let ct = volume_file::read_ct(&ct_path)?;
    let mask = match optional_input(io, run_dir, "mask") {
        Some(p) => Some(nifti::read_u8(&p)?),
        None => None,
    };
    let mut points: Vec<(String, Point3)> = match optional_input(io, run_dir, "landmarks") {
        Some(p) => markups::read(&p)?.points,
        None => Vec::new(),
    };
    points.extend(ostia_of(detection));
    let paths: Vec<Vec<Point3>> = match optional_input(io, run_dir, "paths") {
        Some(p) => {
            let pd = vtp::read(&p)?;
            pd.lines
                .iter()
                .map(|l| l.iter().map(|&k| pd.points[k as usize]).collect())
                .collect()
        }
        None => Vec::new(),
    };
    Ok(Some(figures::ct_check::ct_check(
        &ct,
        mask.as_ref(),
        &v.frame,
        &points,
        &paths,
    )))
}

/// The closure's residual against its iterations, from `closure.json`
/// (`log`), when it recorded a history.
fn convergence_figure(log: &Json) -> Option<Figure> {
    let hist = log["solver"]["history"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let series = |key: &str| -> Vec<(usize, f64)> {
        hist.iter()
            .enumerate()
            .filter_map(|(i, r)| Some((i + 1, r[key].as_f64()?)))
            .collect()
    };
    (!hist.is_empty()).then(|| {
        figures::convergence::convergence(
            &series("residual_n"),
            &series("max_force_n"),
            log["config"]["tolerance_n"].as_f64(),
            log["solver"]["residual_n"]
                .as_f64()
                .zip(log["solver"]["converged"].as_bool()),
            log["solver"]["reason"].as_str(),
        )
    })
}

/// Each input read, by name: its path, BLAKE3 and size (a CT header with
/// detached voxels hashed with its data file). `required`: closed,
/// leaflets, valve.
fn input_record(
    io: &StageIo,
    run_dir: Option<&Path>,
    required: [&Path; 3],
) -> Result<IndexMap<String, InputFile>> {
    let mut inputs = IndexMap::new();
    let mut record = |name: &str, p: &Path| -> Result<()> {
        let (blake3, bytes) = provenance::hash_files(&volume_file::files_of(p))?;
        inputs.insert(
            name.into(),
            InputFile {
                path: p.display().to_string(),
                blake3,
                bytes: Some(bytes),
            },
        );
        Ok(())
    };
    for (name, p) in ["closed", "leaflets", "valve"].into_iter().zip(required) {
        record(name, p)?;
    }
    for name in [
        "log",
        "summary",
        "landmarks_report",
        "ct",
        "mask",
        "landmarks",
        "paths",
        "surface",
        "design",
    ] {
        if let Some(p) = optional_input(io, run_dir, name) {
            record(name, &p)?;
        }
    }
    Ok(inputs)
}

/// The contact margin (mm) and, when it had to be assumed, a note saying
/// so: `given`, else seed 001 §3.1's 0.01 R either side of a contact plane
/// for a one-leaflet closure (`one_leaflet`), else 1.8 thicknesses.
fn contact_margin(
    given: Option<f64>,
    one_leaflet: bool,
    thickness: Option<f64>,
    valve: &ClosedValve,
) -> (f64, Option<String>) {
    match (given, one_leaflet, thickness) {
        (Some(m), _, _) => (m, None),
        // Seed 001 §3.1: the zone is where the signed distance to a
        // contact plane is at most 0.01 R (R: the commissures' radius).
        (None, true, _) => {
            let f = &valve.frame;
            let r = f
                .commissures_mm
                .iter()
                .map(|c| {
                    let d = c - f.origin_mm;
                    (d - f.axis * d.dot(&f.axis)).norm()
                })
                .sum::<f64>()
                / 3.0;
            (0.02 * r, None)
        }
        (None, false, Some(t)) => (MARGIN_PER_THICKNESS * t, None),
        (None, false, None) => (
            MARGIN_PER_THICKNESS * 0.5,
            Some("No closure.json with the leaflet thickness: the contact margin assumes 0.5 mm leaflets (0.9 mm); pass --margin to set it.".to_string()),
        ),
    }
}

/// The page's figures in their order: the valve seen two ways, the
/// coaptation maps, the CT check (when the CT is at hand), the solver's
/// convergence (with closure.json) and the size sweep's charts (with a
/// design).
#[allow(clippy::too_many_arguments)]
fn figures_of(
    io: &StageIo,
    run_dir: Option<&Path>,
    v: &ClosedValve,
    node_mask: &[u8],
    detection: Option<&Json>,
    log: Option<&Json>,
    design: Option<&Design>,
    rp: &ReportParams,
) -> Result<Vec<Figure>> {
    let mut figs: Vec<Figure> = figures::valve_views::valve_views(v, node_mask);
    figs.extend(figures::coaptation_map::coaptation_maps(v, node_mask));
    if let Some(f) = ct_figure(io, run_dir, detection, v)? {
        figs.push(f);
    }
    if let Some(f) = log.and_then(convergence_figure) {
        figs.push(f);
    }
    if let Some(d) = design {
        figs.extend(figures::sizing::sizing(
            d,
            (rp.min_central_coaptation_mm, rp.min_effective_height_mm),
        ));
    }
    Ok(figs)
}

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let rp = ReportParams::try_from(params)?;
    let t0 = Instant::now();
    let cpath = io.input("closed").expect("required");
    let lpath = io.input("leaflets").expect("required");
    let vpath = io.input("valve").expect("required");
    let run_dir: Option<PathBuf> = rp
        .run_dir
        .clone()
        .or_else(|| cpath.parent().map(Path::to_path_buf));
    let run_dir = run_dir.as_deref();
    let frame = coapt_io::valve_json::read_frame(vpath)?;
    let closed = vtp::read_mesh(cpath)?;
    let placed = vtp::read_mesh(lpath)?;
    let valve = load::closed_valve(&closed, cpath, &placed, lpath, frame)?;
    let log_path = optional_input(io, run_dir, "log");
    let log = match &log_path {
        Some(p) => Some(read_json(p)?),
        None => None,
    };
    let design = match io.input("design") {
        Some(p) => Some(Design::read(p)?),
        None => None,
    };
    let thickness = log
        .as_ref()
        .and_then(|l| l["config"]["thickness_mm"].as_f64())
        .filter(|t| *t > 0.0);
    let completed = symmetry::complete(&valve);
    let (margin, margin_note) =
        contact_margin(rp.margin_mm, completed.is_some(), thickness, &valve);
    progress.set(0.1);
    let (v, planes) = match &completed {
        Some((w, p)) => (w, p.as_slice()),
        None => (&valve, &[][..]),
    };
    let zone = ZoneOptions {
        margin_mm: margin,
        refine: rp.refine,
    };
    let coapt = coaptation::find_with_planes(v, &zone, planes);
    progress.set(0.4);
    let mopts = metrics::Options {
        column_mm: rp.column_width_mm,
        hcc_radius_mm: rp.hcc_radius_mm,
        measured: completed.is_some().then_some(1),
        // The margin note says when 0.5 mm is assumed for want of closure.json.
        half_thickness_mm: 0.5 * thickness.unwrap_or(0.5),
        ..metrics::Options::default()
    };
    let mut m = metrics::measure(v, &coapt, &mopts);
    let measured = mopts.measured.unwrap_or(v.leaflets);
    // An extra closure at a low pressure (the seeds measure h_E at 3 mmHg),
    // when the close stage was asked for one: its effective height beside
    // the loaded one, and its leaflets count for the STJ bound too.
    let mut pressures = Pressures {
        closing_mmhg: log
            .as_ref()
            .and_then(|l| l["config"]["pressure_mmhg"].as_f64()),
        low_mmhg: None,
    };
    if let Some(low) = load::low_pressure_positions(&closed, cpath)? {
        let mut x = low;
        if let Some((w, _)) = &completed {
            x = mirror_positions(&valve, w, &x);
        }
        m.effective_height_low_pressure_mm = metrics::effective_height_at(v, &x, measured);
        m.highest_leaflet_mm = m
            .highest_leaflet_mm
            .max(metrics::highest_at(v, &x, measured));
        pressures.low_mmhg = log
            .as_ref()
            .and_then(|l| l["config"]["effective_height_pressure_mmhg"].as_f64());
    }
    let anatomy = Anatomy::new(
        &v.frame,
        coapt_io::valve_json::read_stj_height(vpath, &v.frame)?,
    );
    let thresholds = Thresholds {
        central_coaptation_mm: rp.min_central_coaptation_mm,
        effective_height_mm: rp.min_effective_height_mm,
        regurgitant_orifice_mm2: rp.max_regurgitant_orifice_mm2,
        billowing_mm: rp.max_billowing_mm,
    };
    let crit = criteria::judge(&m, &thresholds, &anatomy, &pressures);
    let placement = match optional_input(io, run_dir, "summary") {
        Some(p) => Some(read_json(&p)?),
        None => None,
    };
    let reach = placement
        .as_ref()
        .map_or(Vec::new(), |p| reach::reach(&v.frame, p));
    let mut gates = verdict::gates(log.as_ref());
    gates.extend(reach::gates(&reach, m.closed));
    let verdict = verdict::decide(&crit, gates);
    let mut finds = findings(
        v,
        &m,
        completed.is_some(),
        log.as_ref(),
        margin_note,
        thresholds.billowing_mm,
    );
    finds.extend(reach::findings(&reach, m.closed));
    progress.set(0.5);

    // Only as wired by the runner or given: a landmarks.json left in the
    // run directory by an earlier run without landmarks does not make
    // given points "detected".
    let detection = match io.input("landmarks_report") {
        Some(p) => Some(read_json(p)?),
        None => None,
    };
    let figs = figures_of(
        io,
        run_dir,
        v,
        &coapt.node_mask,
        detection.as_ref(),
        log.as_ref(),
        design.as_ref(),
        &rp,
    )?;
    let wall = match optional_input(io, run_dir, "surface") {
        Some(p) => Some(vtp::read_mesh(&p)?),
        None => None,
    };
    let scene = view3d::build(v, &coapt.node_mask, wall.as_ref());
    progress.set(0.9);

    let inputs = input_record(io, run_dir, [cpath, lpath, vpath])?;
    let mut timing = timings(run_dir);
    let report_s = t0.elapsed().as_secs_f64();
    timing.insert(SPEC.name.into(), finite(report_s));
    let solver = match &log {
        Some(l) => report_json::Solver {
            converged: l["solver"]["converged"].as_bool(),
            iterations: l["solver"]["iterations"].as_u64(),
            residual_n: l["solver"]["residual_n"].as_f64(),
            reason: l["solver"]["reason"].as_str().map(str::to_string),
        },
        None => report_json::Solver::default(),
    };
    let mut parameters: serde_json::Map<String, Json> = params
        .canonical()
        .into_iter()
        .map(|(k, v)| (k, json!(v)))
        .collect();
    parameters.insert("margin_mm".into(), json!(margin));
    if let Some(l) = &log {
        parameters.insert("closure".into(), l["config"].clone());
    }
    let ctx = Context {
        zone,
        pressures,
        anatomy,
        solver,
        timing_s: timing,
        inputs,
        parameters,
    };
    let mut doc = document::build(&m, &crit, &verdict, &finds, &ctx);
    doc.case = Some(case::build(&case::Sources {
        run_dir,
        landmarks: optional_input(io, run_dir, "landmarks").as_deref(),
        detection: detection.as_ref(),
        valve: &read_json(vpath)?,
        frame: &v.frame,
        placement: placement.as_ref(),
        log: log.as_ref(),
    }));
    doc.design = design;
    let page = html::render(&doc, &figs, scene.as_ref());
    let mut tx = Transaction::new();
    tx.write_bytes(io.output("report"), doc.to_text().as_bytes())?;
    tx.write_bytes(io.output("page"), page.as_bytes())?;
    tx.commit()?;
    progress.set(1.0);
    Ok(json!({
        "closed": m.closed,
        "meets_all_criteria": doc.verdict.meets_all_criteria,
        "coaptation_height_mm": m.coaptation_height_mm,
        "central_coaptation_height_mm": m.central_coaptation_height_mm,
        "effective_height_mm": doc.metrics.effective_height_mm,
        "status": doc.verdict.status,
        "refined_triangles": coapt.refined_triangles,
        "figures": figs.len(),
    }))
}

/// The coronary ostia the landmarks stage found, as labelled points for the
/// CT figure ("RCA", "LCA").
fn ostia_of(detection: Option<&Json>) -> Vec<(String, Point3)> {
    let Some(sinuses) = detection.and_then(|d| d["sinuses"].as_array()) else {
        return Vec::new();
    };
    sinuses
        .iter()
        .filter_map(|s| {
            let label = match s["name"].as_str()? {
                "right_coronary" => "RCA",
                "left_coronary" => "LCA",
                _ => return None,
            };
            let p: Vec<f64> = s["ostium"]["point_mm"]
                .as_array()?
                .iter()
                .filter_map(Json::as_f64)
                .collect();
            (p.len() == 3).then(|| (label.to_string(), Point3::new(p[0], p[1], p[2])))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CT figure gets a point per ostium found, named by its artery;
    /// no ostium, no sinuses or no landmarks report gives none.
    #[test]
    fn ostia_become_labelled_points_of_the_ct_figure() {
        let det = json!({"sinuses": [
            {"nadir": "N1", "name": "right_coronary", "ostium": {"point_mm": [1.0, 2.0, 3.0]}},
            {"nadir": "N2", "name": "left_coronary", "ostium": null},
            {"nadir": "N3", "name": "non_coronary", "ostium": null},
        ]});
        assert_eq!(
            ostia_of(Some(&det)),
            vec![("RCA".to_string(), Point3::new(1.0, 2.0, 3.0))]
        );
        assert!(ostia_of(Some(&json!({"points": []}))).is_empty());
        assert!(ostia_of(None).is_empty());
    }
}
