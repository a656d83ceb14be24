//! The `valve` stage: landmarks snapped to the wall, the valve frame and
//! radii, and the three suture paths.

use serde_json::{Value as Json, json};

use super::frame::{self, CommissureCylinder};
use super::stage_params::ValveParams;
use super::suture::{self, LengthMatch, PathSpec};
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_geom::wall::Wall;
use coapt_geom::{DataArray, DataValues, Frame, Point3, PolyData};
use coapt_io::{Transaction, markups, vtp};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};
use coapt_template::outline::Edge;
use coapt_template::{Template, read_templates};

pub static SPEC: StageSpec = StageSpec {
    name: "valve",
    about: "Valve frame, radii and suture paths from the wall surface and the commissures",
    inputs: &[
        Port {
            name: "surface",
            flag: "surface",
            file: "aorta.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "lumen wall (closed; `region` 0 marks the wall when present)",
        },
        Port {
            name: "landmarks",
            flag: "landmarks",
            file: "landmarks.mrk.json",
            kind: ArtifactKind::Landmarks,
            required: true,
            help: "commissures C1–C3 (required), nadirs N1–N3 (optional)",
        },
        Port {
            name: "template",
            flag: "template",
            file: "template.toml",
            kind: ArtifactKind::Template,
            required: false,
            help: "leaflet templates: the paths are length-matched to their attachment edges",
        },
    ],
    outputs: &[
        Port {
            name: "valve",
            flag: "out",
            file: "valve.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "valve frame, snapped landmarks, radii, path lengths",
        },
        Port {
            name: "paths",
            flag: "paths",
            file: "paths.vtp",
            kind: ArtifactKind::Polylines,
            required: true,
            help: "three suture paths (cell data `leaflet` 1–3), C_k → C_k+1",
        },
    ],
    out_dir: None,
    params: &[
        Param {
            name: "hc",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("1.5 mm"),
            help: "straight part below each commissure (seed 001 H_c); a five-parameter template's own H_c wins",
        },
        Param {
            name: "spacing",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("0.2 mm"),
            help: "largest point spacing along the paths",
        },
    ],
    check: |p| ValveParams::try_from(p)?.check(),
    run,
};

const MAX_SNAP_MM: f64 = 2.0;

