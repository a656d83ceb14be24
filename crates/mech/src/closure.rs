//! Close a set of placed leaflets under diastolic pressure: the library
//! function behind the `close` stage and `coapt bench close`.

use std::sync::Arc;
use std::time::Instant;

use super::bending::{self, Bending};
use super::config::{CloseConfig, ContactKind, Reference, SolverKind};
use super::contact::barrier::BarrierParams;
use super::contact::leaflet_barrier::LeafletBarrier;
use super::contact::wall_barrier::{WallBarrier, WallGeometry, WallSummary};
use super::element::{RefTri, V3};
use super::flat_bending::FlatBending;
use super::model::{
    Axis, Leaflets, axis_from_leaflets, leaflet_crossings, planes_for, pressure_signs,
    sutured_wall, tri_area_vec,
};
use super::reference_blend;
use super::solve::{
    self, NewtonOptions, Outcome, RelaxOptions, Stop, Stopped, load_steps, merge,
    newton_with_continuation,
};
use super::sparse::Dofs;
use super::suture::{self, Sutured};
use super::system::{PressureMode, System, Term};
use super::terms::PlaneContact;
use super::wall::Wall;

/// Largest nodal move of one Newton step (mm).
const MAX_STEP_MM: f64 = 0.5;

/// The suturing pre-stage's rounds get at most this many iterations of the
/// closure's budget (`max_iterations`, 1500 by default): a round that needs
/// more is a doubling of K the solver cannot follow, and suturing keeps its
/// last sewn state (on the real CT resampled to 2 mm a round's fallback
/// ran 300 iterations, 64 s, without converging).
const SEW_MAX_ITERATIONS: usize = 300;

#[derive(Debug, Clone)]
pub struct Closed {
    pub x: Vec<V3>,
    pub outcome: Outcome,
    /// Bit b: the node touches leaflet b (or plane b in plane mode); bit 7
    /// ([`super::contact::wall_barrier::WALL_BIT`]): it is within the wall
    /// barrier's margin (`wall_contact`).
    pub contact: Vec<u8>,
    /// Area stretch J and largest principal stretch per triangle.
    pub area_stretch: Vec<f64>,
    pub max_stretch: Vec<f64>,
    pub setup_s: f64,
    pub solve_s: f64,
    pub pressure_sign: Vec<f64>,
    /// The suturing pre-stage, when it ran (its `x` is where the closure
    /// started).
    pub suturing: Option<Sutured>,
    /// The wall barrier's record at the final state (`wall_contact`).
    pub wall_contact: Option<WallSummary>,
    /// Triangle pairs (i < j) of different leaflets that cross in the final
    /// state, and the pairs that only meet where neighbours are sewn to the
    /// same commissure post (both triangles with a sutured node): the rule
    /// of leaflets.json ([`coapt_geom::crossings`]).
    pub crossings: Vec<(u32, u32)>,
    pub sewn_contacts: Vec<(u32, u32)>,
}

fn stretches(x: &[V3], refs: &[RefTri], tris: &[[u32; 3]]) -> (Vec<f64>, Vec<f64>) {
    let mut j = Vec::with_capacity(tris.len());
    let mut m = Vec::with_capacity(tris.len());
    for (t, r) in tris.iter().zip(refs) {
        let mut f = nalgebra::Matrix3::zeros();
        for i in 0..3 {
            f += x[t[i] as usize] * r.d[i].transpose();
        }
        let c = f.transpose() * f;
        let ev = c.symmetric_eigen().eigenvalues;
        m.push(ev.iter().fold(0.0f64, |a, &b| a.max(b)).max(0.0).sqrt());
        j.push(tri_area_vec(x, t).norm() / r.area);
    }
    (j, m)
}

/// Growth of the leaflets' whole area beyond which a failed closure is
/// said to balloon (a closed valve's grows by tens of per cent), and area
/// ratio below which a triangle is said to have collapsed.
const BALLOON_AREA: f64 = 1.5;
const COLLAPSED_AREA: f64 = 0.05;
/// What a converged closure may leave unbalanced, as a fraction of the
/// pressure load.
const LOAD_FRACTION: f64 = 1e-3;

/// Newton's step criterion (`Stop::step_mm`) holds only at a residual
/// below this fraction of the pressure load, a tenth of what any converged
/// closure must meet: a guard against a short correction from an absurd
/// state, not an accuracy (the correction is that). On the real CT
/// (h 0.5 mm) the stalls sat at 1e-7 to 5e-5 of it, at 80 and at 3 mmHg,
/// with corrections of 1e-10 to 1e-5 mm.
const STEP_LOAD_FRACTION: f64 = 1e-4;

