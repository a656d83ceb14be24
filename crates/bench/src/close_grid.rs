//! `coapt bench close --grid`: run time against error (issue 6). Every mesh
//! size × material model × solver × contact kind closes the same leaflets;
//! each row gets its wall time, iterations and coaptation numbers, and their
//! errors against the finest converged Newton closure of the same model and
//! contact kind, node displacements included (mapped through the flat
//! template coordinates, `displacement_error`). CSV plus a PNG of time
//! against the error in coaptation height (`close_grid_plot`).
//!
//! Case `sample`: the committed sample phantom (`sample_data/`) through
//! segment → surface → valve once, the leaflets re-meshed per h in the same
//! run directory (the runner skips the unchanged stages). Case
//! `ozaki-cylinder`: the one-leaflet peer case of `close.rs` (planes only).

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::close;
use super::displacement_error::{self, DisplacementError, Field};
use coapt_base::{Error, Result};
use coapt_geom::{Point3, ValveFrame};
use coapt_io::{valve_json, vtp};
use coapt_mech::closure::{self, Closed};
use coapt_mech::config;
use coapt_mech::element::V3;
use coapt_mech::model::{Axis, Leaflets};
use coapt_pipeline::LogMode;
use coapt_pipeline::execute::Invocation;
use coapt_pipeline::runner::{self, RunOptions};
use coapt_report::ClosedValve;
use coapt_report::{coaptation, metrics};
use coapt_stages::registry;

/// The grid.
pub const HS: [f64; 5] = [3.0, 2.0, 1.0, 0.5, 0.25];
pub const SOLVERS: [&str; 3] = ["relax", "combined", "newton"];
pub const MODELS: [&str; 3] = ["msm", "neo-hookean", "goh"];
pub const CONTACTS: [&str; 2] = ["planes", "leaflets"];

/// The pipeline's closure settings: GOH material, thickness, pressure,
/// bending and tolerance of every row come from here.
const CLOSE_TOML: &str = include_str!("../../../pipelines/close.toml");
const TEMPLATE_TOML: &str = include_str!("../../../pipelines/templates/ozaki_default.toml");

/// Contact margin per thickness, as the report stage measures
/// (docs/report.md, "Where leaflets touch"), and its refinement of partly
/// touching triangles.
const MARGIN_PER_THICKNESS: f64 = 1.8;
const REFINE: usize = 4;

#[derive(Debug, Clone, PartialEq)]
pub enum Case {
    /// The committed sample phantom; the directory holding ct.nii.gz and
    /// landmarks.mrk.json.
    Sample(PathBuf),
    OzakiCylinder,
}

impl Case {
    pub fn name(&self) -> &'static str {
        match self {
            Case::Sample(_) => "sample",
            Case::OzakiCylinder => "ozaki-cylinder",
        }
    }
}

#[derive(Debug, Clone)]
pub struct Options {
    pub case: Case,
    /// Mesh sizes (mm); run coarse to fine.
    pub hs: Vec<f64>,
    pub models: Vec<String>,
    pub solvers: Vec<String>,
    pub contacts: Vec<String>,
    /// Solver time limit of one closure (s); a combination that reaches it
    /// is not run on the finer meshes.
    pub time_limit_s: f64,
    /// Keep the sample's run directory here (default: a temporary one).
    pub work: Option<PathBuf>,
    pub threads: usize,
}