/// Everything the stage computes, for the CLI and for tests.
pub struct ValveResult {
    pub json: Json,
    pub paths: Vec<Vec<Point3>>,
}

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let vp = ValveParams::try_from(params)?;
    let surf_path = io.input("surface").expect("required");
    let lm_path = io.input("landmarks").expect("required");
    let mesh = vtp::read_mesh(surf_path)?;
    let lm = markups::read(lm_path)?;
    let wall = Wall::new(&mesh).map_err(|e| Error::bad_input(surf_path, e))?;
    let snap = |label: &str, p: Point3| -> Result<(Point3, f64)> {
        let (q, _) = wall.closest(&p);
        let d = (q - p).norm();
        if d > MAX_SNAP_MM {
            return Err(Error::bad_input(
                lm_path,
                format!("{label} is {d:.2} mm from the wall (more than {MAX_SNAP_MM} mm)"),
            ));
        }
        Ok((q, d))
    };
    let cs = lm
        .require(&["C1", "C2", "C3"])
        .map_err(|e| e.in_file(lm_path))?;
    let mut snapped = serde_json::Map::new();
    let mut c = [Point3::origin(); 3];
    for k in 0..3 {
        let (q, d) = snap(&format!("C{}", k + 1), cs[k])?;
        c[k] = q;
        snapped.insert(
            format!("C{}", k + 1),
            json!({"point_mm": [q.x, q.y, q.z], "moved_mm": d}),
        );
    }
    let gaps: [f64; 3] = std::array::from_fn(|k| (c[k] - c[(k + 1) % 3]).norm());
    let templates = match io.input("template") {
        Some(p) => Some(read_templates(p, Some(gaps))?),
        None => None,
    };
    let have_n: Vec<bool> = (1..=3)
        .map(|k| lm.get(&format!("N{k}")).is_some())
        .collect();
    let mut nadir_labels = None;
    let nadirs = if have_n.iter().all(|&b| b) {
        let mut n = [Point3::origin(); 3];
        for k in 0..3 {
            let (q, d) = snap(
                &format!("N{}", k + 1),
                lm.get(&format!("N{}", k + 1)).unwrap(),
            )?;
            n[k] = q;
            snapped.insert(
                format!("N{}", k + 1),
                json!({"point_mm": [q.x, q.y, q.z], "moved_mm": d}),
            );
        }
        // The file's labels are names: leaflet k's nadir is the one between
        // C_k and C_k+1 (issue "landmarks optional": an N1 between C3 and
        // C1 used to be refused).
        let of = coapt_geom::nadir_sectors::nadir_sectors(&c, &n)
            .map_err(|e| Error::bad_input(lm_path, e))?;
        if of != [0, 1, 2] {
            nadir_labels = Some(of.map(|i| format!("N{}", i + 1)));
        }
        Some(of.map(|i| n[i]))
    } else if have_n.iter().any(|&b| b) {
        return Err(Error::bad_input(
            lm_path,
            "give all three nadirs N1–N3 or none",
        ));
    } else {
        None
    };
    progress.set(0.2);
    // Without nadirs the paths are laid on the commissures' cylinder, which
    // an asymmetric root may not allow (the real CT with C1–C3 alone: "the
    // attachment edge is longer than the deepest path"); the nadirs, given
    // or detected, are what fixes that.
    let r = compute(&mesh, &wall, &c, nadirs.as_ref(), templates.as_ref(), &vp).map_err(|e| {
        let hint = if nadirs.is_none() {
            format!(
                " ({} holds no nadirs: add N1–N3, or have them detected: give this file to `coapt run` as `landmarks`, or to `coapt landmarks --given`)",
                lm_path.display()
            )
        } else {
            String::new()
        };
        Error::failed("valve", format!("{e}{hint}"))
    })?;
    for f in r.json["findings"].as_array().into_iter().flatten() {
        if let Some(f) = f.as_str() {
            tracing::warn!("valve: {f}");
        }
    }
    let mut out = r.json;
    out["landmarks_snapped"] = Json::Object(snapped);
    if let Some(l) = nadir_labels {
        // Which of the file's nadirs each leaflet's path runs through.
        out["nadir_of_leaflet"] = json!(l);
    }
    let mut pd = PolyData::default();
    let mut leaflet = Vec::new();
    for (k, p) in r.paths.iter().enumerate() {
        let base = pd.points.len() as u32;
        pd.points.extend_from_slice(p);
        pd.lines.push((base..base + p.len() as u32).collect());
        leaflet.push(k as i32 + 1);
    }
    pd.cell_data
        .insert(DataArray::new("leaflet", 1, DataValues::I32(leaflet)));
    pd.field_data
        .insert(DataArray::string("frame", Frame::Lps.name()));
    let mut tx = Transaction::new();
    let text = serde_json::to_string_pretty(&out).expect("valve json") + "\n";
    tx.write_bytes(io.output("valve"), text.as_bytes())?;
    tx.write(io.output("paths"), |w| {
        vtp::encode(w, &pd, &vtp::WriteOptions::default())
    })?;
    tx.commit()?;
    progress.set(1.0);
    Ok(json!({
        "annulus_from": out["annulus_from"],
        "path_lengths_mm": out["paths"].as_array().map(|a| a.iter().map(|p| p["path_mm"].clone()).collect::<Vec<_>>()),
    }))
}

