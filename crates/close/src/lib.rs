//! The `close` stage: read placed leaflets, close them under diastolic
//! pressure, write the deformed leaflets and the solver's record.

use serde_json::{Value as Json, json};

use coapt_base::{Error, Result};
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::closest_point;
use coapt_geom::crossings;
use coapt_geom::{DataArray, DataValues, Frame, Point3, TriMesh};
use coapt_io::{Transaction, atomic, vtp};
use coapt_mech::closure::{self};
use coapt_mech::config;
use coapt_mech::contact::wall_barrier::WALL_BIT;
use coapt_mech::element::V3;
use coapt_mech::model::{Axis, Leaflets, leaflets_from_mesh};
use coapt_mech::suture;
use coapt_mech::wall::Wall;
use coapt_pipeline::{ArtifactKind, Params, Port, Progress, StageIo, StageSpec};

pub static SPEC: StageSpec = StageSpec {
    name: "close",
    about: "Close the leaflets under diastolic pressure (membrane mechanics, contact, Newton)",
    inputs: &[
        Port {
            name: "leaflets",
            flag: "leaflets",
            file: "leaflets.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "placed leaflets from `coapt leaflets` (point data boundary, ref_uv; cell data leaflet)",
        },
        Port {
            name: "surface",
            flag: "surface",
            file: "aorta.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "lumen wall: the sutured nodes are checked to lie on it",
        },
        Port {
            name: "config",
            flag: "config",
            file: "close.toml",
            kind: ArtifactKind::MechConfig,
            required: true,
            help: "model, material, thickness, pressure, contact, solver (explicit units)",
        },
        Port {
            name: "valve",
            flag: "valve",
            file: "valve.json",
            kind: ArtifactKind::Json,
            required: false,
            help: "valve frame (axis); without it the axis is fitted to the lug corners",
        },
    ],
    outputs: &[
        Port {
            name: "closed",
            flag: "out",
            file: "closed.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "deformed leaflets: point data displacement, contact; cell data area_stretch, max_stretch",
        },
        Port {
            name: "log",
            flag: "log",
            file: "closure.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "model, parameters, solver history, contact pairs, timings, converged or why not",
        },
    ],
    out_dir: None,
    params: &[],
    check: |_| Ok(()),
    run,
};

fn v3(p: &Point3) -> V3 {
    V3::new(p.x, p.y, p.z)
}

fn axis_from_valve(path: &std::path::Path) -> Result<Axis> {
    let v: Json = serde_json::from_slice(&std::fs::read(path).map_err(|e| Error::read(path, e))?)
        .map_err(|e| Error::bad_input(path, e.to_string()))?;
    let get =
        |p: &Json| -> Option<V3> { Some(V3::new(p[0].as_f64()?, p[1].as_f64()?, p[2].as_f64()?)) };
    // The frame as every stage reads it.
    let a = coapt_io::valve_json::read_frame(path)?.axis;
    let origin = get(&v["commissure_cylinder"]["centre_mm"])
        .ok_or_else(|| Error::bad_input(path, "no commissure_cylinder.centre_mm"))?;
    Ok(Axis {
        origin,
        dir: V3::new(a.x, a.y, a.z),
    })
}

/// The wall the suture line is sewn to: its wall triangles (region 0) when
/// the surface labels its caps, else all of it.
fn wall_of(m: &TriMesh) -> Wall {
    let tris = m.wall_triangles();
    Wall::mesh(m.vertices.iter().map(v3).collect(), tris)
}

/// Distance (mm) of every sutured node to the wall.
fn suture_distances(l: &Leaflets, wall: &TriMesh) -> Vec<f64> {
    let wx: Vec<V3> = wall.vertices.iter().map(v3).collect();
    let bvh = Bvh::build(&wx, &wall.triangles);
    let mut out = Vec::new();
    for (i, p) in l.x.iter().enumerate() {
        if l.boundary[i] != 1 {
            continue;
        }
        let mut r = 0.5;
        loop {
            let mut best = f64::INFINITY;
            bvh.query_sphere(p, r, |t| {
                let tri = wall.triangles[t as usize];
                let c = closest_point(
                    p,
                    &wx[tri[0] as usize],
                    &wx[tri[1] as usize],
                    &wx[tri[2] as usize],
                );
                best = best.min((c.point - p).norm());
            });
            if best <= r || r > 1e3 {
                out.push(best);
                break;
            }
            r *= 4.0;
        }
    }
    out
}