/// Why a closure that did not converge is where it is, read off its last
/// state, so that a failure names its physical cause before the solver's
/// account of it. `load`: P·(size/2)/(E′t), the membrane strain the
/// pressure asks for at the leaflets' scale. `None` when neither sign
/// shows.
fn failure_cause(
    ref_area: &[f64],
    area_stretch: &[f64],
    max_stretch: &[f64],
    load: f64,
) -> Option<String> {
    // The whole area, not the largest triangle's stretch: one squeezed
    // triangle can stretch a hundredfold while the leaflet does not.
    let a0: f64 = ref_area.iter().sum();
    let grown = ref_area
        .iter()
        .zip(area_stretch)
        .map(|(a, j)| a * j)
        .sum::<f64>()
        / a0;
    if grown > BALLOON_AREA {
        let lmax = max_stretch.iter().copied().fold(0.0f64, f64::max);
        return Some(format!(
            "the leaflets balloon: their area grew {grown:.1}-fold, a triangle {lmax:.1}-fold \
             (pressure × size / (E′·thickness) = {load:.2}): more load than this membrane carries \
             in equilibrium; a stiffer or thicker leaflet or a lower pressure"
        ));
    }
    let (t, amin) = area_stretch
        .iter()
        .copied()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, f64::INFINITY));
    (amin < COLLAPSED_AREA).then(|| {
        format!(
            "triangle {t} collapsed to {:.1} % of its area: the material does not resist it \
             (the MSM's edge springs) or the mesh is degenerate there",
            100.0 * amin
        )
    })
}

/// The stress-free triangles at `ref_x` (the reference's positions), with
/// the leaflets' fibres, which `coapt leaflets` gives tangent to the placed
/// triangles (`placed`).
fn reference_triangles(
    reference: Reference,
    thickness: f64,
    l: &Leaflets,
    placed: &[V3],
    ref_x: &[V3],
) -> Result<Vec<RefTri>, String> {
    Ok(match (reference, l.fibers.as_deref()) {
        // Projected onto the flat template's plane the placed fibres would
        // point anywhere; their edge coordinates carry over.
        (Reference::Flat, Some(f)) => {
            reference_blend::blended(placed, ref_x, &l.tris, 1.0, thickness, Some((f, placed)))?
        }
        _ => l
            .tris
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                let fib = l.fibers.as_ref().map(|f| f[t]);
                RefTri::new(tri.map(|i| ref_x[i as usize]), thickness, fib).ok_or_else(|| {
                    format!("triangle {t} is degenerate in the reference configuration")
                })
            })
            .collect::<Result<Vec<_>, String>>()?,
    })
}

/// Close the leaflets. `axis`: from valve.json when known, else estimated.
/// The suture line is sewn to the cylinder about the axis through it; see
/// [`close_on`] for a patient's wall.
pub fn close(l: &Leaflets, cfg: &CloseConfig, axis: Option<Axis>) -> Result<Closed, String> {
    close_on(l, cfg, axis, None, None)
}

/// Close the leaflets: suture them first (seed 001 Algorithm 1) unless
/// `cfg.suture.mode` is off (the stage turns `auto` into off for leaflets
/// that say they are sutured) or `sutured` gives the pre-stage's result
/// already ([`sew`]; its seconds count against `time_limit` as if it had
/// run here). `wall`: the wall whose tangent the sutured triangles turn to
/// (default: the cylinder about the axis).
pub fn close_on(
    l: &Leaflets,
    cfg: &CloseConfig,
    axis: Option<Axis>,
    wall: Option<&Wall>,
    sutured: Option<&Sutured>,
) -> Result<Closed, String> {
    close_watched(l, cfg, axis, wall, sutured, None)
}

/// Which solve a residual told to a [`Watch`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solve {
    /// The suturing pre-stage (its rounds, one after another).
    Suture,
    /// The closure under pressure.
    Close,
}

/// Told each Newton iteration's residual norm (N) and its solve: the
/// stage's progress bar. It never changes the result.
pub type Watch = std::sync::Arc<dyn Fn(Solve, f64) + Send + Sync>;

fn watching(w: Option<&Watch>, solve: Solve) -> Option<super::system::Watch> {
    w.map(|w| {
        let w = w.clone();
        std::sync::Arc::new(move |r: f64| w(solve, r)) as super::system::Watch
    })
}

/// The solver's stopping rules and Newton options from the settings.
fn solver_settings(cfg: &CloseConfig) -> (Stop, NewtonOptions) {
    let stop = Stop {
        abs_n: cfg.tolerance,
        rel: cfg.relative_tolerance,
        max_iterations: cfg.max_iterations,
        max_seconds: cfg.time_limit,
        step_mm: cfg.step_tolerance,
        step_residual_n: 0.0,
    };
    let nopt = NewtonOptions {
        stop: stop.clone(),
        max_step_mm: MAX_STEP_MM,
        max_rejections: 12,
        ..NewtonOptions::default()
    };
    (stop, nopt)
}

