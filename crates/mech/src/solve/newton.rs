//! Newton with a Levenberg shift, a step cap and a backtracking line search:
//! on the energy when every load has a potential (Cholesky of the projected
//! tangent), on ½‖R‖² otherwise (the exact, non-symmetric tangent, solved
//! by GMRES preconditioned with its symmetric part's Cholesky, LU as the
//! fallback: `Pattern::solve_nonsymmetric`).

use std::time::Instant;

use serde::Serialize;

use super::{Outcome, Record, Stop, Stopped, contact_pairs};
use crate::element::V3;
use crate::sparse::Pattern;
use crate::system::{System, max_norm, norm};

#[derive(Debug, Clone, Serialize)]
pub struct NewtonOptions {
    pub stop: Stop,
    /// Largest nodal displacement of the first step (mm). The cap doubles
    /// after each full capped step that is taken (up to
    /// [`MAX_STEP_GROWTH`] times this) and falls back after a step the line
    /// search had to shorten.
    pub max_step_mm: f64,
    /// Give up after this many consecutive rejected steps.
    pub max_rejections: usize,
    /// Pseudo-transient continuation for loads without a potential: solve
    /// (K⁺ + s·diag) d = R with the PSD part K⁺ of the tangent (Cholesky),
    /// take the step unless it triples the residual, and let the shift s
    /// (1/Δt) follow the residual ratio (switched evolution relaxation).
    pub ptc: bool,
    /// Non-symmetric steps try the previous step's factor first, solved
    /// inexactly (a tenth of the reduction the step must make, Eisenstat–
    /// Walker style): for a sequence of nearby, loosely solved systems
    /// (the suturing rounds).
    pub reuse_factor: bool,
    /// Non-symmetric steps are accepted against the largest ‖R‖ of the
    /// last this many iterates (1: monotone; see [`NONMONOTONE`]).
    pub nonmonotone: usize,
    /// (n, f): stop once n steps have left the residual above f times
    /// where it started (a phase that hands over when it stagnates).
    pub stagnation: Option<(usize, f64)>,
    /// Continuation only: hand over ([`Stopped::HandedOver`]) once its
    /// tangent, not the shift, limits it (see [`Creep`]).
    pub creep: Option<Creep>,
    /// Continuation only: hand over ([`Stopped::HandedOver`]) once full
    /// steps at the shift's floor no longer gain (see [`Plateau`]).
    pub plateau: Option<Plateau>,
    /// (n, f), Newton without continuation only: stop once n accepted
    /// steps in a row were cut to f of Newton's or less, by the line search
    /// or by a barrier's collision-free limit (a phase that hands back when
    /// its tangent no longer points anywhere useful), as
    /// [`Stopped::IterationLimit`].
    pub held_back: Option<(usize, f64)>,
    /// Continuation's first shift (relative to the diagonal). 1 from a
    /// state far from equilibrium; a phase that starts near one (after
    /// another phase) starts small, as the last phase ended.
    pub initial_shift: f64,
}

/// A continuation phase creeps when `steps` full steps in a row at the
/// shift's floor each lower the residual, but to no less than `ratio` times
/// where it was, once it is below `below` times its start: the step is then Newton's on
/// this phase's tangent, and its linear rate is that tangent's error, which
/// no shift can mend. (A step that raises the residual is the nonlinearity
/// continuation is there for: a pure membrane's residual bounces for dozens
/// of steps before it falls.)
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Creep {
    pub below: f64,
    pub ratio: f64,
    pub steps: usize,
}

/// A continuation phase is on a plateau when, over `steps` full steps in a
/// row at the shift's floor, the lowest residual stayed above `1 − gain`
/// times the residual those steps started from, at whatever level: the
/// steps bounce or crawl where [`Creep`], which asks each step to lower the
/// residual and the phase to be near its goal, does not fire; only below
/// the phase's start, so the state it hands over is a gain. (The sample
/// with a slightly different sutured reference: 20 unprojected steps at
/// 8.1–8.4e-4 N, 16 % of that phase's start, until its iteration limit.)
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Plateau {
    pub steps: usize,
    pub gain: f64,
}

/// The shift counted as at its floor for [`Creep`] and [`Plateau`] (continuation lowers
/// it to 1e-12).
const CREEP_SHIFT: f64 = 1e-9;