/// How far a solve has come by its residual: ln(r₀/r) / ln(r₀/goal), 0 at
/// its first residual r₀ and 1 at the goal, max(absolute, relative × r₀).
/// A Newton solve's residual falls by orders of magnitude, and each order
/// takes about as long as the last, so the log is what tracks time.
fn residual_fraction(r0: f64, r: f64, (abs_n, rel): (f64, f64)) -> f64 {
    let goal = abs_n.max(rel * r0);
    if !(r0 > goal) {
        return 1.0;
    }
    if !(r < r0) {
        return 0.0;
    }
    ((r0 / r).ln() / (r0 / goal).ln()).clamp(0.0, 1.0)
}

/// The stage's bar while the solver runs: the suturing rounds fill the
/// `suture` span of the bar, the closure the `close` span, each never going
/// back (a suturing round starts from a larger residual than the last ended
/// at).
fn bar_watch(
    progress: &Progress,
    goal: (f64, f64),
    suture: (f64, f64),
    close: (f64, f64),
) -> closure::Watch {
    let bar = progress.clone();
    // Per solve: its first residual and the furthest fraction reached.
    let seen = std::sync::Mutex::new([(f64::NAN, 0.0f64); 2]);
    std::sync::Arc::new(move |solve, r| {
        let (k, (lo, hi)) = match solve {
            closure::Solve::Suture => (0, suture),
            closure::Solve::Close => (1, close),
        };
        let Ok(mut s) = seen.lock() else { return };
        let (first, best) = &mut s[k];
        if first.is_nan() {
            *first = r;
        }
        *best = best.max(residual_fraction(*first, r, goal));
        bar.set(lo + *best * (hi - lo));
    })
}

fn run(io: &StageIo, _params: &Params, progress: &Progress) -> Result<Json> {
    let lpath = io.input("leaflets").expect("required");
    let mesh = vtp::read_mesh(lpath)?;
    let leaflets = leaflets_from_mesh(&mesh).map_err(|e| Error::bad_input(lpath, e))?;
    let cpath = io.input("config").expect("required");
    let mut cfg = config::read(cpath)?;
    let already_sutured = mesh
        .field_data
        .get("sutured")
        .and_then(|a| a.values.to_f64())
        .is_some_and(|v| v.first() == Some(&1.0));
    if cfg.suture.mode == suture::Mode::Auto && already_sutured {
        cfg.suture.mode = suture::Mode::Off;
    }
    let spath = io.input("surface").expect("required");
    let wall = vtp::read_mesh(spath)?;
    let d = suture_distances(&leaflets, &wall);
    let axis = match io.input("valve") {
        Some(p) => Some(axis_from_valve(p)?),
        None => None,
    };
    progress.set(0.05);
    let wall_normals = wall_of(&wall);
    let goal = (cfg.tolerance, cfg.relative_tolerance);
    let watch = bar_watch(progress, goal, (0.05, 0.35), (0.35, 0.95));
    let sewn = closure::sew(&leaflets, &cfg, axis, Some(&wall_normals), Some(&watch))
        .map_err(|e| Error::bad_input(lpath, e))?;
    // The seeds read the effective height on an extra closure at a low
    // pressure (3 mmHg), where the leaflets just meet without being pressed.
    // It starts from the same sewing, not from the first closure, so the
    // two run side by side: on two cores the second fills the core the
    // first leaves idle while it factorises. It counts only when the first
    // converges (its result, or its error, is dropped otherwise).
    let low_cfg = cfg.effective_height_pressure.map(|p| {
        let mut c = cfg.clone();
        c.pressure = p;
        c.effective_height_pressure = None;
        c
    });
    let sewn = sewn.as_ref();
    let main = || {
        closure::close_watched(
            &leaflets,
            &cfg,
            axis,
            Some(&wall_normals),
            sewn,
            Some(&watch),
        )
    };
    let low = || {
        low_cfg
            .as_ref()
            .map(|c| closure::close_watched(&leaflets, c, axis, Some(&wall_normals), sewn, None))
    };
    // On one thread nothing runs beside the first closure, so the second
    // waits for it and is skipped when it fails, as before.
    let (closed, low) = if rayon::current_num_threads() > 1 {
        rayon::join(main, low)
    } else {
        let closed = main();
        let converged = closed.as_ref().is_ok_and(|c| c.outcome.converged);
        (closed, if converged { low() } else { None })
    };
    let closed = closed.map_err(|e| Error::bad_input(lpath, e))?;
    let low = match low {
        Some(l) if closed.outcome.converged => Some(l.map_err(|e| Error::bad_input(lpath, e))?),
        _ => None,
    };
    progress.set(0.95);
    let o = &closed.outcome;
    // Interpenetration check on the final state (`close_on`): exact
    // triangle–triangle tests between different leaflets, by the rule of
    // leaflets.json (neighbours sewn to one post touch there: counted apart).
    let crossing = &closed.crossings;
    let log = closure_log(&cfg, &leaflets, &d, already_sutured, &closed, low.as_ref());
    let text = serde_json::to_string_pretty(&log).expect("json") + "\n";
    let low_failed = low.as_ref().filter(|l| !l.outcome.converged);
    if !o.converged || low_failed.is_some() {
        let (what, reason) = match low_failed {
            Some(l) if o.converged => (
                "the low-pressure closure (effective_height_pressure) did not converge",
                &l.outcome.reason,
            ),
            _ => ("did not converge", &o.reason),
        };
        atomic::write_atomic(io.output("log"), |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })?;
        return Err(Error::failed(
            "close",
            format!(
                "{what}: {reason} (history in {})",
                io.output("log").display()
            ),
        ));
    }
    let out = closed_mesh(&mesh, &leaflets, &closed, low.as_ref());
    let pd = out.to_polydata();
    let mut tx = Transaction::new();
    tx.write(io.output("closed"), |w| {
        vtp::encode(w, &pd, &vtp::WriteOptions::default())
    })?;
    tx.write_bytes(io.output("log"), text.as_bytes())?;
    tx.commit()?;
    progress.set(1.0);
    Ok(json!({
        "converged": true,
        "iterations": o.iterations,
        "residual_n": o.residual_n,
        "nodes_in_contact": in_contact(&closed.contact),
        "intersecting_triangle_pairs": crossing.len(),
        "solve_s": closed.solve_s,
    }))
}

