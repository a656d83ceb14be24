//! The closure's solve: Newton alternating pseudo-transient continuation
//! on the projected tangent with Newton on the exact one (the follower
//! load has no potential), shared by the closure and the suturing rounds.

use super::{Creep, NewtonOptions, Outcome, Plateau, Stop, Stopped, newton};
use crate::element::V3;
use crate::system::{System, norm};

/// Steps the exact-tangent phase may take before continuation takes over
/// again (it needs 3–7 on the real CT and its copies, 13 on the sample).
const EXACT_NEWTON_ITERATIONS: usize = 30;

/// An exact-tangent phase whose residual is still above 90 % of its start
/// after this many steps goes back to continuation at once. One that
/// converges creeps first at most this long: the sample's stood at 86 % of
/// its start after 8 steps and 22 % after 12, and converged at 13. The peer
/// case at h 0.7 mm spent all 30 steps of its first exact phase going from
/// 8.99e-4 to 8.85e-4 N, and ran out of iterations one step into the
/// second, at 1.5e-6 N.
const EXACT_NEWTON_STAGNATION: usize = 12;

/// An exact-tangent phase goes back to continuation once this many of its
/// steps in a row were cut to 1/16 of Newton's or less, by the line search
/// or a barrier's collision-free limit (`solve::NewtonOptions::held_back`).
/// On the real CT's design sweep (sizes 17–29, h 0.5 mm) every exact phase
/// that converged took full steps, and every one that did not cut 9–27 of
/// its 12–30 steps while the residual crawled: size 27's second went from
/// 1.52e-3 to 1.33e-3 N in 30 steps (87 % of its start, so the stagnation
/// rule's 90 % never fired), and the closure ran out of its 300 iterations.
/// Handed back after five such steps it converges in 268. After four, one
/// plausible stress case (MSM with bending) lost an exact phase that
/// converges after a run of four.
const EXACT_NEWTON_HELD_BACK: usize = 5;

/// When continuation on the projected tangent hands over (issue 22, the
/// 5 s close). Projecting each element's Hessian onto its PSD part drops
/// the negative curvature of compressed and wrinkled triangles, so near
/// equilibrium its full steps converge only linearly: on the sample the
/// residual fell 0.63–0.94-fold per step from 8.4e-3 to 2.1e-3 N, and the
/// exact phase that followed needed 11 steps cut by the line search before
/// its quadratic ones (39 iterations). Two such steps in a row, below a
/// tenth of the start, hand over.
const CREEP: Creep = Creep {
    below: 0.1,
    ratio: 0.5,
    steps: 2,
};

/// The unprojected phase hands over to the exact one as soon as a full
/// step gains less than fourfold: without the follower load's tangent its
/// steps converge only linearly, at 0.3–0.4 per step on the real CT from
/// 2e-5 N, where the exact phase converges in one.
const UNPROJECTED_CREEP: Creep = Creep {
    below: 0.1,
    ratio: 0.25,
    steps: 1,
};

/// The unprojected phase also hands over once four full steps no longer
/// lower its residual by a tenth, wherever it stands: with the sample's
/// sutured reference nudged (the suture targets moved by 1–15°) it held at
/// 8.1–8.4e-4 N, 16 % of its start, for 20 steps, above the creep rule's
/// 10 % and below its own stagnation rule's 90 %.
const UNPROJECTED_PLATEAU: Plateau = Plateau {
    steps: 4,
    gain: 0.1,
};

/// The unprojected phase's first shift: it starts near equilibrium, where
/// the projected phase left its shift at 1e-12, but on a tangent that may
/// be indefinite (each failed factorisation raises the shift tenfold).
const UNPROJECTED_SHIFT: f64 = 1e-6;

/// An unprojected phase still above 90 % of its start after this many
/// steps gives up, and the exact phase starts where the projected one left
/// off. Its residual rises before it falls: on the sample it stood at 4.7
/// times its start after 3 steps and at 0.26 after 5. A pure membrane's
/// (the peer case without bending) stagnates at once.
const UNPROJECTED_STAGNATION: usize = 6;