/// The axis given, else the leaflets' own; refused when nothing is sewn.
fn checked_axis(l: &Leaflets, axis: Option<Axis>) -> Result<Axis, String> {
    let axis = match axis {
        Some(a) => a,
        None => axis_from_leaflets(l)?,
    };
    if !l.boundary.iter().any(|&b| b == 1) {
        return Err("no sutured nodes (boundary = 1): the leaflets would float away".into());
    }
    Ok(axis)
}

/// The suturing pre-stage alone (seed 001 Algorithm 1), as [`close_watched`]
/// runs it when it is not given one: `None` when `cfg.suture.mode` is off.
/// Two closures of one valve (at the closing pressure and at the effective
/// height's) start from one sewing.
pub fn sew(
    l: &Leaflets,
    cfg: &CloseConfig,
    axis: Option<Axis>,
    wall: Option<&Wall>,
    watch: Option<&Watch>,
) -> Result<Option<Sutured>, String> {
    let axis = checked_axis(l, axis)?;
    if cfg.suture.mode == suture::Mode::Off {
        return Ok(None);
    }
    let (stop, nopt) = solver_settings(cfg);
    let stop = Stop {
        max_iterations: stop.max_iterations.min(SEW_MAX_ITERATIONS),
        ..stop
    };
    let nopt = NewtonOptions {
        stop: stop.clone(),
        ..nopt
    };
    // Without a wall mesh the suture line is sewn to the ideal root.
    let cyl;
    let wall = match wall {
        Some(w) => w,
        None => {
            cyl = sutured_wall(l, &axis);
            &cyl
        }
    };
    // With true contact the leaflets are sewn without crossing each other
    // too (the closure's barrier cannot undo it).
    let contact = (cfg.contact == ContactKind::Leaflets).then(|| {
        let dhat = cfg.contact_margin;
        suture::SewContact {
            dhat,
            xi: (cfg.thickness - 0.5 * dhat).max(0.0),
        }
    });
    suture::suture(
        l,
        &cfg.suture,
        &axis,
        wall,
        &stop,
        &nopt,
        contact,
        watching(watch, Solve::Suture),
    )
    .map(Some)
}

/// The closure's system on the sewn leaflets `l`: membrane, pressure and
/// the terms the settings ask for, each in its starting state. The load
/// steps build a fresh one, since terms keep state from their last update
/// (a hinge's branch, a barrier's candidates) that a jump back to the start
/// would leave behind.
#[allow(clippy::too_many_arguments)]
fn build_system(
    cfg: &CloseConfig,
    l: &Leaflets,
    axis: &Axis,
    n_leaflets: usize,
    wall: Option<&Wall>,
    ref_x: &[V3],
    refs: Vec<RefTri>,
    signs: &[f64],
    watch: Option<&Watch>,
) -> Result<(System, Option<Arc<WallGeometry>>), String> {
    let fixed: Vec<[bool; 3]> = l.boundary.iter().map(|&b| [b == 1; 3]).collect();
    let tri_pressure: Vec<f64> = l
        .leaflet
        .iter()
        .map(|&k| signs[k as usize] * cfg.pressure)
        .collect();
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    match cfg.contact {
        ContactKind::Leaflets if n_leaflets < 2 => {
            return Err(format!(
                "contact = \"leaflets\" is contact between leaflets and there is {n_leaflets} leaflet; a lone leaflet of a symmetric valve closes against its neighbours' planes: contact = \"planes\""
            ));
        }
        ContactKind::Leaflets => {
            if cfg.solver != SolverKind::Newton {
                return Err(
                    "contact = \"leaflets\" needs solver = \"newton\" (its steps are filtered so that nothing crosses)"
                        .into(),
                );
            }
            let params = BarrierParams::from_pressure(cfg.contact_margin, cfg.pressure.max(1e-6));
            let node_fixed: Vec<bool> = l.boundary.iter().map(|&b| b == 1).collect();
            // κ puts two sheets pressed by the closing pressure at
            // s = d̂/2; an offset of the thickness less d̂/2 puts their
            // mid-surfaces a thickness apart there, where two touching
            // leaflets are (leaflet_barrier.rs, "Offset").
            let xi = (cfg.thickness - 0.5 * params.dhat).max(0.0);
            terms.push(Box::new(LeafletBarrier::new(
                &l.x,
                &l.tris,
                &l.leaflet,
                &node_fixed,
                params,
                xi,
                2.0 * MAX_STEP_MM,
            )));
        }
        ContactKind::Planes => {
            let planes = planes_for(l, axis, n_leaflets, 1.1 * cfg.pressure, cfg.plane_offset)?;
            terms.push(Box::new(PlaneContact::new(planes, &l.x, &l.tris)));
        }
        _ => {}
    }
    let wall_geo = if cfg.wall_contact {
        if cfg.solver != SolverKind::Newton {
            return Err(
                "wall_contact = true needs solver = \"newton\" (its steps are filtered so that no node passes the wall)"
                    .into(),
            );
        }
        let shape = match wall {
            Some(w) => w.clone(),
            None => sutured_wall(l, axis),
        };
        // One node–wall pair per node (nothing pushes back from the wall):
        // twice the leaflet pairs' κ rests a pressed sheet at s = d̂/2
        // (|P|: a library caller may reverse the load onto the wall).
        let params =
            BarrierParams::from_pressure(cfg.contact_margin, 2.0 * cfg.pressure.abs().max(1e-6));
        let free: Vec<bool> = l.boundary.iter().map(|&b| b != 1).collect();
        let geo = Arc::new(WallGeometry::new(
            shape,
            &l.x,
            &l.tris,
            &free,
            params,
            0.5 * cfg.thickness,
        ));
        terms.push(Box::new(WallBarrier::new(geo.clone())));
        Some(geo)
    } else {
        None
    };
    if cfg.bending {
        let d = bending::stiffness(cfg.plane_strain_modulus(), cfg.thickness);
        // A flat rest state (the cut pericardium) bends by the quadratic
        // stencil, which a collapsing triangle cannot make singular; a
        // curved one needs the hinges' rest angles.
        let hinges = bending::hinges(ref_x, &l.tris, d);
        match FlatBending::from_hinges(&hinges, ref_x, d) {
            Some(flat) => terms.push(Box::new(flat)),
            None => terms.push(Box::new(Bending::from_hinges(hinges))),
        }
    }
    let sys = System {
        tris: l.tris.clone(),
        refs,
        materials: vec![cfg.membrane()],
        tri_material: vec![0; l.tris.len()],
        dofs: Dofs::new(&fixed),
        fixed,
        tri_pressure,
        pressure_scale: 1.0,
        pressure_mode: PressureMode::Follower,
        terms,
        project: false,
        pressure_tangent: true,
        watch: watching(watch, Solve::Close),
    };
    Ok((sys, wall_geo))
}