/// Nodes touching another leaflet (or a plane), not the wall (the wall
/// contact has its own record).
fn in_contact(contact: &[u8]) -> usize {
    contact.iter().filter(|&&m| m & !WALL_BIT != 0).count()
}

/// closure.json: the config, the mesh, the suturing, the solver's account
/// (and the low-pressure closure's), contacts, crossings and timings.
fn closure_log(
    cfg: &config::CloseConfig,
    leaflets: &Leaflets,
    d: &[f64],
    already_sutured: bool,
    closed: &closure::Closed,
    low: Option<&closure::Closed>,
) -> Json {
    let o = &closed.outcome;
    let dmax = d.iter().cloned().fold(0.0, f64::max);
    let mut log = json!({
        "frame": "LPS",
        "config": cfg.to_json(),
        "model": cfg.model_name(),
        "nodes": leaflets.x.len(),
        "triangles": leaflets.tris.len(),
        "free_dofs": leaflets.boundary.iter().filter(|&&b| b != 1).count() * 3,
        "sutured_to_wall_mm": {"max": dmax, "mean": d.iter().sum::<f64>() / d.len().max(1) as f64},
        "suturing": match &closed.suturing {
            Some(s) => serde_json::to_value(s).expect("json"),
            None if already_sutured => json!("skipped: the leaflets say they are sutured (field data sutured = 1)"),
            None => json!("skipped: suture.mode = \"off\""),
        },
        "pressure_sign_per_leaflet": closed.pressure_sign,
        "solver": {
            "converged": o.converged,
            "stopped_by": o.stopped_by,
            "reason": o.reason,
            "iterations": o.iterations,
            "residual_n": o.residual_n,
            "initial_residual_n": o.initial_residual_n,
            "history": o.history,
        },
        "nodes_in_contact": in_contact(&closed.contact),
        "intersecting_triangle_pairs": closed.crossings.len(),
        "sewn_contacts": closed.sewn_contacts.len(),
        "crossing_rule": crossings::RULE,
        "low_pressure": low.map(|l| json!({
            "pressure_mmhg": cfg.effective_height_pressure.map(|p| p / coapt_base::units::MMHG_IN_MPA),
            "converged": l.outcome.converged,
            "stopped_by": l.outcome.stopped_by,
            "reason": l.outcome.reason,
            "iterations": l.outcome.iterations,
            "residual_n": l.outcome.residual_n,
            "intersecting_triangle_pairs": l.crossings.len(),
            "history": l.outcome.history,
        })),
        "timing_s": {"setup": closed.setup_s, "suture": closed.suturing.as_ref().map(|s| s.seconds), "solve": closed.solve_s, "low_pressure_solve": low.map(|l| l.solve_s)},
    });
    if let (Some(w), Some(o)) = (&closed.wall_contact, log.as_object_mut()) {
        o.insert(
            "wall_contact".into(),
            serde_json::to_value(w).expect("json"),
        );
    }
    if let (Some(w), Some(o)) = (&closed.wall_contact, log.as_object_mut()) {
        o.insert(
            "wall_contact".into(),
            serde_json::to_value(w).expect("json"),
        );
    }
    log
}