/// How far the step cap may grow over [`NewtonOptions::max_step_mm`]. A
/// closing leaflet moves 6 mm; at a fixed 0.5 mm cap, eight of the peer
/// case's 22 closure iterations were full capped steps.
pub const MAX_STEP_GROWTH: f64 = 4.0;

/// Continuation whose step the barrier cuts below this fraction and whose
/// residual still rises is heading into a contact it cannot resolve, so
/// the shift goes up (sixteenfold) instead of down: a shorter, more local
/// step. Without it the real CT under a 20° oblique affine spent its 300
/// iterations on steps cut to 0.5–4 % of Newton's while the residual
/// climbed from 1 to 25 N (shift at its floor, 1e-12); with it it converged
/// in 64.
pub const PTC_CUT: f64 = 0.1;

/// The suturing pre-stage's window for [`NewtonOptions::nonmonotone`]
/// (Grippo, Lampariello and Lucidi's nonmonotone line search, on ½‖R‖²).
/// Its first solve carries the placed template into the wall under 90 mmHg,
/// and the exact Newton step that leads on often raises ‖R‖ for a step
/// before it falls: monotone, the real CT resampled to 0.5 mm cut those
/// steps to slivers and stopped after 300 iterations at 0.12 N; against the
/// last four iterates it converged in 69. The closure keeps the monotone
/// search: with this window the flat-reference wrinkling membrane (sample,
/// h 1 mm) cycled at 8e-3 to 1.1e-2 N instead of converging.
pub const NONMONOTONE: usize = 4;

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            stop: Stop::default(),
            max_step_mm: 1.0,
            max_rejections: 12,
            ptc: false,
            reuse_factor: false,
            nonmonotone: 1,
            stagnation: None,
            held_back: None,
            creep: None,
            plateau: None,
            initial_shift: 1.0,
        }
    }
}

pub fn newton(sys: &mut System, x: &mut Vec<V3>, opt: &NewtonOptions) -> Outcome {
    newton_reusing(sys, x, opt, &mut None)
}

/// Backtracking from the full step `d` (halving to 1e-4): with an energy
/// `e0` (symmetric tangent) the Armijo condition on it along `slope`; with
/// `ptc`, any step that keeps ‖R‖ within three times `rn`, the shift then
/// falling fourfold (and by `inside`, how far the step stayed inside its
/// cap), or rising sixteenfold when a barrier cut the step below
/// [`PTC_CUT`] (`limit`) and ‖R‖ rose; else a decrease against the
/// nonmonotone reference `r_ref`. The accepted state and its α.
#[allow(clippy::too_many_arguments)]
fn line_search(
    sys: &System,
    x: &[V3],
    d: &[f64],
    e0: Option<f64>,
    slope: f64,
    rn: f64,
    r_ref: f64,
    ptc: bool,
    shift: &mut f64,
    inside: f64,
    limit: f64,
) -> (Option<Vec<V3>>, f64) {
    let mut alpha = 1.0;
    let mut accepted = None;
    while alpha > 1e-4 {
        let xn = sys.step(x, d, alpha);
        if !sys.terms.iter().all(|t| t.admissible(&xn)) {
            alpha *= 0.5;
            continue;
        }
        if let Some(e0) = e0 {
            if slope >= 0.0 {
                break;
            }
            if let Ok(Some(e)) = sys.energy(&xn) {
                if e <= e0 + 1e-4 * alpha * slope {
                    accepted = Some(xn);
                    break;
                }
            }
            // Near the solution the energy change drowns in round-off:
            // then a full step that lowers the residual is taken.
            if alpha == 1.0 && (e0.abs() * 1e-12 > -slope) {
                if let Ok(r1) = sys.residual(&xn) {
                    if norm(&r1) < rn {
                        accepted = Some(xn);
                        break;
                    }
                }
            }
        } else if let Ok(rn1) = sys.residual(&xn) {
            let m = norm(&rn1);
            if ptc {
                if m.is_finite() && m <= 3.0 * rn {
                    // Δt grows geometrically while steps are taken: the
                    // residual of a membrane rises before it falls, so
                    // following the residual ratio (SER) would stall.
                    // Fourfold per step: halving spent the first ten
                    // steps of a closure barely moving (residual 0.20 →
                    // 0.18 N on the sample). A step far inside the cap
                    // says the shift, not the cap, holds the leaflet
                    // back (the shift scales the step as 1/s): the
                    // shift falls by that ratio as well, which took the
                    // peer case's first steps from 0.006 mm to the cap
                    // in one step instead of five.
                    *shift = if limit < PTC_CUT && m > rn {
                        (shift.max(1e-8) * 16.0).min(1.0)
                    } else {
                        (*shift * 0.25 * inside).max(1e-12)
                    };
                    accepted = Some(xn);
                    break;
                }
            } else if m.is_finite() && m * m <= r_ref * r_ref * (1.0 - 1e-4 * alpha) {
                accepted = Some(xn);
                break;
            }
        }
        alpha *= 0.5;
    }
    (accepted, alpha)
}