/// The `close.toml` text of one row: pipelines/close.toml with the model's
/// material (msm: the springs of seed 000's closure benchmark, E 1 MPa, whose
/// 44 s is the time the ≤ 5 s target answers — the seed's three-step
/// pericardium law is `msm_law = "seed000-isotropic"`; neo-Hookean μ 900 kPa;
/// GOH as in the file), the contact kind, solver and time limit set. Parsed by
/// `mech::config::parse`, so every other key keeps its pipeline value.
pub fn config_text(
    model: &str,
    solver: &str,
    contact: &str,
    time_limit_s: f64,
) -> std::result::Result<String, String> {
    let mut t: toml::Table = toml::from_str(CLOSE_TOML).map_err(|e| e.to_string())?;
    let s = |v: &str| toml::Value::String(v.to_string());
    let material = [
        "mu", "young", "poisson", "k1", "k2", "kappa", "jm", "msm_law",
    ];
    match model {
        "goh" => {}
        "msm" => {
            for k in material {
                t.remove(k);
            }
            t.insert("model".into(), s("msm"));
            t.insert("msm_law".into(), s("linear"));
            t.insert("young".into(), s("1 MPa"));
        }
        "neo-hookean" => {
            for k in material {
                t.remove(k);
            }
            t.insert("model".into(), s("neo-hookean"));
            t.insert("mu".into(), s("900 kPa"));
        }
        other => {
            return Err(format!(
                "model {other}: expected one of {}",
                MODELS.join(", ")
            ));
        }
    }
    t.insert("contact".into(), s(contact));
    t.insert("solver".into(), s(solver));
    t.insert("time_limit".into(), s(&format!("{time_limit_s} s")));
    toml::to_string(&t).map_err(|e| e.to_string())
}

/// One mesh of the case.
struct Mesh {
    leaflets: Leaflets,
    axis: Axis,
    /// Valve frame of the sample (heights from the annulus plane); `None`
    /// for the one-leaflet peer case, measured against its planes.
    frame: Option<ValveFrame>,
}

/// Coaptation numbers of one closed state (mm, mm²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coaptation {
    pub height_mm: Option<f64>,
    pub central_height_mm: Option<f64>,
    /// Total over the leaflets.
    pub area_mm2: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    Converged,
    NotConverged,
    /// The solver stopped at the time limit (or ran past it).
    TimeLimit,
    /// The closure refused or failed (reason says why): no numbers.
    Failed,
    /// Not run: a coarser mesh of the same combination reached the limit.
    Skipped,
}

impl Status {
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::NotConverged => "not converged",
            Status::TimeLimit => "time limit",
            Status::Failed => "failed",
            Status::Skipped => "skipped",
        }
    }
}

/// Errors against the reference (row minus reference; displacement as
/// node-wise distances).
#[derive(Debug, Clone, PartialEq)]
pub struct Errors {
    pub height_mm: Option<f64>,
    pub central_height_mm: Option<f64>,
    pub area_mm2: f64,
    pub displacement: std::result::Result<DisplacementError, String>,
}

#[derive(Debug, Clone)]
pub struct Row {
    pub case: &'static str,
    pub model: String,
    pub solver: String,
    pub contact: String,
    pub h: f64,
    pub nodes: usize,
    pub triangles: usize,
    pub status: Status,
    pub iterations: usize,
    pub residual_n: f64,
    pub wall_s: f64,
    pub reason: String,
    pub coaptation: Option<Coaptation>,
    /// Closed minus placed position per node (mm).
    displacement: Option<Vec<V3>>,
    /// Index of the row's mesh.
    mesh: usize,
    /// "newton h 0.25 mm" of the reference row, when there is one.
    pub reference: Option<String>,
    pub is_reference: bool,
    pub errors: Option<Errors>,
}

impl Row {
    pub fn converged(&self) -> bool {
        self.status == Status::Converged
    }
}

/// What a grid run produced.
#[derive(Debug, Clone)]
pub struct Grid {
    pub rows: Vec<Row>,
    /// Combinations left out, with why.
    pub notes: Vec<String>,
}

/// Check the options, then run the grid.
pub fn run(opts: &Options) -> Result<Grid> {
    validate(opts)?;
    let work = super::work_dir::WorkDir::new(opts.work.as_deref(), "close-grid");
    run_in(opts, work.path())
}