/// The follower load has no potential (the free edge moves), so Newton
/// alternates phases until the residual meets `stop` or the iterations
/// run out: pseudo-transient continuation on the PSD part of the tangent
/// (robust from the unloaded, out-of-plane-floppy state, and where the exact
/// tangent is nearly singular) until the residual has dropped 100-fold;
/// with `unprojected`, a continuation that creeps first (see `CREEP`)
/// goes on with whole steps on the unprojected symmetric tangent; then
/// Newton with the exact, non-symmetric tangent (GMRES or LU), quadratic
/// near the end; when that stalls, continuation takes over again.
pub fn newton_with_continuation(
    sys: &mut System,
    x: &mut Vec<V3>,
    stop: &Stop,
    nopt: &NewtonOptions,
    unprojected: bool,
) -> Outcome {
    let mut all: Option<Outcome> = None;
    let mut notes = Vec::new();
    let mut stopped_by = None;
    // The time limit bounds the whole solve, not each phase of each round.
    let t0 = std::time::Instant::now();
    let seconds_left = || stop.max_seconds - t0.elapsed().as_secs_f64();
    for round in 1..=5 {
        let used = all.as_ref().map_or(0, |o| o.iterations);
        let left = stop.max_iterations.saturating_sub(used);
        if left == 0 {
            break;
        }
        if seconds_left() <= 0.0 {
            notes.push(format!("time limit {:.1} s reached", stop.max_seconds));
            stopped_by = Some(Stopped::TimeLimit);
            break;
        }
        let r0 = all.as_ref().map_or(f64::NAN, |o| o.initial_residual_n);
        let target = |o: &Outcome| {
            if r0.is_finite() {
                stop.rel * r0 / o.residual_n.max(1e-300)
            } else {
                stop.rel
            }
        };
        set_projected(sys, true);
        sys.pressure_tangent = false;
        let mut p1 = newton(
            sys,
            x,
            &NewtonOptions {
                ptc: true,
                stop: Stop {
                    rel: 1e-2,
                    max_iterations: left,
                    max_seconds: seconds_left().max(0.0),
                    ..stop.clone()
                },
                creep: unprojected.then_some(CREEP),
                ..nopt.clone()
            },
        );
        for r in p1.history.iter_mut() {
            r.phase = "continuation";
        }
        notes.push(format!("round {round}: continuation: {}", p1.reason));
        let handed_over = p1.stopped_by == Stopped::HandedOver;
        let mut merged = merge(all.take(), p1);
        merged.converged |= handed_over;
        // Reaching the absolute tolerance in continuation is convergence too.
        if merged.residual_n <= stop.abs_n
            || !merged.converged && merged.iterations >= stop.max_iterations
        {
            merged.reason = notes.join("; ");
            return merged;
        }
        if !merged.converged {
            merged.reason = notes.join("; ");
            return merged;
        }
        // Only a creeping continuation goes on unprojected: one that made
        // its 100-fold drop is in the exact phase's quadratic basin (the
        // peer case with bending: 2 exact steps from 7e-4 N, where whole
        // unprojected steps converge linearly and took 4).
        if handed_over {
            let (start, r_start) = (x.clone(), merged.residual_n);
            set_projected(sys, false);
            let mut pu = newton(
                sys,
                x,
                &NewtonOptions {
                    ptc: true,
                    initial_shift: UNPROJECTED_SHIFT,
                    stop: Stop {
                        rel: target(&merged),
                        max_iterations: stop
                            .max_iterations
                            .saturating_sub(merged.iterations)
                            .clamp(1, EXACT_NEWTON_ITERATIONS),
                        max_seconds: seconds_left().max(0.0),
                        ..stop.clone()
                    },
                    creep: Some(UNPROJECTED_CREEP),
                    plateau: Some(UNPROJECTED_PLATEAU),
                    stagnation: Some((UNPROJECTED_STAGNATION, 0.9)),
                    ..nopt.clone()
                },
            );
            for r in pu.history.iter_mut() {
                r.phase = "unprojected";
            }
            notes.push(format!("unprojected: {}", pu.reason));
            let ok = pu.converged || pu.stopped_by == Stopped::HandedOver;
            merged = merge(Some(merged), pu);
            merged.converged = true;
            if !ok {
                // Its steps stay on record; the exact phase starts where
                // the projected one left off.
                *x = start;
                merged.residual_n = r_start;
                notes.push("back to where continuation left off".into());
            }
            if merged.residual_n <= stop.abs_n {
                merged.reason = notes.join("; ");
                return merged;
            }
            if merged.iterations >= stop.max_iterations {
                merged.converged = false;
                merged.stopped_by = Stopped::IterationLimit;
                merged.reason = notes.join("; ");
                return merged;
            }
        }
        set_projected(sys, false);
        sys.pressure_tangent = true;
        let mut exact = nopt.clone();
        exact.stop.rel = target(&merged);
        // Newton from a 100-fold drop is quadratic within a few steps when
        // it is in its basin; one that wanders for dozens of steps (a pure
        // membrane's nearly singular tangent) goes back to continuation.
        exact.stop.max_iterations = stop
            .max_iterations
            .saturating_sub(merged.iterations)
            .clamp(1, EXACT_NEWTON_ITERATIONS);
        exact.stop.max_seconds = seconds_left().max(0.0);
        exact.stagnation = Some((EXACT_NEWTON_STAGNATION, 0.9));
        exact.held_back = Some((EXACT_NEWTON_HELD_BACK, 1.0 / 16.0));
        let p2 = newton(sys, x, &exact);
        notes.push(format!("Newton: {}", p2.reason));
        let conv = p2.converged;
        let mut m = merge(Some(merged), p2);
        m.converged = conv;
        m.reason = notes.join("; ");
        if conv {
            return m;
        }
        all = Some(m);
    }
    let mut o = all.unwrap_or_else(|| {
        // Stopped before its first step (no time left): still say where the
        // residual stands rather than leave it undefined.
        let mut o = Outcome::start();
        for term in sys.terms.iter_mut() {
            term.update(x);
        }
        if let Ok(r) = sys.residual(x) {
            o.residual_n = norm(&r);
            o.initial_residual_n = o.residual_n;
        }
        o
    });
    o.converged = false;
    o.stopped_by = stopped_by.unwrap_or(match o.stopped_by {
        // Five rounds, each ending in Newton's own iteration limit.
        Stopped::Converged | Stopped::NotStarted => Stopped::IterationLimit,
        other => other,
    });
    o.reason = notes.join("; ");
    o
}

/// Tell the system and its terms to assemble the projected (positive
/// semi-definite) tangent or the exact one.
pub fn set_projected(sys: &mut System, projected: bool) {
    sys.project = projected;
    for t in sys.terms.iter_mut() {
        t.set_projected(projected);
    }
}

/// Append a phase to the record of the whole solve.
pub fn merge(prev: Option<Outcome>, mut next: Outcome) -> Outcome {
    match prev {
        None => next,
        Some(mut p) => {
            p.history.append(&mut next.history);
            p.iterations += next.iterations;
            p.seconds += next.seconds;
            p.residual_n = next.residual_n;
            p.converged = next.converged;
            p.stopped_by = next.stopped_by;
            p
        }
    }
}