/// Frame, radii and paths from snapped landmarks.
pub fn compute(
    mesh: &coapt_geom::TriMesh,
    wall: &Wall,
    c: &[Point3; 3],
    nadirs: Option<&[Point3; 3]>,
    templates: Option<&[Template; 3]>,
    params: &ValveParams,
) -> std::result::Result<ValveResult, String> {
    let (cyl, oriented_by) =
        frame::commissure_cylinder(mesh, c, nadirs).ok_or("the three commissures are collinear")?;
    let m = frame::measure(mesh, wall, &cyl, c, nadirs)?;
    plausible(&m)?;
    let ds = params.spacing_mm;
    let mut paths = Vec::new();
    let mut matches = Vec::new();
    for k in 0..3 {
        let (ca, cb) = (c[k], c[(k + 1) % 3]);
        let tpl = templates.map(|t| &t[k]);
        let hc = match tpl {
            Some(Template::Seed001(s)) => s.hc,
            _ => params.hc_mm,
        };
        let target = tpl.map(|t| t.outline().length(Edge::Sutured));
        let mut nadir_unpinned_mm = None;
        let (path, depth, adjusted, spec) = match (nadirs, target) {
            (Some(n), _) => {
                let mut spec = PathSpec::between(&cyl, &ca, &cb, hc, 0.0);
                let (hn, an) = cyl.height_angle(&n[k]);
                let an = spec.angle_a + frame::wrap(an - spec.angle_a);
                let (lo, hi) = (
                    spec.angle_a.min(spec.angle_b),
                    spec.angle_a.max(spec.angle_b),
                );
                if !(an > lo && an < hi) {
                    return Err(format!(
                        "N{} does not lie between C{} and C{} around the axis",
                        k + 1,
                        k + 1,
                        (k + 1) % 3 + 1
                    ));
                }
                spec.nadir_angle = an;
                spec.nadir_height = hn;
                let projected = suture::project(wall, &cyl, &spec, (ca, Some(n[k]), cb), ds);
                nadir_unpinned_mm = projected.nadir_unpinned_mm;
                let p = projected.points;
                let depth = (spec.height_a + spec.height_b) / 2.0 - hc - hn;
                (p, depth, false, spec)
            }
            (None, Some(t)) => {
                let top = (cyl.height_angle(&ca).0 + cyl.height_angle(&cb).0) / 2.0 - hc;
                let deepest = top - (m.annulus_height_mm - 3.0).max(wall_bottom(mesh, &cyl) + 0.1);
                let (p, d) = suture::match_length(wall, &cyl, &ca, &cb, hc, (0.5, deepest), t, ds)
                    .map_err(|e| format!("leaflet {}: {e}", k + 1))?;
                (p, d, true, PathSpec::between(&cyl, &ca, &cb, hc, d))
            }
            (None, None) => {
                let top = (cyl.height_angle(&ca).0 + cyl.height_angle(&cb).0) / 2.0 - hc;
                let depth = top - m.annulus_height_mm;
                let spec = PathSpec::between(&cyl, &ca, &cb, hc, depth);
                (
                    suture::project(wall, &cyl, &spec, (ca, None, cb), ds).points,
                    depth,
                    false,
                    spec,
                )
            }
        };
        let len = suture::length(&path);
        matches.push(LengthMatch {
            path_mm: len,
            on_cylinder_mm: suture::cylinder_length(&cyl, &spec),
            target_mm: target,
            relative_mismatch: target.map(|t| (len - t) / t),
            depth_mm: depth,
            adjusted,
            past_commissures_deg: suture::past_commissures_deg(&cyl, &spec, &path),
            nadir_unpinned_mm,
        });
        paths.push(path);
    }
    let findings = path_findings(&matches)?;
    let f = &m.frame;
    let p3 = |p: &Point3| json!([p.x, p.y, p.z]);
    let json = json!({
        "frame": "LPS",
        "valve_frame": f,
        "annulus_from": m.annulus_from,
        "axis_oriented_by": oriented_by.name(),
        "annulus_plane_tilt_deg": m.annulus_tilt_deg,
        "sections": {
            "annulus": m.annulus_section,
            "sinus": m.sinus_section,
            "stj": m.stj_section,
        },
        "commissure_cylinder": {
            "centre_mm": p3(&cyl.centre),
            "radius_mm": cyl.radius,
        },
        "radii": m.radii,
        "commissure_angles_deg": m.commissure_angles_deg,
        "h_comm_mm": m.h_comm_mm,
        "paths": matches,
        "findings": findings,
    });
    Ok(ValveResult { json, paths })
}

/// Radius bands (mm) of an adult aortic root that the stage accepts. Far
/// outside them the landmarks or the surface are wrong (a commissure on
/// the wrong vessel, a surface of something else), and every later stage
/// would compute on nonsense.
const ANNULUS_RADIUS_MM: (f64, f64) = (8.0, 20.0);
const SINUS_RADIUS_MM: (f64, f64) = (8.0, 30.0);
const STJ_RADIUS_MM: (f64, f64) = (8.0, 25.0);
const H_COMM_MM: (f64, f64) = (5.0, 35.0);