fn validate(opts: &Options) -> Result<()> {
    if opts.hs.is_empty() || opts.hs.iter().any(|h| !(*h > 0.0 && h.is_finite())) {
        return Err(Error::usage(
            "--hs: mesh sizes must be positive numbers (mm)",
        ));
    }
    if !(opts.time_limit_s > 0.0 && opts.time_limit_s.is_finite()) {
        return Err(Error::usage(
            "--time-limit must be a positive number of seconds",
        ));
    }
    for (flag, given, known) in [
        ("--models", &opts.models, &MODELS[..]),
        ("--solvers", &opts.solvers, &SOLVERS[..]),
        ("--contacts", &opts.contacts, &CONTACTS[..]),
    ] {
        if given.is_empty() {
            return Err(Error::usage(format!("{flag}: give at least one")));
        }
        if let Some(bad) = given.iter().find(|g| !known.contains(&g.as_str())) {
            return Err(Error::usage(format!(
                "{flag} {bad}: expected one of {}",
                known.join(", ")
            )));
        }
    }
    if opts.case == Case::OzakiCylinder && opts.contacts.iter().any(|c| c == "leaflets") {
        return Err(Error::usage(
            "--contacts leaflets: the ozaki-cylinder case has one leaflet, closed against planes",
        ));
    }
    if let Case::Sample(dir) = &opts.case {
        for f in ["ct.nii.gz", "landmarks.mrk.json"] {
            let p = dir.join(f);
            if !p.is_file() {
                return Err(Error::usage(format!(
                    "--sample {}: no {} (the committed sample phantom lives in sample_data/ of the repository)",
                    dir.display(),
                    p.display()
                )));
            }
        }
    }
    Ok(())
}

/// The combinations a grid runs, in order: (model, contact, solver).
/// Relaxation and the combined solver refuse true contact (Newton's steps
/// are filtered so that nothing crosses), so those are left out and noted.
fn combinations(opts: &Options) -> (Vec<(String, String, String)>, Vec<String>) {
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for m in &opts.models {
        for c in &opts.contacts {
            for s in &opts.solvers {
                if c == "leaflets" && s != "newton" {
                    let note = format!(
                        "{s} with contact = leaflets not run: only Newton handles true contact (its steps are filtered so that nothing crosses)"
                    );
                    if !notes.contains(&note) {
                        notes.push(note);
                    }
                    continue;
                }
                out.push((m.clone(), c.clone(), s.clone()));
            }
        }
    }
    (out, notes)
}

fn run_in(opts: &Options, work: &Path) -> Result<Grid> {
    let mut hs = opts.hs.clone();
    hs.sort_by(|a, b| b.total_cmp(a));
    hs.dedup();
    let (combos, notes) = combinations(opts);
    let mut rows: Vec<Row> = Vec::new();
    let mut meshes: Vec<Mesh> = Vec::new();
    // Combinations that reached the time limit on a coarser mesh.
    let mut stopped: BTreeMap<(String, String, String), f64> = BTreeMap::new();
    println!("{}", progress_header());
    for &h in &hs {
        let mesh = make_mesh(&opts.case, h, work, opts.threads)?;
        meshes.push(mesh);
        let mi = meshes.len() - 1;
        let mesh = &meshes[mi];
        for key in &combos {
            let (model, contact, solver) = key;
            let mut row = Row {
                case: opts.case.name(),
                model: model.clone(),
                solver: solver.clone(),
                contact: contact.clone(),
                h,
                nodes: mesh.leaflets.x.len(),
                triangles: mesh.leaflets.tris.len(),
                status: Status::Skipped,
                iterations: 0,
                residual_n: f64::NAN,
                wall_s: f64::NAN,
                reason: String::new(),
                coaptation: None,
                displacement: None,
                mesh: mi,
                reference: None,
                is_reference: false,
                errors: None,
            };
            if let Some(coarse) = stopped.get(key) {
                row.reason = format!(
                    "not run: h {coarse} mm reached the {} s time limit",
                    opts.time_limit_s
                );
            } else {
                close_row(&mut row, mesh, opts.time_limit_s)?;
                if row.status == Status::TimeLimit {
                    stopped.insert(key.clone(), h);
                }
            }
            println!("{}", progress_line(&row));
            let _ = std::io::stdout().flush();
            rows.push(row);
        }
    }
    compare(&mut rows, &meshes);
    // Rows in a stable order: model, contact, solver, then coarse to fine.
    let order = |r: &Row| {
        (
            opts.models.iter().position(|m| *m == r.model),
            opts.contacts.iter().position(|c| *c == r.contact),
            opts.solvers.iter().position(|s| *s == r.solver),
        )
    };
    rows.sort_by(|a, b| order(a).cmp(&order(b)).then(b.h.total_cmp(&a.h)));
    Ok(Grid { rows, notes })
}