/// What a Newton run carries from one iteration to the next: its shift and
/// step cap, and what its stop rules read.
struct Run {
    shift: f64,
    cap: f64,
    rejections: usize,
    /// The last step was cut short or refused: Newton is no longer in its
    /// quadratic regime, and a short correction may mean round-off, not a
    /// distant solution.
    stalled: bool,
    /// ‖R‖ of the last accepted iterates, newest last (nonmonotone
    /// acceptance of non-symmetric steps).
    recent: Vec<f64>,
    /// ‖R‖ before the last step, when that step was a full one at the
    /// shift's floor (for `creep` and `plateau`).
    full_from: Option<f64>,
    crept: usize,
    /// ‖R‖ at the iterates joined by the current run of full steps at the
    /// shift's floor (for `plateau`).
    floor_run: Vec<f64>,
    /// Accepted steps in a row cut short, by the line search or a barrier
    /// (for `held_back`).
    held: usize,
}

impl Run {
    fn new(opt: &NewtonOptions) -> Run {
        Run {
            shift: 0.0,
            cap: opt.max_step_mm,
            rejections: 0,
            stalled: false,
            recent: Vec::with_capacity(opt.nonmonotone.max(1)),
            full_from: None,
            crept: 0,
            floor_run: Vec::new(),
            held: 0,
        }
    }

    /// Why the run stops at residual `rn` before its next step, if it does
    /// (the rules in the order they are asked).
    fn stop(
        &mut self,
        out: &Outcome,
        rn: f64,
        opt: &NewtonOptions,
        t0: Instant,
    ) -> Option<(Stopped, String)> {
        if out.done(rn, &opt.stop) {
            return Some((
                Stopped::Converged,
                format!(
                    "residual {:.3e} N ≤ max({:.1e} N, {:.1e} × initial)",
                    rn, opt.stop.abs_n, opt.stop.rel
                ),
            ));
        }
        if out.iterations >= opt.stop.max_iterations {
            return Some((
                Stopped::IterationLimit,
                format!(
                    "iteration limit {} reached at residual {:.3e} N",
                    opt.stop.max_iterations, rn
                ),
            ));
        }
        if t0.elapsed().as_secs_f64() > opt.stop.max_seconds {
            return Some((
                Stopped::TimeLimit,
                format!(
                    "time limit {:.1} s reached at residual {:.3e} N",
                    opt.stop.max_seconds, rn
                ),
            ));
        }
        if let Some((n, keep)) = opt.stagnation {
            if out.iterations >= n && rn > keep * out.initial_residual_n {
                return Some((
                    Stopped::IterationLimit,
                    format!(
                        "stagnated: {} steps left the residual at {:.3e} N, {:.0} % of its start",
                        out.iterations,
                        rn,
                        100.0 * rn / out.initial_residual_n
                    ),
                ));
            }
        }
        if let Some((n, f)) = opt.held_back.filter(|&(n, _)| !opt.ptc && self.held >= n) {
            return Some((
                Stopped::IterationLimit,
                format!(
                    "held back: {n} steps in a row cut to {f} of Newton's or less, at residual {rn:.3e} N"
                ),
            ));
        }
        if let Some(c) = opt.creep {
            let creeping = self.full_from.is_some_and(|before| {
                rn <= c.below * out.initial_residual_n && rn > c.ratio * before && rn < before
            });
            self.crept = if creeping { self.crept + 1 } else { 0 };
            if self.crept >= c.steps {
                return Some((
                    Stopped::HandedOver,
                    format!(
                        "creeping: {} full steps lowered the residual only to {:.3e} N ({:.0} % of the step before)",
                        self.crept,
                        rn,
                        100.0 * rn / self.full_from.unwrap_or(rn)
                    ),
                ));
            }
        }
        if let Some(p) = opt.plateau {
            return self.plateau(p, rn, out.initial_residual_n);
        }
        None
    }

