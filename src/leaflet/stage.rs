//! The `leaflets` stage: mesh each leaflet's flat template and place it on
//! its suture path.

use serde_json::{Value as Json, json};

use super::aft;
use super::crossings;
use super::outline::Edge;
use super::place::{self, Path3};
use super::template::{Template, read_templates};
use crate::geom::{DataArray, DataValues, Frame, Point3, TriMesh, Vector3};
use crate::io::{Transaction, vtp};
use crate::pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};
use crate::units::Kind;
use crate::valve::wall::Wall;
use crate::{Error, Result};

pub static SPEC: StageSpec = StageSpec {
    name: "leaflets",
    about: "Mesh the three leaflet templates and place them on the suture paths",
    inputs: &[
        Port {
            name: "valve",
            flag: "valve",
            file: "valve.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "valve frame from `coapt valve`",
        },
        Port {
            name: "paths",
            flag: "paths",
            file: "paths.vtp",
            kind: ArtifactKind::Polylines,
            required: true,
            help: "suture paths from `coapt valve`",
        },
        Port {
            name: "surface",
            flag: "surface",
            file: "aorta.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "lumen wall, to check that no leaflet crosses it",
        },
        Port {
            name: "template",
            flag: "template",
            file: "template.toml",
            kind: ArtifactKind::Template,
            required: true,
            help: "leaflet templates (one for all or one per leaflet)",
        },
    ],
    outputs: &[
        Port {
            name: "leaflets",
            flag: "out",
            file: "leaflets.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "three leaflets: point data ref_uv, boundary; cell data leaflet, fiber1, fiber2",
        },
        Port {
            name: "summary",
            flag: "summary",
            file: "leaflets.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "template, h, counts, mesh quality, attachment vs path length",
        },
    ],
    out_dir: None,
    params: &[
        Param {
            name: "h",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("0.5 mm"),
            help: "mesh size",
        },
        Param {
            name: "omega",
            kind: ParamKind::Quantity(Kind::Angle),
            default: Some("-40 deg"),
            help: "extrusion lean (seed 001 ω = −2π/9; negative leans towards the axis); five-parameter templates use their own",
        },
        Param {
            name: "fiber_angle",
            kind: ParamKind::Quantity(Kind::Angle),
            default: Some("0 deg"),
            help: "fibre angle θ on the flat template: M = cos θ e_x ± sin θ e_y",
        },
    ],
    check: |p| {
        if !(p.quantity("h") > 0.0) {
            return Err(Error::value("h must be positive"));
        }
        if !(p.quantity("omega").abs() < 1.5) {
            return Err(Error::value("omega must lie in (−86°, 86°)"));
        }
        Ok(())
    },
    run,
};

/// A node farther than this outside the wall (mm) means the leaflet does
/// not fit the root: a rough wall puts nodes a voxel (≈ 1.5 mm) out at most.
const FAR_OUTSIDE_MM: f64 = 2.0;
/// How far inside the wall a node outside is put back (mm).
const INSIDE_MM: f64 = 0.05;

/// Nodes moved back inside the wall: how many, and how far they were out.
pub(super) struct Pulled {
    pub(super) count: usize,
    pub(super) max_mm: f64,
    pub(super) mean_mm: f64,
}

/// Moves every node off the attachment edge that lies outside the closed
/// wall surface onto the nearest wall point and `INSIDE_MM` beyond it. A
/// radial ray from the commissure axis cannot judge this: on a tilted root
/// the axis itself leaves the lumen below the annulus on the high side.
pub(super) fn pull_inside(x: &mut [Point3], boundary: &[u8], wall: &Wall) -> Pulled {
    let (mut count, mut max_mm, mut sum) = (0usize, 0.0f64, 0.0);
    for (i, p) in x.iter_mut().enumerate() {
        if boundary[i] == 1 || wall.contains(p) {
            continue;
        }
        let (q, _) = wall.closest(p);
        let d = q - *p;
        let out = d.norm();
        count += 1;
        max_mm = max_mm.max(out);
        sum += out;
        if out > 0.0 {
            *p = q + d * (INSIDE_MM / out);
        }
    }
    Pulled {
        count,
        max_mm,
        mean_mm: if count > 0 { sum / count as f64 } else { 0.0 },
    }
}