/// Close one row's leaflets and measure them. Only the closure is timed.
fn close_row(row: &mut Row, mesh: &Mesh, time_limit_s: f64) -> Result<()> {
    let text = config_text(&row.model, &row.solver, &row.contact, time_limit_s)
        .map_err(|e| Error::failed("bench close --grid", e))?;
    let cfg = config::parse(&text).map_err(|e| {
        Error::failed(
            "bench close --grid",
            format!("pipelines/close.toml as {}: {e}", row.model),
        )
    })?;
    let mut l = mesh.leaflets.clone();
    if row.model == "goh" && l.fibers.is_none() {
        l.fibers = close::circumferential_fibres(&l);
    }
    let t0 = Instant::now();
    let res = closure::close(&l, &cfg, Some(mesh.axis));
    row.wall_s = t0.elapsed().as_secs_f64();
    match res {
        Ok(c) => {
            let o = &c.outcome;
            row.iterations = o.iterations;
            row.residual_n = o.residual_n;
            row.reason = o.reason.clone();
            row.status = if o.converged {
                Status::Converged
            } else if o.stopped_by == coapt_mech::solve::Stopped::TimeLimit
                || row.wall_s >= time_limit_s
            {
                Status::TimeLimit
            } else {
                Status::NotConverged
            };
            row.coaptation = Some(measure(mesh, &l, &c, cfg.thickness));
            row.displacement = Some(c.x.iter().zip(&l.x).map(|(a, b)| a - b).collect());
        }
        Err(e) => {
            row.status = Status::Failed;
            row.reason = e;
        }
    }
    Ok(())
}

/// The report's coaptation numbers on the sample (zones within 1.8 × the
/// thickness of another leaflet, heights along the valve axis); the peer
/// case's own zone against its two planes otherwise.
fn measure(mesh: &Mesh, l: &Leaflets, c: &Closed, thickness: f64) -> Coaptation {
    match &mesh.frame {
        Some(frame) => {
            let p = |v: &V3| Point3::new(v.x, v.y, v.z);
            let v = ClosedValve {
                x: c.x.iter().map(p).collect(),
                x0: l.x.iter().map(p).collect(),
                tris: l.tris.clone(),
                tri_leaflet: l.leaflet.iter().map(|&k| k as u8).collect(),
                boundary: l.boundary.clone(),
                ref_uv: l.ref_uv.clone(),
                frame: frame.clone(),
                leaflets: l.leaflet.iter().map(|&k| k as usize + 1).max().unwrap_or(0),
            };
            let zones = coaptation::find(
                &v,
                &coaptation::Options {
                    margin_mm: MARGIN_PER_THICKNESS * thickness,
                    refine: REFINE,
                },
            );
            let m = metrics::measure(&v, &zones, &metrics::Options::default());
            Coaptation {
                height_mm: m.coaptation_height_mm,
                central_height_mm: m.central_coaptation_height_mm,
                area_mm2: m.leaflets.iter().map(|l| l.coaptation_area_mm2).sum(),
            }
        }
        None => {
            let m = close::metrics(l, c);
            Coaptation {
                height_mm: Some(m.coaptation_height_mm),
                central_height_mm: None,
                area_mm2: m.contact_area_mm2,
            }
        }
    }
}