    fn plateau(&mut self, p: Plateau, rn: f64, initial: f64) -> Option<(Stopped, String)> {
        let run = &mut self.floor_run;
        match self.full_from {
            Some(before) => {
                if run.is_empty() {
                    run.push(before);
                }
                run.push(rn);
                if run.len() > p.steps + 1 {
                    run.remove(0);
                }
            }
            None => run.clear(),
        }
        if run.len() <= p.steps {
            return None;
        }
        let from = run[run.len() - 1 - p.steps];
        let best = run[run.len() - p.steps..]
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        // Below the phase's start only (the state handed over is this
        // iterate): a plateau above it is the stagnation rule's (the phase
        // failed, its state is not kept).
        (best > (1.0 - p.gain) * from && rn < initial).then(|| {
            (
                Stopped::HandedOver,
                format!(
                    "plateau: {} full steps took the residual from {:.3e} N to no less than {:.3e} N",
                    p.steps, from, best
                ),
            )
        })
    }

    /// The reference the line search must lower ‖R‖ below: the largest of
    /// the last [`NewtonOptions::nonmonotone`] iterates', `rn` among them.
    fn reference(&mut self, rn: f64, opt: &NewtonOptions) -> f64 {
        if self.recent.len() >= opt.nonmonotone.max(1) {
            self.recent.remove(0);
        }
        self.recent.push(rn);
        self.recent.iter().copied().fold(rn, f64::max)
    }

    /// A step of `alpha` × `limit` of the (`capped`) correction was taken
    /// from residual `rn` at `shift`.
    fn accepted(
        &mut self,
        alpha: f64,
        limit: f64,
        capped: bool,
        shift: f64,
        rn: f64,
        opt: &NewtonOptions,
    ) {
        let cut = opt.held_back.is_some_and(|(_, f)| alpha * limit <= f);
        self.held = if cut { self.held + 1 } else { 0 };
        self.full_from =
            (opt.ptc && alpha == 1.0 && limit >= 1.0 && shift <= CREEP_SHIFT).then_some(rn);
        self.rejections = 0;
        self.stalled = alpha < 1.0 || limit < 1.0;
        if alpha == 1.0 && capped {
            self.cap = (2.0 * self.cap).min(MAX_STEP_GROWTH * opt.max_step_mm);
        } else if alpha < 1.0 {
            self.cap = (0.5 * self.cap).max(opt.max_step_mm);
        }
        if alpha == 1.0 && !opt.ptc {
            self.shift = if self.shift < 1e-6 {
                0.0
            } else {
                self.shift * 0.1
            };
        }
    }

    /// The line search found no step: shorter and more shifted next time.
    /// False once it has failed more than [`NewtonOptions::max_rejections`]
    /// times in a row.
    fn rejected(&mut self, opt: &NewtonOptions) -> bool {
        self.full_from = None;
        self.held = 0;
        self.rejections += 1;
        self.stalled = true;
        self.cap = (0.5 * self.cap).max(opt.max_step_mm);
        self.shift = if self.shift == 0.0 {
            1e-4
        } else {
            self.shift * 10.0
        };
        self.rejections <= opt.max_rejections
    }
}

/// How far a pattern kept for reuse may outgrow one built from the
/// couplings alone (in stored entries) before it is built anew.
///
/// Contact pairs come and go at every step (on the real CT 26 to 6800
/// pairs over a closure, a few hundred changing per step while it
/// settles; in the suturing rounds a few at the commissures), and each
/// new pattern cost its AMD ordering and symbolic analysis (15 ms of a
/// 100 ms Newton step) and new element slot tables (about 12 ms more
/// assembly). A pattern that
/// keeps the couplings it had, as explicit zeros, is reused while it
/// covers the new ones; the stale couplings it carries add a little fill
/// and are shed once they exceed this fraction.
const PATTERN_SLACK: f64 = 0.1;