fn plausible(m: &frame::Measured) -> std::result::Result<(), String> {
    let check = |what: &str, v: f64, (lo, hi): (f64, f64)| {
        if v.is_finite() && v >= lo && v <= hi {
            Ok(())
        } else {
            Err(format!(
                "implausible {what} {v:.1} mm (an adult aortic root has {lo}–{hi} mm): check the landmarks and the surface"
            ))
        }
    };
    check("annulus radius", m.radii.annulus_mm, ANNULUS_RADIUS_MM)?;
    for (k, r) in m.radii.sinus_mm.iter().enumerate() {
        check(&format!("sinus {} radius", k + 1), *r, SINUS_RADIUS_MM)?;
    }
    check("STJ radius", m.radii.stj_mm, STJ_RADIUS_MM)?;
    // Without nadirs the annulus level is only the narrowest section found,
    // which on a plain tube is anywhere: its height proves nothing.
    if m.annulus_from == "nadirs" {
        check("commissure height over the annulus", m.h_comm_mm, H_COMM_MM)?;
    }
    Ok(())
}

/// A path this much longer or shorter than its attachment edge is reported.
const PATH_FINDING: f64 = 0.10;
/// A path longer than its attachment edge by more than this cannot be
/// covered: the leaflet would be stretched by more than a pericardial
/// leaflet tolerates, so the stage refuses rather than hand a misfit
/// downstream.
const PATH_STRETCH_REFUSE: f64 = 0.30;
/// A shorter path gathers the edge onto it, as Ozaki's running suture does
/// (the seeds' group's `onethirdCDF`: 3 : 1 at the nadir, 1 : 1 up the
/// posts; an Ozaki template's edge is 1.3–1.5 times its path on the
/// sample). Denser than 3 : 1 all along, no suture gathers it.
const PATH_GATHER_REFUSE: f64 = 2.0 / 3.0;
/// A path straying this far (degrees) past its commissures is reported.
/// Healthy paths stay within them (0° on the sample, phantom seeds 1–20,
/// the real CT and nine of its copies; 1.7° on the copy resampled to
/// 1 mm); where a flat patch of the wall was taken for a cut cap, one ran
/// 23.9° past (phantom of `pipelines/phantom.toml`, seed 7).
const PATH_PAST_COMMISSURES_DEG: f64 = 5.0;

pub(super) fn path_findings(matches: &[LengthMatch]) -> std::result::Result<Vec<String>, String> {
    let mut out = Vec::new();
    for (k, m) in matches.iter().enumerate() {
        let (Some(t), Some(r)) = (m.target_mm, m.relative_mismatch) else {
            continue;
        };
        let what = format!(
            "leaflet {} (C{} → C{}): suture path {:.1} mm is {:.0} % {} than the template's attachment edge {:.1} mm",
            k + 1,
            k + 1,
            (k + 1) % 3 + 1,
            m.path_mm,
            100.0 * r.abs(),
            if r > 0.0 { "longer" } else { "shorter" },
            t
        );
        let bound = if r > 0.0 {
            PATH_STRETCH_REFUSE
        } else {
            PATH_GATHER_REFUSE
        };
        if r.abs() > bound {
            return Err(format!(
                "{what} (more than {:.0} %): the template cannot be made to fit; resize the template or check the landmarks",
                100.0 * bound
            ));
        }
        if r.abs() > PATH_FINDING {
            out.push(what);
        }
    }
    for (k, m) in matches.iter().enumerate() {
        if let Some(d) = m.nadir_unpinned_mm {
            out.push(format!(
                "leaflet {} (C{} → C{}): its suture path does not pass through N{}: pinned there it would turn back on itself by more than {:.0}° (the rays from the axis at the nadir's height graze the sinus floor and cross the wall {d:.1} mm from it); it passes through the wall the rays meet at N{}'s angle and height",
                k + 1,
                k + 1,
                (k + 1) % 3 + 1,
                k + 1,
                suture::NADIR_PIN_MAX_TURN_DEG,
                k + 1
            ));
        }
        if m.past_commissures_deg > PATH_PAST_COMMISSURES_DEG {
            out.push(format!(
                "leaflet {} (C{} → C{}): its suture path strays {:.1}° past its commissures about the axis: rays from the axis met no wall there and the nearest wall point was taken, so the leaflet placed on it overlaps its neighbour; check the surface's wall (region 0) around that sinus",
                k + 1,
                k + 1,
                (k + 1) % 3 + 1,
                m.past_commissures_deg
            ));
        }
    }
    Ok(out)
}

fn wall_bottom(mesh: &coapt_geom::TriMesh, cyl: &CommissureCylinder) -> f64 {
    mesh.vertices
        .iter()
        .map(|v| (v - cyl.centre).dot(&cyl.axis))
        .fold(f64::INFINITY, f64::min)
}