/// Errors of every row against the finest converged Newton row of its
/// model and contact kind.
fn compare(rows: &mut [Row], meshes: &[Mesh]) {
    let mut refs: BTreeMap<(String, String), usize> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        if r.solver != "newton" || !r.converged() {
            continue;
        }
        let key = (r.model.clone(), r.contact.clone());
        match refs.get(&key) {
            Some(&j) if rows[j].h <= r.h => {}
            _ => {
                refs.insert(key, i);
            }
        }
    }
    let errors: Vec<Option<(String, bool, Errors)>> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let &j = refs.get(&(r.model.clone(), r.contact.clone()))?;
            let rf = &rows[j];
            let name = format!("newton {} h {} mm", rf.contact, rf.h);
            let (a, b) = (r.coaptation?, rf.coaptation?);
            let diff = |x: Option<f64>, y: Option<f64>| Some(x? - y?);
            let displacement = field(r, meshes).and_then(|f| {
                field(rf, meshes).and_then(|g| displacement_error::displacement_error(&f, &g))
            });
            Some((
                name,
                i == j,
                Errors {
                    height_mm: diff(a.height_mm, b.height_mm),
                    central_height_mm: diff(a.central_height_mm, b.central_height_mm),
                    area_mm2: a.area_mm2 - b.area_mm2,
                    displacement,
                },
            ))
        })
        .collect();
    for (r, e) in rows.iter_mut().zip(errors) {
        if let Some((name, is_ref, e)) = e {
            r.reference = Some(name);
            r.is_reference = is_ref;
            r.errors = Some(e);
        }
    }
}

/// A closed row as the displacement comparison sees it.
fn field<'a>(row: &'a Row, meshes: &'a [Mesh]) -> std::result::Result<Field<'a>, String> {
    let m = &meshes[row.mesh].leaflets;
    Ok(Field {
        uv: m.ref_uv.as_deref().ok_or("the leaflets have no ref_uv")?,
        tris: &m.tris,
        tri_leaflet: &m.leaflet,
        displacement: row.displacement.as_deref().ok_or("no closed state")?,
    })
}