/// Keep the sparsity pattern (and its symbolic factorisation) while it
/// couples every pair the system lists; else build it anew, as the union
/// of the new couplings and the old pattern's while that stays within
/// [`PATTERN_SLACK`] of the last pattern built from couplings alone.
fn refresh_pattern(sys: &System, pattern: &mut Option<Pattern>, last_pairs: &mut Vec<[u32; 2]>) {
    let pairs = sys.couplings();
    // Terms list their couplings in a fixed order, so an unchanged list
    // (fixed planes, bending, settled contact) needs no lookup.
    let rebuild = match &*pattern {
        None => true,
        Some(_) if pairs == *last_pairs => false,
        // A new solve on the same system (the next suturing round).
        Some(p) if pairs == p.listed => false,
        Some(p) => !p.covers(&pairs),
    };
    if rebuild {
        let n = sys.n_nodes();
        let kept = pattern.as_ref().and_then(|old| {
            let mut union = pairs.clone();
            union.extend(old.node_pairs());
            let mut p = Pattern::new(n, &sys.dofs, &union);
            p.listed = pairs.clone();
            p.base_nnz = old.base_nnz;
            (p.nnz() as f64 <= (1.0 + PATTERN_SLACK) * old.base_nnz as f64).then_some(p)
        });
        let mut p = kept.unwrap_or_else(|| Pattern::new(n, &sys.dofs, &pairs));
        // The counts are the solve's, whichever patterns it went through.
        if let Some(old) = pattern.as_ref() {
            p.stats = old.stats;
        }
        *pattern = Some(p);
    }
    *last_pairs = pairs;
}

/// Newton's correction for the packed residual `rhs`: the tangent
/// `vals` on `pat` solved by Cholesky (`symmetric`) or inexactly by GMRES,
/// the shift raised until the factorisation succeeds. Records which solver
/// answered; None when none did.
#[allow(clippy::too_many_arguments)]
fn correction(
    pat: &mut Pattern,
    vals: &[f64],
    rhs: &[f64],
    symmetric: bool,
    rn: f64,
    initial_residual_n: f64,
    opt: &NewtonOptions,
    shift: &mut f64,
    rec: &mut Record,
) -> Option<Vec<f64>> {
    let diag = pat.diagonal(vals);
    let mean_diag = diag.iter().map(|d| d.abs()).sum::<f64>() / diag.len().max(1) as f64;
    let before = pat.stats;
    let mut d = None;
    for _ in 0..20 {
        let mut v = vals.to_vec();
        if *shift > 0.0 {
            let s: Vec<f64> = diag
                .iter()
                .map(|&g| *shift * g.abs().max(mean_diag * 1e-3))
                .collect();
            pat.add_diagonal(&mut v, &s);
        }
        let mut b = rhs.to_vec();
        let ok = if symmetric {
            pat.solve_llt(&v, &mut b)
        } else {
            // Inexact Newton: the step's linear residual need only be a
            // tenth of what must remain after it (the residual then falls
            // as an exact step's would), never looser than 1 %.
            let goal = opt.stop.abs_n.max(opt.stop.rel * initial_residual_n);
            let forcing = (0.1 * goal / rn).min(1e-2);
            let reuse = opt.reuse_factor && *shift == 0.0;
            pat.solve_nonsymmetric_reusing(&v, &mut b, forcing, reuse)
        };
        if ok.is_ok() && b.iter().all(|z| z.is_finite()) {
            d = Some(b);
            break;
        }
        *shift = if *shift == 0.0 { 1e-6 } else { *shift * 10.0 };
    }
    rec.linear_solver = if symmetric {
        "cholesky"
    } else if pat.stats.lu_solves > before.lu_solves {
        "lu"
    } else if pat.stats.reused_factor > before.reused_factor {
        "gmres, earlier factor"
    } else {
        "gmres"
    };
    rec.gmres_iterations = pat.stats.gmres_iterations - before.gmres_iterations;
    d
}

