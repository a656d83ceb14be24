//! The `leaflets` stage: mesh each leaflet's flat template and place it on
//! its suture path.

use serde_json::{Value as Json, json};

use super::aft;
use super::crossings;
use super::hang;
use super::place::{self, Path3};
use super::stage_params::{LeafletParams, Placement};
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_geom::wall::Wall;
use coapt_geom::{DataArray, DataValues, Frame, Point3, TriMesh, Vector3};
use coapt_io::{Transaction, leaflet_mesh, vtp};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};
use coapt_template::outline::Edge;
use coapt_template::{Template, read_templates};

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
            name: "placement",
            kind: ParamKind::Choice(&["hanging", "extruded"]),
            default: Some("extruded"),
            help: "flat templates: hanging (free edge a taut V from commissure to centre to commissure, columns bowed between it and the suture line, see leaflet::hang) or extruded (columns along ω from the suture line); five-parameter templates are always extruded (seed 001)",
        },
        Param {
            name: "clearance",
            kind: ParamKind::Quantity(Kind::Length),
            default: Some("0.5 mm"),
            help: "hanging placement: how far off the axis each free edge's apex is put, into its own sector, so the leaflets start apart",
        },
        Param {
            name: "gathering",
            kind: ParamKind::Choice(&["ozaki", "uniform"]),
            default: Some("uniform"),
            help: "how an attachment edge longer than its suture path is gathered onto it: ozaki (1 : 1 up the posts, 3 : 1 about the nadir, as the running suture takes it; the seeds' group's onethirdCDF) or uniform (the same ratio all along); five-parameter templates are spread evenly (seed 001 eq. 2)",
        },
        Param {
            name: "fiber_angle",
            kind: ParamKind::Quantity(Kind::Angle),
            default: Some("0 deg"),
            help: "fibre angle θ on the flat template: M = cos θ e_x ± sin θ e_y",
        },
    ],
    check: |p| LeafletParams::try_from(p)?.check(),
    run,
};

/// A node farther than this outside the wall (mm) means the leaflet does
/// not fit the root: a rough wall puts nodes a voxel (≈ 1.5 mm) out at most.
const FAR_OUTSIDE_MM: f64 = 2.0;
/// Most nodes a leaflet may be meshed with (a closure at h 0.125 mm has
/// ≈ 40,000 per leaflet).
const MAX_NODES: f64 = 1e6;
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

/// The plane through the three paths' lowest points (along the axis), its
/// normal upwards: the annulus the hanging leaflets' strips stay above.
fn annulus_plane(pd: &coapt_geom::PolyData, axis: &Vector3) -> Option<(Point3, Vector3)> {
    let low: Vec<Point3> = pd
        .lines
        .iter()
        .map(|l| {
            l.iter()
                .map(|&i| pd.points[i as usize])
                .min_by(|a, b| a.coords.dot(axis).total_cmp(&b.coords.dot(axis)))
        })
        .collect::<Option<_>>()?;
    let n = (low[1] - low[0])
        .cross(&(low[2] - low[0]))
        .try_normalize(1e-9)?;
    let n = if n.dot(axis) < 0.0 { -n } else { n };
    Some((low[0], n))
}

/// Sign of the diastolic load on a leaflet placed leaning towards the axis:
/// −1 when its triangles' normals point away from the axis (the aortic
/// side), +1 otherwise.
fn pressure_sign(x: &[Point3], tris: &[[u32; 3]], centre: &Point3, axis: &Vector3) -> f64 {
    let s: f64 = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| x[i as usize]);
            let area = (b - a).cross(&(c - a));
            let d = (a.coords + b.coords + c.coords) / 3.0 - centre.coords;
            area.dot(&(d - axis * d.dot(axis)))
        })
        .sum();
    if s > 0.0 { -1.0 } else { 1.0 }
}

fn vec3(v: &Json) -> Option<Vector3> {
    Some(Vector3::new(v[0].as_f64()?, v[1].as_f64()?, v[2].as_f64()?))
}

/// The root a leaflet is placed in: its axis, the commissures' centre, the
/// wall, and the annulus plane the hanging placement keeps above.
struct Root<'a> {
    axis: Vector3,
    centre: Point3,
    wall: &'a Wall,
    floor: Option<(Point3, Vector3)>,
}

/// One leaflet meshed and placed.
struct Placed {
    mesh: aft::FlatMesh,
    x: Vec<Point3>,
    fibre1: Vec<[f64; 3]>,
    fibre2: Vec<[f64; 3]>,
    commissure: Point3,
    /// The aortic side (`pressure_sign`).
    sign: f64,
    hanging: bool,
    mesh_ms: f64,
    /// Its entry in leaflets.json.
    record: Json,
}