/// The leaflets of the case at mesh size `h`.
fn make_mesh(case: &Case, h: f64, work: &Path, threads: usize) -> Result<Mesh> {
    match case {
        Case::OzakiCylinder => {
            let (leaflets, axis) =
                close::ozaki_cylinder(h).map_err(|e| Error::failed("bench close --grid", e))?;
            Ok(Mesh {
                leaflets,
                axis,
                frame: None,
            })
        }
        Case::Sample(dir) => sample_mesh(dir, h, work, threads),
    }
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// The sample's chain up to the leaflets at mesh size `h`, in `work/run`.
fn sample_mesh(sample: &Path, h: f64, work: &Path, threads: usize) -> Result<Mesh> {
    std::fs::create_dir_all(work).map_err(|e| Error::write(work, e))?;
    let abs = |f: &str| {
        let p = sample.join(f);
        std::fs::canonicalize(&p).map_err(|e| Error::read(&p, e))
    };
    let template = work.join("template.toml");
    std::fs::write(&template, TEMPLATE_TOML).map_err(|e| Error::write(&template, e))?;
    let text = format!(
        "# Written by `coapt bench close --grid`: the committed sample up to the leaflets.\n\
         [run]\ndir = \"run\"\n\n[inputs]\nct = {}\nlandmarks = {}\ntemplate = \"template.toml\"\n\n\
         [leaflets]\nh = \"{h} mm\"\n",
        toml_string(&abs("ct.nii.gz")?.to_string_lossy()),
        toml_string(&abs("landmarks.mrk.json")?.to_string_lossy()),
    );
    let config = work.join("run.toml");
    std::fs::write(&config, text).map_err(|e| Error::write(&config, e))?;
    let inv = Invocation {
        command_line: vec![
            "coapt".into(),
            "bench".into(),
            "close".into(),
            "--grid".into(),
        ],
        threads,
        log: LogMode {
            quiet: true,
            json: false,
        },
    };
    runner::run(
        &RunOptions {
            config,
            out: None,
            from: None,
            until: Some("leaflets".into()),
            force: false,
        },
        registry(),
        &inv,
    )?;
    let run = work.join("run");
    let lpath = run.join("leaflets.vtp");
    let mesh = vtp::read_mesh(&lpath)?;
    let leaflets =
        coapt_mech::model::leaflets_from_mesh(&mesh).map_err(|e| Error::bad_input(&lpath, e))?;
    let vpath = run.join("valve.json");
    let frame = valve_json::read_frame(&vpath)?;
    Ok(Mesh {
        leaflets,
        axis: axis_from_valve(&vpath)?,
        frame: Some(frame),
    })
}

/// The axis the close stage takes from valve.json: the valve frame's axis
/// through the commissure cylinder's centre.
fn axis_from_valve(path: &Path) -> Result<Axis> {
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(path).map_err(|e| Error::read(path, e))?)
            .map_err(|e| Error::bad_input(path, format!("not JSON: {e}")))?;
    let get = |p: &serde_json::Value| -> Option<V3> {
        Some(V3::new(p[0].as_f64()?, p[1].as_f64()?, p[2].as_f64()?))
    };
    let dir = get(&v["valve_frame"]["axis"])
        .filter(|d| d.norm() > 0.5)
        .ok_or_else(|| Error::bad_input(path, "no unit valve_frame.axis"))?;
    let origin = get(&v["commissure_cylinder"]["centre_mm"])
        .ok_or_else(|| Error::bad_input(path, "no commissure_cylinder.centre_mm"))?;
    Ok(Axis {
        origin,
        dir: dir.normalize(),
    })
}

fn progress_header() -> String {
    format!(
        "{:<12} {:<9} {:<8} {:>5} {:>6} {:<13} {:>5} {:>9} {:>8} {:>7} {:>7} {:>8}",
        "model",
        "solver",
        "contact",
        "h_mm",
        "nodes",
        "status",
        "iter",
        "resid_N",
        "wall_s",
        "coapt_h",
        "central",
        "area_mm2"
    )
}

fn progress_line(r: &Row) -> String {
    let o = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
    // A skipped row has no residual or time: a dash, not "NaN".
    let finite = |v: f64| Some(v).filter(|v| v.is_finite());
    let c = r.coaptation;
    format!(
        "{:<12} {:<9} {:<8} {:>5} {:>6} {:<13} {:>5} {:>9} {:>8} {:>7} {:>7} {:>8}",
        r.model,
        r.solver,
        r.contact,
        r.h,
        r.nodes,
        r.status.as_str(),
        r.iterations,
        finite(r.residual_n).map_or("-".to_string(), |v| format!("{v:.2e}")),
        o(finite(r.wall_s), 2),
        o(c.and_then(|c| c.height_mm), 2),
        o(c.and_then(|c| c.central_height_mm), 2),
        o(c.map(|c| c.area_mm2), 1),
    )
}

pub const CSV_HEADER: &str = "case,model,solver,contact,h_mm,nodes,triangles,status,converged,iterations,residual_n,wall_s,coaptation_height_mm,central_coaptation_height_mm,coaptation_area_mm2,reference,is_reference,err_coaptation_height_mm,err_central_coaptation_height_mm,err_coaptation_area_mm2,disp_err_rms_mm,disp_err_max_mm,disp_err_extrapolated_nodes,reason";