fn vec3(v: &Json) -> Option<Vector3> {
    Some(Vector3::new(v[0].as_f64()?, v[1].as_f64()?, v[2].as_f64()?))
}

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let valve_path = io.input("valve").expect("required");
    let valve: Json =
        serde_json::from_slice(&std::fs::read(valve_path).map_err(|e| Error::read(valve_path, e))?)
            .map_err(|e| Error::bad_input(valve_path, e.to_string()))?;
    let bad = |what: &str| Error::bad_input(valve_path, format!("no {what}"));
    let axis = vec3(&valve["valve_frame"]["axis"]).ok_or_else(|| bad("valve_frame.axis"))?;
    let centre = Point3::from(
        vec3(&valve["commissure_cylinder"]["centre_mm"])
            .ok_or_else(|| bad("commissure_cylinder.centre_mm"))?,
    );
    let paths_file = io.input("paths").expect("required");
    let pd = vtp::read(paths_file)?;
    if pd.lines.len() != 3 {
        return Err(Error::bad_input(
            paths_file,
            format!("expected 3 suture paths, found {}", pd.lines.len()),
        ));
    }
    let surf_path = io.input("surface").expect("required");
    let surface = vtp::read_mesh(surf_path)?;
    let wall = Wall::new(&surface).map_err(|e| Error::bad_input(surf_path, e))?;
    let templates = read_templates(io.input("template").expect("required"))?;
    let h = params.quantity("h");
    let theta = params.quantity("fiber_angle");
    let mut out = TriMesh::new(Vec::new(), Vec::new());
    let (mut uv, mut bnd, mut lf, mut f1, mut f2) = (vec![], vec![], vec![], vec![], vec![]);
    let mut per = Vec::new();
    // Timings go to the run record, not the artifact: outputs depend on inputs only.
    let mut mesh_ms_all = Vec::new();
    let mut commissures = Vec::new();
    for k in 0..3 {
        let t: &Template = &templates[k];
        let outline = t.outline();
        let t0 = std::time::Instant::now();
        let m = aft::mesh(&outline, h)
            .map_err(|e| Error::failed("leaflets", format!("leaflet {}: {e}", k + 1)))?;
        let mesh_ms = t0.elapsed().as_secs_f64() * 1e3;
        mesh_ms_all.push(mesh_ms);
        let (s, w) = place::column_coords(t, &m);
        let path = Path3::new(pd.lines[k].iter().map(|&i| pd.points[i as usize]).collect());
        commissures.push(path.at(0.0));
        let omega = match t {
            Template::Seed001(s) => s.omega,
            _ => params.quantity("omega"),
        };
        let (mut x, om) = place::place_radial(&s, &w, &path, &axis, &centre, omega, 0.5);
        // Every node off the attachment edge must be inside the lumen. On a
        // real, slightly rough wall a few land just outside: they go back
        // radially to just inside the wall; far outside, the template does
        // not fit this root.
        let pulled = pull_inside(&mut x, &m.boundary, &wall);
        if pulled.max_mm > FAR_OUTSIDE_MM {
            return Err(Error::failed(
                "leaflets",
                format!(
                    "leaflet {}: {} nodes lie outside the wall, up to {:.2} mm (more than {FAR_OUTSIDE_MM} mm): the template does not fit this root",
                    k + 1,
                    pulled.count,
                    pulled.max_mm
                ),
            ));
        }
        let (a1, a2) = place::fibres(&m, &x, theta);
        let stats = m.stats(h);
        let base = out.vertices.len() as u32;
        out.vertices.extend_from_slice(&x);
        out.triangles
            .extend(m.tris.iter().map(|t| t.map(|i| i + base)));
        uv.extend(m.nodes.iter().copied());
        bnd.extend(m.boundary.iter().copied());
        lf.extend(std::iter::repeat_n(k as i32 + 1, m.tris.len()));
        f1.extend(a1);
        f2.extend(a2);
        let att = outline.length(Edge::Sutured);
        per.push(json!({
            "leaflet": k + 1,
            "template": t.name(),
            "nodes": stats.nodes,
            "triangles": stats.triangles,
            "quality": stats,
            "attachment_mm": att,
            "free_edge_mm": outline.length(Edge::Free),
            "path_mm": path.length(),
            "attachment_vs_path": (att - path.length()) / path.length(),
            "omega_used_deg": om.to_degrees(),
            "outside_wall": {
                "nodes_moved_inside": pulled.count,
                "max_mm": pulled.max_mm,
                "mean_mm": pulled.mean_mm,
            },
        }));
        progress.set((k + 1) as f64 / 3.5);
    }
    let leaf_of: Vec<u16> = lf.iter().map(|&k| k as u16).collect();
    let sutured: Vec<bool> = bnd.iter().map(|&b| b == 1).collect();
    let crossings = crossings::summary(&out, &leaf_of, &sutured, &surface, &commissures);
    if let Some(msg) = crossings.get("warning").and_then(|w| w.as_str()) {
        tracing::warn!("leaflets: {msg}");
    }
    out.point_data.insert(DataArray::new(
        "ref_uv",
        2,
        DataValues::F64(uv.iter().flat_map(|p| [p[0], p[1]]).collect()),
    ));
    out.point_data
        .insert(DataArray::new("boundary", 1, DataValues::U8(bnd)));
    out.cell_data
        .insert(DataArray::new("leaflet", 1, DataValues::I32(lf)));
    out.cell_data.insert(DataArray::vectors_f64("fiber1", &f1));
    out.cell_data.insert(DataArray::vectors_f64("fiber2", &f2));
    out.frame = Frame::Lps;
    out.sanity_check()
        .map_err(|e| Error::failed("leaflets", e.to_string()))?;
    let summary = json!({
        "h_mm": h,
        "fiber_angle_deg": theta.to_degrees(),
        "leaflets": per,
        "crossings": crossings,
    });
    let mut tx = Transaction::new();
    let pdo = out.to_polydata();
    tx.write(io.output("leaflets"), |w| {
        vtp::encode(w, &pdo, &vtp::WriteOptions::default())
    })?;
    let text = serde_json::to_string_pretty(&summary).expect("json") + "\n";
    tx.write_bytes(io.output("summary"), text.as_bytes())?;
    tx.commit()?;
    progress.set(1.0);
    Ok(json!({"triangles": out.triangles.len(), "mesh_ms": mesh_ms_all}))
}