/// What a closure reports when suturing's first round failed: the leaflets
/// where suturing left them, nothing solved.
fn unsewn(l: &Leaflets, s: &Sutured, pressure_sign: Vec<f64>, setup_s: f64) -> Closed {
    let (crossings, sewn_contacts) = leaflet_crossings(l, &s.x);
    Closed {
        crossings,
        sewn_contacts,
        contact: vec![0; s.x.len()],
        area_stretch: Vec::new(),
        max_stretch: Vec::new(),
        setup_s,
        solve_s: 0.0,
        pressure_sign,
        outcome: Outcome {
            stopped_by: Stopped::SuturingFailed,
            reason: format!("suturing (seed 001 Algorithm 1) failed: {}", s.reason),
            iterations: s.iterations,
            residual_n: s.rounds.last().map_or(0.0, |r| r.residual_n),
            initial_residual_n: s.rounds.first().map_or(0.0, |r| r.residual_n),
            seconds: s.seconds,
            ..Outcome::start()
        },
        x: s.x.clone(),
        suturing: Some(s.clone()),
        wall_contact: None,
    }
}

/// `reference_steps` closures, the reference walking from the sutured
/// state to the one asked for (`ref_x`); each starts where the last left
/// off.
#[allow(clippy::too_many_arguments)]
fn walk_reference(
    cfg: &CloseConfig,
    l: &Leaflets,
    placed_x: &[V3],
    ref_x: &[V3],
    sys: &mut System,
    x: &mut Vec<V3>,
    stop: &Stop,
    nopt: &NewtonOptions,
    unprojected: bool,
    t1: Instant,
) -> Result<Outcome, String> {
    // The reference walks from the sutured state to the one asked
    // for; each step starts where the last left off.
    let target = std::mem::take(&mut sys.refs);
    let mut all: Option<Outcome> = None;
    let mut notes = Vec::new();
    for k in 1..=cfg.reference_steps {
        let s = k as f64 / cfg.reference_steps as f64;
        sys.refs = if k == cfg.reference_steps {
            target.clone()
        } else {
            reference_blend::blended(
                &l.x,
                ref_x,
                &l.tris,
                s,
                cfg.thickness,
                l.fibers.as_deref().map(|f| (f, placed_x)),
            )?
        };
        let left = Stop {
            max_seconds: (stop.max_seconds - t1.elapsed().as_secs_f64()).max(0.0),
            ..stop.clone()
        };
        let o = newton_with_continuation(sys, x, &left, nopt, unprojected);
        notes.push(format!("reference {s:.2} of the way: {}", o.reason));
        all = Some(merge(all, o));
        if left.max_seconds <= 0.0 {
            break;
        }
    }
    let mut o = all.unwrap_or_else(Outcome::start);
    o.reason = notes.join("; ");
    Ok(o)
}

type Build<'a> = dyn Fn() -> Result<(System, Option<Arc<WallGeometry>>), String> + 'a;