/// The closed leaflets: the placed mesh moved to the closed positions, with
/// the displacement, the sutured and low-pressure positions, the contact
/// bits and the stretches.
fn closed_mesh(
    mesh: &TriMesh,
    leaflets: &Leaflets,
    closed: &closure::Closed,
    low: Option<&closure::Closed>,
) -> TriMesh {
    let mut out = mesh.clone();
    out.vertices = closed
        .x
        .iter()
        .map(|p| Point3::new(p.x, p.y, p.z))
        .collect();
    let disp: Vec<[f64; 3]> = closed
        .x
        .iter()
        .zip(&leaflets.x)
        .map(|(a, b)| [a.x - b.x, a.y - b.y, a.z - b.z])
        .collect();
    out.point_data
        .insert(DataArray::vectors_f64("displacement", &disp));
    if let Some(s) = &closed.suturing {
        let p: Vec<[f64; 3]> = s.x.iter().map(|q| [q.x, q.y, q.z]).collect();
        out.point_data
            .insert(DataArray::vectors_f64("sutured_position", &p));
    }
    if let Some(l) = low {
        let p: Vec<[f64; 3]> = l.x.iter().map(|q| [q.x, q.y, q.z]).collect();
        out.point_data
            .insert(DataArray::vectors_f64("low_pressure_position", &p));
    }
    out.point_data.insert(DataArray::new(
        "contact",
        1,
        DataValues::U8(closed.contact.clone()),
    ));
    out.cell_data.insert(DataArray::scalars_f64(
        "area_stretch",
        closed.area_stretch.clone(),
    ));
    out.cell_data.insert(DataArray::scalars_f64(
        "max_stretch",
        closed.max_stretch.clone(),
    ));
    out.frame = Frame::Lps;
    out.frame = Frame::Lps;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_residual_fraction_counts_orders_of_magnitude() {
        let goal = (1e-7, 1e-7);
        // From 0.1 N to the 1e-7 N goal: six orders; three are half.
        assert_eq!(residual_fraction(0.1, 0.1, goal), 0.0);
        assert!((residual_fraction(0.1, 1e-4, goal) - 0.5).abs() < 1e-12);
        assert_eq!(residual_fraction(0.1, 1e-9, goal), 1.0);
        // A residual above the first is no progress; a first residual at
        // the goal is done; NaN is no progress.
        assert_eq!(residual_fraction(0.1, 0.3, goal), 0.0);
        assert_eq!(residual_fraction(1e-8, 1e-8, goal), 1.0);
        assert_eq!(residual_fraction(0.1, f64::NAN, goal), 0.0);
        // The relative goal when it is the larger: 1e-2 of 0.1 N.
        assert!((residual_fraction(0.1, 1e-2, (1e-7, 1e-2)) - 0.5).abs() < 1e-12);
    }

    /// The watch never moves the bar back, keeps each solve in its span,
    /// and a later suturing round starting higher does not undo the last.
    #[test]
    fn the_bar_watch_only_moves_forward_within_its_spans() {
        let p = Progress::hidden();
        let w = bar_watch(&p, (1e-7, 1e-7), (0.05, 0.35), (0.35, 0.8));
        let at = |p: &Progress| p.position();
        w(closure::Solve::Suture, 0.1);
        assert!((at(&p) - 0.05).abs() < 1e-3);
        w(closure::Solve::Suture, 1e-4);
        assert!((at(&p) - 0.20).abs() < 1e-3);
        w(closure::Solve::Suture, 1.0);
        assert!((at(&p) - 0.20).abs() < 1e-3);
        w(closure::Solve::Close, 1.0);
        assert!((at(&p) - 0.35).abs() < 1e-3);
        w(closure::Solve::Close, 1e-8);
        assert!((at(&p) - 0.8).abs() < 1e-3);
    }
}