/// Leaflet `k` cut as `t`, meshed at `lp.h_mm` and placed on the suture
/// path through `sewn_on`: extruded towards the axis, or hung; nodes a
/// little outside the wall pulled back in, far outside refused.
fn place_one(
    k: usize,
    t: &Template,
    sewn_on: Vec<Point3>,
    lp: &LeafletParams,
    root: &Root,
) -> Result<Placed> {
    let (axis, centre) = (root.axis, root.centre);
    let h = lp.h_mm;
    let outline = t.outline();
    let t0 = std::time::Instant::now();
    let m = aft::mesh(&outline, h)
        .map_err(|e| Error::failed("leaflets", format!("leaflet {}: {e}", k + 1)))?;
    let mesh_ms = t0.elapsed().as_secs_f64() * 1e3;
    let gathering = match (lp.gathering, t) {
        (place::Gathering::Ozaki, Template::Arc(_) | Template::Ozaki(_)) => place::Gathering::Ozaki,
        _ => place::Gathering::Uniform,
    };
    let path = Path3::sewn(sewn_on, outline.length(Edge::Sutured), gathering);
    let hanging = lp.placement == Placement::Hanging && !matches!(t, Template::Seed001(_));
    // The aortic side is judged on the leaflet extruded towards the
    // axis, where it is the outer one whatever the template's winding
    // (the closure's own rule); a hanging leaflet turns it inwards.
    let (s_e, w_e) = place::column_coords(t, &m);
    let omega = match t {
        Template::Seed001(s) => s.omega,
        _ => lp.omega_rad,
    };
    let (x_e, om_e) = place::place_radial(&s_e, &w_e, &path, &axis, &centre, omega, 0.5);
    let sign = pressure_sign(&x_e, &m.tris, &centre, &axis);
    let (mut x, om, hang_record) = if hanging {
        let c = place::columns(&m);
        let v = hang::vee(
            path.at(0.0),
            path.at(1.0),
            outline.length(Edge::Free),
            &axis,
            &centre,
            lp.clearance_mm,
        );
        let (x, excess) = hang::place(&c.s, &c.lam, &c.len, &path, &v, &axis, root.floor);
        (
            x,
            None,
            Some(json!({"free_edge": v.info, "column_excess_mm": excess})),
        )
    } else {
        (x_e, Some(om_e), None)
    };
    // Every node off the attachment edge must be inside the lumen. On a
    // real, slightly rough wall a few land just outside: they go back
    // radially to just inside the wall; far outside, the template does
    // not fit this root.
    let pulled = pull_inside(&mut x, &m.boundary, root.wall);
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
    let (fibre1, fibre2) = place::fibres(&m, &x, lp.fiber_angle_rad);
    let stats = m.stats(h);
    let att = outline.length(Edge::Sutured);
    let record = json!({
        "leaflet": k + 1,
        "template": t.name(),
        "nodes": stats.nodes,
        "triangles": stats.triangles,
        "quality": stats,
        "attachment_mm": att,
        "free_edge_mm": outline.length(Edge::Free),
        "path_mm": path.length(),
        "attachment_vs_path": (att - path.length()) / path.length(),
        "gathering": path.gathering(),
        "omega_used_deg": om.map(f64::to_degrees),
        "hanging": hang_record,
        "outside_wall": {
            "nodes_moved_inside": pulled.count,
            "max_mm": pulled.max_mm,
            "mean_mm": pulled.mean_mm,
        },
    });
    Ok(Placed {
        mesh: m,
        x,
        fibre1,
        fibre2,
        commissure: path.at(0.0),
        sign,
        hanging,
        mesh_ms,
        record,
    })
}

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let lp = LeafletParams::try_from(params)?;
    let valve_path = io.input("valve").expect("required");
    let valve: Json =
        serde_json::from_slice(&std::fs::read(valve_path).map_err(|e| Error::read(valve_path, e))?)
            .map_err(|e| Error::bad_input(valve_path, e.to_string()))?;
    let bad = |what: &str| Error::bad_input(valve_path, format!("no {what}"));
    // The frame as every stage reads it (a zero axis moved leaflets 7 mm
    // here with exit 0 while the report refused the same file).
    let axis = coapt_io::valve_json::read_frame(valve_path)?.axis;
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
    // Each leaflet spans its path's two ends, the commissures: the distance
    // a sizer measures, for `size = "measured"`.
    let gaps: [f64; 3] = std::array::from_fn(|k| {
        let l = &pd.lines[k];
        match (l.first(), l.last()) {
            (Some(&a), Some(&b)) => (pd.points[a as usize] - pd.points[b as usize]).norm(),
            _ => f64::NAN,
        }
    });
    let templates = read_templates(io.input("template").expect("required"), Some(gaps))?;
    let h = lp.h_mm;
    // Nodes ∝ area / h² (`--h 0.001 mm` filled 8 GiB): the outline's area
    // is at most L²/4π, and an equilateral mesh gives a node per √3/2 h².
    for t in &templates {
        let o = t.outline();
        let l = o.length(Edge::Sutured) + o.length(Edge::Free);
        let nodes = l * l / (4.0 * std::f64::consts::PI) / (0.866 * h * h);
        if nodes > MAX_NODES {
            return Err(Error::value(format!(
                "--h {h} mm: template {} would be meshed with about {nodes:.1e} nodes, more than {MAX_NODES:.0e}; use a larger h",
                t.name()
            )));
        }
    }
    let mut out = TriMesh::new(Vec::new(), Vec::new());
    let (mut uv, mut bnd, mut lf, mut f1, mut f2) = (vec![], vec![], vec![], vec![], vec![]);
    let mut per = Vec::new();
    // Timings go to the run record, not the artifact: outputs depend on inputs only.
    let mut mesh_ms_all = Vec::new();
    let mut commissures = Vec::new();
    let mut signs = Vec::new();
    let (mut all_hanging, mut any_hanging) = (true, false);
    let floor = annulus_plane(&pd, &axis);
    for (k, t) in templates.iter().enumerate() {
        let sewn_on: Vec<Point3> = pd.lines[k].iter().map(|&i| pd.points[i as usize]).collect();
        let p = place_one(
            k,
            t,
            sewn_on,
            &lp,
            &Root {
                axis,
                centre,
                wall: &wall,
                floor,
            },
        )?;
        mesh_ms_all.push(p.mesh_ms);
        commissures.push(p.commissure);
        signs.push(p.sign);
        all_hanging &= p.hanging;
        any_hanging |= p.hanging;
        let base = out.vertices.len() as u32;
        out.vertices.extend_from_slice(&p.x);
        out.triangles
            .extend(p.mesh.tris.iter().map(|t| t.map(|i| i + base)));
        uv.extend(p.mesh.nodes.iter().copied());
        bnd.extend(p.mesh.boundary.iter().copied());
        lf.extend(std::iter::repeat_n(k as i32 + 1, p.mesh.tris.len()));
        f1.extend(p.fibre1);
        f2.extend(p.fibre2);
        per.push(p.record);
        progress.set((k + 1) as f64 / 3.5);
    }
    // Free edges too short to meet cannot close the valve unstretched,
    // whatever the mechanics: say so before a closure is spent on them.
    let c3 = [commissures[0], commissures[1], commissures[2]];
    let free: [f64; 3] = std::array::from_fn(|k| templates[k].outline().length(Edge::Free));
    let need = coapt_geom::free_edge_reach::needed_free_edges(&c3, &free);
    let mut short = Vec::new();
    for k in 0..3 {
        per[k]["free_edge_needed_mm"] = json!(need[k]);
        if need[k] > free[k] * (1.0 + coapt_geom::free_edge_reach::MAX_SHORTFALL) {
            short.push(format!(
                "leaflet {}: {:.1} mm against {:.1} mm needed",
                k + 1,
                free[k],
                need[k]
            ));
        }
    }
    if !short.is_empty() {
        tracing::warn!(
            "leaflets: the free edges are too short to meet at one point unstretched ({}); the valve cannot close as cut",
            short.join(", ")
        );
    }
    let leaf_of: Vec<u16> = lf.iter().map(|&k| k as u16).collect();
    let sutured: Vec<bool> = bnd.iter().map(|&b| b == 1).collect();
    let crossings = crossings::summary(&out, &leaf_of, &sutured, &surface, &commissures);
    if let Some(msg) = crossings.get("warning").and_then(|w| w.as_str()) {
        tracing::warn!("leaflets: {msg}");
    }
    // Only a hanging leaflet needs its side recorded: the closure's own
    // rule reads an extruded one right.
    leaflet_mesh::insert_arrays(
        &mut out,
        &leaflet_mesh::LeafletArrays {
            boundary: bnd,
            leaflet: lf.iter().map(|&k| (k - 1) as u8).collect(),
            leaflets: 3,
            ref_uv: Some(uv),
            fibres: Some(f1.iter().zip(&f2).map(|(a, b)| [*a, *b]).collect()),
            pressure_sign: any_hanging.then_some(signs),
        },
    );
    // A hanging leaflet is placed as sewn (its columns leave the wall where
    // the suture holds them and hang to the free edge): the closure takes it
    // as the sutured state rather than sewing it again by seed 001's
    // Algorithm 1, whose third plane keeps leaflets 0.2 R off the axis,
    // where a hanging free edge already is.
    if all_hanging {
        out.field_data
            .insert(DataArray::new("sutured", 1, DataValues::U8(vec![1])));
    }
    out.frame = Frame::Lps;
    out.sanity_check()
        .map_err(|e| Error::failed("leaflets", e.to_string()))?;
    let summary = json!({
        "h_mm": h,
        "fiber_angle_deg": lp.fiber_angle_rad.to_degrees(),
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