/// The full load at once; when that fails (but for the time limit), in
/// steps from the start, each step's system fresh from `build`.
#[allow(clippy::too_many_arguments)]
fn at_once_or_by_steps(
    sys: &mut System,
    x: &mut Vec<V3>,
    wall_geo: &mut Option<Arc<WallGeometry>>,
    build: &Build,
    stop: &Stop,
    nopt: &NewtonOptions,
    unprojected: bool,
    t1: Instant,
) -> Result<Outcome, String> {
    let start = x.clone();
    let o = newton_with_continuation(sys, x, stop, nopt, unprojected);
    if o.converged || o.stopped_by == Stopped::TimeLimit {
        Ok(o)
    } else {
        // The full load at once failed: raise it in steps, each from
        // the last equilibrium (`solve::load_steps`), with a budget of
        // its own and what is left of the time.
        let left = Stop {
            max_seconds: (stop.max_seconds - t1.elapsed().as_secs_f64()).max(0.0),
            ..stop.clone()
        };
        let mut geos = Vec::new();
        let stepped = {
            let mut fresh = || {
                let (s, g) = build()?;
                geos.push(g);
                Ok(s)
            };
            load_steps(&mut fresh, &start, &left, nopt, unprojected)?
        };
        match stepped.done {
            Some((xs, s)) => {
                let first = o.reason.clone();
                let mut all = merge(Some(o), stepped.outcome);
                all.reason = format!("{}; the full load at once: {first}", stepped.note);
                *x = xs;
                *sys = s;
                *wall_geo = geos.pop().flatten();
                Ok(all)
            }
            None => {
                let mut o = o;
                o.reason = format!("{}; then {}", o.reason, stepped.note);
                o.iterations += stepped.outcome.iterations;
                o.seconds += stepped.outcome.seconds;
                Ok(o)
            }
        }
    }
}

/// A closure's outcome judged, and what the judging measured.
struct Judged {
    outcome: Outcome,
    /// The sewn leaflets' bounding-box diagonal (mm).
    span: f64,
    crossings: Vec<(u32, u32)>,
    sewn_contacts: Vec<(u32, u32)>,
}

/// What the solver's `outcome` at `x` means for a closure: a time limit
/// that suturing spent, a residual that is large against the pressure load
/// `load_n`, a run-away node, a crossing leaflet pair (true contact) are
/// not converged, whatever the solver said; non-finite positions are an
/// error.
fn judge(
    mut outcome: Outcome,
    cfg: &CloseConfig,
    l: &Leaflets,
    x: &[V3],
    load_n: f64,
    sew_s: f64,
) -> Result<Judged, String> {
    if !outcome.converged && sew_s > 0.0 && outcome.stopped_by == Stopped::TimeLimit {
        outcome.reason = if outcome.iterations == 0 {
            format!(
                "no time left to close: suturing took {sew_s:.1} s of time_limit {} s",
                cfg.time_limit
            )
        } else {
            format!(
                "{} (time_limit {} s for the whole close; suturing took {sew_s:.1} s of it)",
                outcome.reason, cfg.time_limit
            )
        };
    }
    // A solver that ran away (relaxation with too large a step) can leave
    // finite but absurd positions: far beyond the leaflets' own size.
    let (lo, hi) = l.x.iter().fold(
        (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY)),
        |(a, b), p| (a.inf(p), b.sup(p)),
    );
    let span = (hi - lo).norm();
    let moved = x
        .iter()
        .zip(&l.x)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    // The relative tolerance measures from the first residual; from an
    // absurd start (the GOH's exponential on a badly strained reference)
    // it was met at 1e41 N. A closure has converged only when what is left
    // is small against the load it carries.
    let limit_n = cfg.tolerance.max(LOAD_FRACTION * load_n);
    if outcome.converged && !(outcome.residual_n <= limit_n) {
        outcome.converged = false;
        outcome.stopped_by = Stopped::NotAnEquilibrium;
        outcome.reason = format!(
            "residual {:.3e} N is more than {LOAD_FRACTION:.0e} of the pressure load ({load_n:.3e} N): the relative tolerance was met from a start of {:.3e} N, not an equilibrium; {}",
            outcome.residual_n, outcome.initial_residual_n, outcome.reason
        );
    }
    if moved > 100.0 * span && x.iter().all(|p| p.iter().all(|v| v.is_finite())) {
        outcome.converged = false;
        outcome.stopped_by = Stopped::Diverged;
        outcome.reason = format!(
            "diverged: a node moved {moved:.3e} mm, more than 100 times the leaflets' size ({span:.1} mm); {}",
            outcome.reason
        );
    }
    if x.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(format!(
            "the solver produced non-finite positions ({})",
            outcome.reason
        ));
    }
    // Judged by the rule of leaflets.json. True contact never accepts a
    // state with a crossing the start (after suturing) did not have
    // (`LeafletBarrier::admissible`), so a crossing here began at the
    // start: the barrier keeps leaflets from passing through each other but
    // cannot pull apart two that start through each other. Such a state is
    // no closed valve, whatever the residual.
    let (crossings, sewn_contacts) = leaflet_crossings(l, x);
    if cfg.contact == ContactKind::Leaflets && !crossings.is_empty() {
        let (at_start, _) = leaflet_crossings(l, &l.x);
        let kept = crossings
            .iter()
            .filter(|p| at_start.binary_search(p).is_ok())
            .count();
        let what = format!(
            "{} triangle pairs of different leaflets cross in the final state ({kept} of them crossed at the start, after suturing, where {} did)",
            crossings.len(),
            at_start.len()
        );
        if outcome.converged {
            outcome.converged = false;
            outcome.stopped_by = Stopped::LeafletsCross;
        }
        outcome.reason = format!("{what}; {}", outcome.reason);
    }
    Ok(Judged {
        outcome,
        span,
        crossings,
        sewn_contacts,
    })
}