/// [`newton`] keeping the sparsity pattern and its symbolic factorisation
/// in `pattern` across calls: a sequence of solves of one system (the
/// suturing rounds) analyses the pattern once instead of once per solve.
pub fn newton_reusing(
    sys: &mut System,
    x: &mut Vec<V3>,
    opt: &NewtonOptions,
    pattern: &mut Option<Pattern>,
) -> Outcome {
    let t0 = Instant::now();
    let mut out = Outcome::start();
    let mut last_pairs: Vec<[u32; 2]> = Vec::new();
    let mut run = Run::new(opt);
    loop {
        for term in sys.terms.iter_mut() {
            term.update(x);
        }
        let r = match sys.residual(x) {
            Ok(r) => r,
            Err(e) => {
                out.stopped_by = Stopped::Inadmissible;
                out.reason = format!(
                    "inadmissible state at the start: triangle {} inverted or collapsed",
                    e.triangle
                );
                break;
            }
        };
        let rn = norm(&r);
        if out.iterations == 0 {
            out.initial_residual_n = rn;
        }
        out.residual_n = rn;
        if let Some(w) = &sys.watch {
            w(rn);
        }
        if let Some((by, reason)) = run.stop(&out, rn, opt, t0) {
            out.converged = by == Stopped::Converged;
            out.stopped_by = by;
            out.reason = reason;
            break;
        }
        out.iterations += 1;
        let r_ref = run.reference(rn, opt);
        let mut rec = Record {
            phase: "newton",
            iteration: out.iterations,
            residual_n: rn,
            max_force_n: max_norm(&r),
            step: 0.0,
            shift: run.shift,
            correction_mm: 0.0,
            contact_pairs: contact_pairs(sys),
            linear_solver: "",
            gmres_iterations: 0,
        };
        refresh_pattern(sys, pattern, &mut last_pairs);
        let pat = pattern.as_mut().expect("built");
        let mut vals = vec![0.0; pat.nnz()];
        if let Err(e) = sys.tangent(x, pat, &mut vals) {
            out.stopped_by = Stopped::Inadmissible;
            out.reason = format!("inadmissible state: triangle {}", e.triangle);
            break;
        }
        let rhs = sys.pack(&r);
        let symmetric = opt.ptc || (sys.symmetric() && sys.terms.iter().all(|t| t.has_potential()));
        if opt.ptc && out.iterations == 1 {
            run.shift = opt.initial_shift;
        }
        let d = correction(
            pat,
            &vals,
            &rhs,
            symmetric,
            rn,
            out.initial_residual_n,
            opt,
            &mut run.shift,
            &mut rec,
        );
        let Some(mut d) = d else {
            out.stopped_by = Stopped::Singular;
            out.reason = format!(
                "tangent could not be factorised even with a shift of {:.1e}",
                run.shift
            );
            break;
        };
        rec.shift = run.shift;
        // Cap the largest nodal move.
        let dmax = sys
            .step(&vec![V3::zeros(); x.len()], &d, 1.0)
            .iter()
            .map(|v| v.norm())
            .fold(0.0, f64::max);
        rec.correction_mm = dmax;
        // Converged by the step. A node pressed hard into the barrier (on
        // the real CT, one leaflet's node held 0.011 N against another's
        // free edge) sits where a nanometre changes its force by a
        // micronewton: there exact Newton corrections of 4e-9 mm were cut by
        // the line search for 30 steps while the residual stayed at 1.6e-6 N,
        // 16 times the tolerance, and continuation then drove it up to
        // 2e-5 N. Like KINSOL's step tolerance and Abaqus's
        // displacement-correction check, a stalled Newton whose exact
        // correction moves no node farther than `step_mm` has converged to
        // that accuracy, provided the residual is also below
        // `step_residual_n` (a closure: 1e-4 of its pressure load). A
        // singular tangent gives long corrections, not short ones.
        if run.stalled
            && !opt.ptc
            && run.shift == 0.0
            && opt.stop.step_mm > 0.0
            && dmax <= opt.stop.step_mm
            && rn <= opt.stop.step_residual_n
        {
            out.converged = true;
            out.stopped_by = Stopped::Converged;
            out.reason = format!(
                "Newton's correction {:.1e} mm ≤ {:.1e} mm at residual {:.3e} N (the step criterion: the line search could no longer lower the residual)",
                dmax, opt.stop.step_mm, rn
            );
            out.history.push(rec);
            break;
        }
        let capped = dmax > run.cap;
        if capped {
            let s = run.cap / dmax;
            d.iter_mut().for_each(|z| *z *= s);
        }
        // A barrier allows only the part of the step that crosses nothing.
        let dx = sys.step(&vec![V3::zeros(); x.len()], &d, 1.0);
        let limit = sys
            .terms
            .iter()
            .map(|t| t.max_step(x, &dx))
            .fold(1.0, f64::min);
        if limit < 1.0 {
            d.iter_mut().for_each(|z| *z *= limit);
        }
        let slope = -rhs.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>();
        let e0 = if symmetric {
            sys.energy(x).ok().flatten()
        } else {
            None
        };
        let (accepted, alpha) = line_search(
            sys,
            x,
            &d,
            e0,
            slope,
            rn,
            r_ref,
            opt.ptc,
            &mut run.shift,
            (dmax / run.cap).min(1.0),
            limit,
        );
        match accepted {
            Some(xn) => {
                *x = xn;
                rec.step = alpha * limit;
                run.accepted(alpha, limit, capped, rec.shift, rn, opt);
            }
            None => {
                if !run.rejected(opt) {
                    out.history.push(rec);
                    out.stopped_by = Stopped::LineSearch;
                    out.reason = format!(
                        "line search failed {} times in a row at residual {:.3e} N (shift {:.1e})",
                        run.rejections, rn, run.shift
                    );
                    break;
                }
            }
        }
        out.history.push(rec);
    }
    out.seconds = t0.elapsed().as_secs_f64();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::RefTri;
    use crate::material::NeoHookean;
    use crate::sparse::Dofs;
    use crate::system::{PressureMode, Term};

    /// Couplings as a contact term would list them, set by the test.
    struct Listed(Vec<[u32; 2]>);

    impl Term for Listed {
        fn name(&self) -> &'static str {
            "listed"
        }
        fn energy(&self, _x: &[V3]) -> Option<f64> {
            Some(0.0)
        }
        fn add_force(&self, _x: &[V3], _f: &mut [V3]) {}
        fn couplings(&self, out: &mut Vec<[u32; 2]>) {
            out.extend_from_slice(&self.0);
        }
    }

    fn cylinder() -> System {
        let (x0, tris) = crate::shapes::cylinder(5.0, 3.0, 24, 5);
        let fixed: Vec<[bool; 3]> = x0.iter().map(|p| [p.z < -1.49; 3]).collect();
        System {
            refs: tris
                .iter()
                .map(|t| RefTri::new(t.map(|i| x0[i as usize]), 0.4, None).unwrap())
                .collect(),
            materials: vec![Box::new(NeoHookean { mu: 0.3 })],
            tri_material: vec![0; tris.len()],
            dofs: Dofs::new(&fixed),
            fixed,
            tri_pressure: vec![0.0; tris.len()],
            pressure_scale: 1.0,
            pressure_mode: PressureMode::Follower,
            tris,
            terms: vec![Box::new(Listed(vec![]))],
            project: false,
            pressure_tangent: false,
            watch: None,
        }
    }

    /// A contact coupling that comes and goes keeps its pattern; new ones
    /// join the old pattern's while that stays within the slack; past it,
    /// the pattern is the couplings' alone again.
    #[test]
    fn a_pattern_keeps_old_couplings_within_its_slack() {
        let mut sys = cylinder();
        let n = sys.n_nodes() as u32;
        let set = |sys: &mut System, pairs: Vec<[u32; 2]>| sys.terms[0] = Box::new(Listed(pairs));
        let (mut pattern, mut last) = (None, Vec::new());
        let far = [n - 1, n / 2];
        set(&mut sys, vec![far]);
        refresh_pattern(&sys, &mut pattern, &mut last);
        let base = pattern.as_ref().unwrap().nnz();
        assert_eq!(pattern.as_ref().unwrap().base_nnz, base);
        // Gone: the pattern stays, still coupling it.
        set(&mut sys, vec![]);
        refresh_pattern(&sys, &mut pattern, &mut last);
        let p = pattern.as_ref().unwrap();
        assert!(p.covers(&[far]) && p.nnz() == base);
        // A new one: both are coupled, measured against the first.
        let other = [n - 2, n / 3];
        set(&mut sys, vec![other]);
        refresh_pattern(&sys, &mut pattern, &mut last);
        let p = pattern.as_ref().unwrap();
        assert!(p.covers(&[far, other]) && p.nnz() > base);
        assert_eq!(p.base_nnz, base);
        // Many new ones, past the slack: the old ones are shed.
        let many: Vec<[u32; 2]> = (0..n / 2).map(|i| [i, n - 1 - i]).collect();
        set(&mut sys, many.clone());
        refresh_pattern(&sys, &mut pattern, &mut last);
        let p = pattern.as_ref().unwrap();
        let alone = Pattern::new(n as usize, &sys.dofs, &sys.couplings());
        assert!(p.covers(&many) && !p.covers(&[far, other]));
        assert_eq!((p.nnz(), p.base_nnz), (alone.nnz(), alone.nnz()));
        assert!(alone.nnz() as f64 > (1.0 + PATTERN_SLACK) * base as f64);
    }
}