/// The grid as CSV. `reference` names the row the errors are taken
/// against: the finest converged Newton closure of the same model and
/// contact kind; errors are row minus reference, empty where not
/// measurable.
pub fn csv(g: &Grid) -> String {
    let f = |v: Option<f64>| {
        v.map_or(String::new(), |v| {
            let t = format!("{v:.6}");
            // A difference that rounds to zero is zero, whatever its sign.
            if t == "-0.000000" {
                t[1..].to_string()
            } else {
                t
            }
        })
    };
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in &g.rows {
        let c = r.coaptation;
        let e = r.errors.as_ref();
        let d = e.and_then(|e| e.displacement.as_ref().ok());
        let mut reason = r.reason.clone();
        if let Some(Err(why)) = e.map(|e| &e.displacement) {
            reason = format!("{reason}; displacement error: {why}");
        }
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.case,
            r.model,
            r.solver,
            r.contact,
            r.h,
            r.nodes,
            r.triangles,
            r.status.as_str(),
            r.converged(),
            r.iterations,
            if r.residual_n.is_finite() {
                format!("{:.4e}", r.residual_n)
            } else {
                String::new()
            },
            if r.wall_s.is_finite() {
                format!("{:.3}", r.wall_s)
            } else {
                String::new()
            },
            f(c.and_then(|c| c.height_mm)),
            f(c.and_then(|c| c.central_height_mm)),
            f(c.map(|c| c.area_mm2)),
            r.reference.as_deref().unwrap_or("none"),
            r.is_reference,
            f(e.and_then(|e| e.height_mm)),
            f(e.and_then(|e| e.central_height_mm)),
            f(e.map(|e| e.area_mm2)),
            f(d.map(|d| d.rms_mm)),
            f(d.map(|d| d.max_mm)),
            d.map_or(String::new(), |d| d.outside.to_string()),
            reason.replace('"', "'")
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_configs_follow_the_pipeline_and_set_the_model() {
        let goh = config::parse(&config_text("goh", "newton", "planes", 60.0).unwrap()).unwrap();
        let pipeline = config::parse(CLOSE_TOML).unwrap();
        assert_eq!(goh.model, pipeline.model);
        assert!(goh.bending && pipeline.bending);
        assert_eq!(goh.time_limit, 60.0);
        let msm = config::parse(&config_text("msm", "relax", "planes", 5.0).unwrap()).unwrap();
        assert_eq!(
            msm.model,
            config::Model::Msm(coapt_mech::material::msm::Law::Linear { young: 1.0 })
        );
        assert_eq!(msm.reference, config::Reference::Flat);
        assert_eq!(msm.solver, config::SolverKind::Relax);
        assert_eq!(
            (msm.thickness, msm.pressure),
            (pipeline.thickness, pipeline.pressure)
        );
        let nh =
            config::parse(&config_text("neo-hookean", "newton", "leaflets", 5.0).unwrap()).unwrap();
        assert_eq!(nh.model, config::Model::NeoHookean { mu: 0.9 });
        assert_eq!(nh.contact, config::ContactKind::Leaflets);
        assert!(config_text("svk", "newton", "planes", 5.0).is_err());
    }

    #[test]
    fn relax_and_combined_are_left_out_of_true_contact() {
        let opts = Options {
            case: Case::OzakiCylinder,
            hs: vec![3.0],
            models: vec!["msm".into()],
            solvers: SOLVERS.iter().map(|s| s.to_string()).collect(),
            contacts: vec!["planes".into(), "leaflets".into()],
            time_limit_s: 1.0,
            work: None,
            threads: 1,
        };
        let (c, notes) = combinations(&opts);
        let leaflets: Vec<&str> = c
            .iter()
            .filter(|k| k.1 == "leaflets")
            .map(|k| k.2.as_str())
            .collect();
        assert_eq!(leaflets, ["newton"]);
        assert_eq!(c.len(), 4);
        assert_eq!(notes.len(), 2);
        // The one-leaflet case has nothing to touch but its planes.
        assert!(validate(&opts).is_err());
    }
}