/// [`close_on`], telling `watch` how each solve goes.
pub fn close_watched(
    l: &Leaflets,
    cfg: &CloseConfig,
    axis: Option<Axis>,
    wall: Option<&Wall>,
    sutured: Option<&Sutured>,
    watch: Option<&Watch>,
) -> Result<Closed, String> {
    let t0 = Instant::now();
    let n_leaflets = l.leaflet.iter().map(|&k| k as usize + 1).max().unwrap_or(0);
    let axis = checked_axis(l, axis)?;
    let (stop, nopt) = solver_settings(cfg);
    let suturing = match sutured {
        Some(s) => Some(s.clone()),
        None => sew(l, cfg, Some(axis), wall, watch)?,
    };
    if let Some(s) = suturing
        .as_ref()
        .filter(|s| s.status == suture::Status::Failed)
    {
        let signs = pressure_signs(l, &axis, n_leaflets);
        return Ok(unsewn(l, s, signs, t0.elapsed().as_secs_f64()));
    }
    // `time_limit` bounds the whole close: the closure gets what suturing
    // left of it (each had been given the whole limit, so a case could run
    // twice as long as asked), whether it sewed here or was given the sewing.
    let sew_s = suturing.as_ref().map_or(0.0, |s| s.seconds);
    let sewn_before = if sutured.is_some() { sew_s } else { 0.0 };
    let stop = Stop {
        max_seconds: (cfg.time_limit - sewn_before - t0.elapsed().as_secs_f64()).max(0.0),
        ..stop
    };
    let nopt = NewtonOptions {
        stop: stop.clone(),
        ..nopt
    };
    // From here on the leaflets are where suturing left them.
    let placed = l;
    let sewn;
    let l = match &suturing {
        Some(s) => {
            sewn = Leaflets {
                x: s.x.clone(),
                ..placed.clone()
            };
            &sewn
        }
        None => placed,
    };
    let ref_x: Vec<V3> = match (cfg.reference, &l.ref_uv) {
        (Reference::Sutured, _) => l.x.clone(),
        (Reference::Placed, _) => placed.x.clone(),
        (Reference::Flat, Some(uv)) => uv.iter().map(|p| V3::new(p[0], p[1], 0.0)).collect(),
        (Reference::Flat, None) => {
            return Err("reference = \"flat\" (the MSM's default) needs the leaflets' point data ref_uv, the flat template's coordinates that `coapt leaflets` writes; set reference = \"sutured\" to rest on the sutured state instead".into());
        }
    };
    let refs = reference_triangles(cfg.reference, cfg.thickness, l, &placed.x, &ref_x)?;
    let signs = pressure_signs(l, &axis, n_leaflets);
    let build = || {
        build_system(
            cfg,
            l,
            &axis,
            n_leaflets,
            wall,
            &ref_x,
            refs.clone(),
            &signs,
            watch,
        )
    };
    let (mut sys, mut wall_geo) = build()?;
    let setup_s = t0.elapsed().as_secs_f64() - (sew_s - sewn_before);
    let t1 = Instant::now();
    let mut x = l.x.clone();
    let load_n = cfg.pressure.abs() * sys.refs.iter().map(|r| r.area).sum::<f64>();
    let stop = Stop {
        step_residual_n: STEP_LOAD_FRACTION * load_n,
        ..stop
    };
    let nopt = NewtonOptions {
        stop: stop.clone(),
        ..nopt
    };
    // A pure membrane has no stiffness in its wrinkles, so its unprojected
    // tangent is what the projection is there for: on the peer case without
    // bending every unprojected phase stagnated (h 0.5–0.7 mm), and on
    // `bench stress-close --plausible` a first version that also ran it
    // without bending converged 28 of those cases instead of 31 (the ones
    // with bending: 41 both ways).
    let unprojected = cfg.bending;
    let outcome = match cfg.solver {
        SolverKind::Newton if cfg.reference_steps > 1 => walk_reference(
            cfg,
            l,
            &placed.x,
            &ref_x,
            &mut sys,
            &mut x,
            &stop,
            &nopt,
            unprojected,
            t1,
        )?,
        SolverKind::Newton => at_once_or_by_steps(
            &mut sys,
            &mut x,
            &mut wall_geo,
            &build,
            &stop,
            &nopt,
            unprojected,
            t1,
        )?,
        SolverKind::Relax => {
            // An explicit step costs about a hundredth of a Newton step, so
            // `max_iterations` counts hundreds of them here.
            let ropt = RelaxOptions {
                stop: Stop {
                    max_iterations: cfg.max_iterations.max(1000) * 100,
                    ..stop
                },
                ..RelaxOptions::default()
            };
            solve::relax(&mut sys, &mut x, &ropt)
        }
        SolverKind::Combined => {
            solve::combined(&mut sys, &mut x, &RelaxOptions::default(), &nopt, 10)
        }
    };
    let solve_s = t1.elapsed().as_secs_f64();
    let Judged {
        mut outcome,
        span,
        crossings,
        sewn_contacts,
    } = judge(outcome, cfg, l, &x, load_n, sew_s)?;
    // What the report calls touching: the contact term's own criterion at
    // the final state (gap < 0 for leaflets, d ≤ η₂ for planes).
    for t in sys.terms.iter_mut() {
        t.update(&x);
    }
    let mut contact = vec![0u8; x.len()];
    for m in sys.terms.iter().filter_map(|t| t.contact_mask(&x)) {
        for (c, b) in contact.iter_mut().zip(m) {
            *c |= b;
        }
    }
    let (area_stretch, max_stretch) = stretches(&x, &sys.refs, &sys.tris);
    let wall_contact = wall_geo.map(|g| g.summary(&x));
    if !outcome.converged {
        let load = cfg.pressure * 0.5 * span / (cfg.plane_strain_modulus() * cfg.thickness);
        let ref_area: Vec<f64> = sys.refs.iter().map(|r| r.area).collect();
        let why = failure_cause(&ref_area, &area_stretch, &max_stretch, load).or_else(|| {
            match outcome.stopped_by {
                Stopped::IterationLimit | Stopped::TimeLimit => {
                    super::stall::stall_cause(&outcome.history)
                }
                _ => None,
            }
        });
        if let Some(why) = why {
            outcome.reason = format!("{why}: {}", outcome.reason);
        }
    }
    Ok(Closed {
        x,
        outcome,
        contact,
        area_stretch,
        max_stretch,
        setup_s,
        solve_s,
        pressure_sign: signs,
        suturing,
        wall_contact,
        crossings,
        sewn_contacts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On the flat template the fibres are the template's own, whatever
    /// way the placed triangle lies: the placed fibre of a triangle turned
    /// into 3-D (θ = 0, along the template's u) comes back along u.
    #[test]
    fn flat_reference_fibres_are_the_templates() {
        let uv = [[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]];
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, -0.9, 1.3);
        let placed: Vec<V3> = uv
            .iter()
            .map(|p| rot * V3::new(p[0], p[1], 0.0) + V3::new(5.0, 1.0, 2.0))
            .collect();
        let along_u = rot * V3::x();
        let l = Leaflets {
            x: placed.clone(),
            tris: vec![[0, 1, 2]],
            boundary: vec![0; 3],
            leaflet: vec![0],
            ref_uv: Some(uv.to_vec()),
            fibers: Some(vec![[along_u, along_u]]),
            pressure_side: None,
        };
        let flat: Vec<V3> = uv.iter().map(|p| V3::new(p[0], p[1], 0.0)).collect();
        let r = &reference_triangles(Reference::Flat, 0.5, &l, &placed, &flat).unwrap()[0];
        assert!((r.fiber[0] - V3::x()).norm() < 1e-12, "{:?}", r.fiber[0]);
        assert!((r.area - 1.0).abs() < 1e-12);
        // Resting on the placed state, the placed fibre is the one.
        let r = &reference_triangles(Reference::Placed, 0.5, &l, &placed, &placed).unwrap()[0];
        assert!((r.fiber[0] - along_u).norm() < 1e-12);
    }

    #[test]
    fn a_failure_names_ballooning_or_a_collapse_and_nothing_else() {
        let a = [1.0, 1.0, 1.0];
        let fine = (vec![1.2, 0.9, 1.0], vec![1.3, 1.1, 1.05]);
        assert_eq!(failure_cause(&a, &fine.0, &fine.1, 0.3), None);
        // One tiny triangle stretched a hundredfold is not a balloon.
        let one = failure_cause(
            &[1.0, 1.0, 1e-4],
            &[1.1, 1.0, 400.0],
            &[1.1, 1.0, 100.0],
            0.3,
        );
        assert_eq!(one, None);
        let why = failure_cause(&[1.0, 3.0], &[1.0, 9.0], &[1.1, 3.2], 41.0).unwrap();
        assert!(why.starts_with("the leaflets balloon"), "{why}");
        assert!(
            why.contains("7.0-fold") && why.contains("3.2-fold") && why.contains("41.00"),
            "{why}"
        );
        let why = failure_cause(&a, &[1.0, 0.01, 0.5], &[1.1, 1.2, 1.0], 0.3).unwrap();
        assert!(why.starts_with("triangle 1 collapsed to 1.0 %"), "{why}");
    }

    /// The peer leaflet's St.V-K closure against planes, unsewn, with
    /// `extra` config lines.
    fn peer_svk(extra: &str) -> CloseConfig {
        crate::config::parse(&format!(
            "model = \"svk\"\nyoung = \"1 MPa\"\npoisson = 0\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"planes\"\n{extra}\n[suture]\nmode = \"off\"\n"
        ))
        .unwrap()
    }

    /// What stopped the solve is told as a value, not only in words: a
    /// cohort script (and the grid) branch on it.
    #[test]
    fn the_outcome_says_what_stopped_it() {
        let (l, axis) = crate::peer::leaflet(2.0).unwrap();
        let done = close(&l, &peer_svk(""), Some(axis)).unwrap().outcome;
        assert!(done.converged, "{}", done.reason);
        assert_eq!(done.stopped_by, Stopped::Converged);
        let few = close(&l, &peer_svk("max_iterations = 3"), Some(axis))
            .unwrap()
            .outcome;
        assert!(!few.converged);
        assert_eq!(few.stopped_by, Stopped::IterationLimit, "{}", few.reason);
        let late = close(&l, &peer_svk("time_limit = \"0.000001 s\""), Some(axis))
            .unwrap()
            .outcome;
        assert!(!late.converged);
        assert_eq!(late.stopped_by, Stopped::TimeLimit, "{}", late.reason);
        assert!(late.reason.contains("time limit"), "{}", late.reason);
        assert!(late.residual_n.is_finite(), "{}", late.residual_n);
    }

    /// The stage sews once for its two closures: a closure given that
    /// sewing ends where one that sews for itself does, to the bit, and the
    /// sewing's seconds count against `time_limit` as if it had run there.
    #[test]
    fn a_closure_given_the_sewing_is_the_one_that_sews() {
        let (l, axis) = crate::peer::leaflet(2.0).unwrap();
        let cfg = crate::config::parse(
            "model = \"svk\"\nyoung = \"1 MPa\"\npoisson = 0\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"planes\"\n",
        )
        .unwrap();
        let own = close_on(&l, &cfg, Some(axis), None, None).unwrap();
        let sewn = sew(&l, &cfg, Some(axis), None, None)
            .unwrap()
            .expect("suturing is on");
        let given = close_on(&l, &cfg, Some(axis), None, Some(&sewn)).unwrap();
        assert!(own.outcome.converged && given.outcome.converged);
        assert_eq!(own.x, given.x);
        assert_eq!(own.outcome.iterations, given.outcome.iterations);
        assert_eq!(own.suturing.as_ref().unwrap().x, sewn.x);
        let slow = suture::Sutured {
            seconds: cfg.time_limit + 1.0,
            ..sewn
        };
        let late = close_on(&l, &cfg, Some(axis), None, Some(&slow))
            .unwrap()
            .outcome;
        assert!(!late.converged);
        assert_eq!(late.stopped_by, Stopped::TimeLimit, "{}", late.reason);
        assert!(
            late.reason.starts_with("no time left to close"),
            "{}",
            late.reason
        );
    }

    /// A residual tolerance below round-off cannot be met; Newton then
    /// stalls, and its exact correction says how far the state is from the
    /// solution. The step criterion accepts it only when that is short, and
    /// the state it accepts is the one the residual criterion gives.
    #[test]
    fn a_stalled_newton_converges_by_its_step_to_the_same_state() {
        let (l, axis) = crate::peer::leaflet(2.0).unwrap();
        let reference = close(&l, &peer_svk(""), Some(axis)).unwrap();
        assert!(reference.outcome.converged);
        assert!(
            reference.outcome.reason.contains("N ≤"),
            "{}",
            reference.outcome.reason
        );
        let unreachable =
            "tolerance = \"1e-18 N\"\nrelative_tolerance = 1e-18\nmax_iterations = 300";
        let stalled = close(
            &l,
            &peer_svk(&format!("{unreachable}\nstep_tolerance = \"0 mm\"")),
            Some(axis),
        )
        .unwrap()
        .outcome;
        assert!(!stalled.converged, "{}", stalled.reason);
        let by_step = close(&l, &peer_svk(unreachable), Some(axis)).unwrap();
        let o = &by_step.outcome;
        assert!(o.converged, "{}", o.reason);
        assert_eq!(o.stopped_by, Stopped::Converged);
        assert!(o.reason.contains("step criterion"), "{}", o.reason);
        let last = o.history.last().unwrap();
        assert!(last.correction_mm <= 1e-4, "{}", last.correction_mm);
        let far = by_step
            .x
            .iter()
            .zip(&reference.x)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(far < 1e-4, "{far} mm from the residual-converged state");
    }
}
