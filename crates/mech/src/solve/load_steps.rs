//! Load steps: the pressure raised in steps, each solve starting from the
//! last equilibrium, for a closure that failed at its full load.
//!
//! `coapt bench stress-close --explain` closes failed cases from rest at
//! fractions of their pressure. Two of the plausible range's six failures
//! converge from rest up to 97 % (St.V-K, case 42) and 81 % (neo-Hookean
//! with bending, case 49) of their pressure along a path that is still
//! stiffening: an equilibrium exists, and the full load applied at once
//! starts the solver too far from it. Natural-parameter continuation in the
//! pressure starts each step next to the last equilibrium: case 42 then
//! converged; case 49 reaches 3/4 of its load and fails from there to
//! 0.81, where its path from rest ends too. Which wandering membrane the
//! steps rescue is as chaotic as the wandering: since the suturing rounds
//! stop at a tenth of their upset (the sutured state moved by about
//! 1e-7 mm), seed 1's case 42 ends at 0.94 of its load and seed 2's case
//! 81 (neo-Hookean, no bending) converges by steps instead. It runs only
//! after a failure, so a closure that converges is unchanged, bit for bit.
//!
//! The stepping itself is tested here on a problem that is not chaotic (a
//! clamped disc inflated by a follower pressure): the steps end on the
//! equilibrium the direct solve finds, and a load out of reach halves its
//! steps down to the smallest and says so. The closure's use of it is
//! pinned by one of the stress cases it rescues
//! (`a_closure_that_fails_at_once_converges_by_load_steps`), which a change
//! to the solver may have to move to another case.

use std::time::Instant;

use super::{NewtonOptions, Outcome, Stop, merge, newton_with_continuation};
use crate::element::V3;
use crate::system::System;

/// The first step's fraction of the load; a step that converges doubles
/// the next, one that fails halves it.
const FIRST: f64 = 0.5;

/// Steps smaller than this fraction of the load give up: the path has a
/// limit (or a fold) there.
const SMALLEST: f64 = 1.0 / 64.0;

/// A step may take at most this share of the budget, so that one failing
/// step cannot spend it all.
const STEP_SHARE: usize = 4;

/// What the load steps reached.
pub struct Stepped {
    /// The equilibrium at the full load, with its system, or `None`.
    pub done: Option<(Vec<V3>, System)>,
    /// Every step's solve, merged in order.
    pub outcome: Outcome,
    /// The steps tried, and the highest fraction of the load reached.
    pub note: String,
}

/// Raise the load from 0 to 1 in steps from `start`, each solved by
/// [`newton_with_continuation`] on a fresh system from `build` (terms keep
/// state from their last update, such as a hinge's branch or a barrier's
/// candidate lists, which a step begun again after a failed one must not
/// inherit). `stop` is the whole fallback's budget of iterations and
/// seconds.
pub fn load_steps(
    build: &mut dyn FnMut() -> Result<System, String>,
    start: &[V3],
    stop: &Stop,
    nopt: &NewtonOptions,
    unprojected: bool,
) -> Result<Stepped, String> {
    let t0 = Instant::now();
    let (mut at, mut reached, mut step) = (start.to_vec(), 0.0, FIRST);
    let mut all: Option<Outcome> = None;
    let mut used = 0;
    let mut tries = Vec::new();
    let done = loop {
        let seconds = stop.max_seconds - t0.elapsed().as_secs_f64();
        let iterations = stop.max_iterations.saturating_sub(used);
        if seconds <= 0.0 || iterations == 0 || step < SMALLEST {
            break None;
        }
        let s = (reached + step).min(1.0);
        let mut sys = build()?;
        sys.pressure_scale = s;
        let mut x = at.clone();
        let limit = Stop {
            max_seconds: seconds,
            max_iterations: iterations.min(stop.max_iterations.div_ceil(STEP_SHARE)),
            ..stop.clone()
        };
        let o = newton_with_continuation(&mut sys, &mut x, &limit, nopt, unprojected);
        used += o.iterations;
        tries.push(format!(
            "{s:.3} {} ({} its)",
            if o.converged { "converged" } else { "failed" },
            o.iterations
        ));
        let ok = o.converged;
        all = Some(merge(all, o));
        // The step taken, not the one asked for: the last is cut at 1.
        let taken = s - reached;
        if ok {
            if s >= 1.0 {
                sys.pressure_scale = 1.0;
                break Some((x, sys));
            }
            (at, reached, step) = (x, s, 2.0 * taken);
        } else {
            step = 0.5 * taken;
        }
    };
    let mut outcome = all.unwrap_or_else(Outcome::start);
    outcome.converged = done.is_some();
    let note = format!(
        "load steps (fraction of the pressure: {}): {}",
        tries.join(", "),
        if done.is_some() {
            "converged at the full load".to_string()
        } else {
            format!("reached {reached:.3} of the load")
        }
    );
    outcome.reason = note.clone();
    Ok(Stepped {
        done,
        outcome,
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::neo_hookean::NeoHookean;
    use crate::shapes;
    use crate::system::PressureMode;
    use crate::verify;

    /// A clamped neo-Hookean disc (radius 10 mm, 0.5 mm thick, μ 0.3 MPa)
    /// under a follower pressure `q` (MPa), and its start: a shallow dome,
    /// so the first tangent of the flat sheet is not singular. Smooth, and
    /// at Q below the load where a neo-Hookean membrane, softening as it
    /// inflates, has no equilibrium left (centre 6.4 mm up, of a 10 mm
    /// radius): nothing chaotic.
    fn disc(q: f64) -> (System, Vec<V3>) {
        let (x0, tris, rim) = shapes::disc(10.0, 1.0);
        let fixed: Vec<[bool; 3]> = rim.iter().map(|&r| [r; 3]).collect();
        let sys = verify::uniform_system(
            verify::refs(&x0, &tris, 0.5, None),
            &tris,
            Box::new(NeoHookean { mu: 0.3 }),
            fixed,
            q,
            PressureMode::Follower,
            false,
        );
        let start = x0
            .iter()
            .map(|p| V3::new(p.x, p.y, 0.2 * (1.0 - p.xy().norm_squared() / 100.0)))
            .collect();
        (sys, start)
    }

    const Q: f64 = 0.02;

    fn options(max_iterations: usize) -> NewtonOptions {
        NewtonOptions {
            stop: Stop {
                max_iterations,
                max_seconds: 60.0,
                ..Stop::default()
            },
            ..NewtonOptions::default()
        }
    }

    fn direct(scale: f64) -> (Vec<V3>, Outcome) {
        let (mut sys, mut x) = disc(Q);
        sys.pressure_scale = scale;
        let o = newton_with_continuation(&mut sys, &mut x, &options(200).stop, &options(200), true);
        (x, o)
    }

    /// Steps of half the load, each within a budget smaller than the whole
    /// load at once needs, end on the equilibrium the direct solve finds.
    #[test]
    fn steps_end_on_the_direct_solves_equilibrium_within_a_smaller_budget() {
        let (x_full, full) = direct(1.0);
        let (_, half) = direct(0.5);
        assert!(
            full.converged && half.converged,
            "{} / {}",
            full.reason,
            half.reason
        );
        // The premise: half the load from rest is cheaper than all of it.
        assert!(
            half.iterations < full.iterations,
            "{} vs {}",
            half.iterations,
            full.iterations
        );
        let per_step = full.iterations - 1;
        let opt = options(STEP_SHARE * per_step);
        let (_, start) = disc(Q);
        let stepped = load_steps(&mut || Ok(disc(Q).0), &start, &opt.stop, &opt, true).unwrap();
        let (x, sys) = stepped.done.expect(&stepped.note);
        assert_eq!(sys.pressure_scale, 1.0);
        assert!(stepped.outcome.converged);
        assert!(
            stepped
                .note
                .starts_with("load steps (fraction of the pressure: 0.500 converged"),
            "{}",
            stepped.note
        );
        assert!(stepped.note.contains("1.000 converged"), "{}", stepped.note);
        let apart = x
            .iter()
            .zip(&x_full)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(apart < 1e-6, "{apart} mm from the direct solve");
        // The dome is really inflated: the centre rose well past its start.
        assert!(x[0].z > 2.0, "{}", x[0].z);
    }

    /// With too little budget for any step, the steps halve down to the
    /// smallest and the result says how far they got, with finite numbers.
    #[test]
    fn a_load_out_of_reach_halves_its_steps_and_says_so() {
        let opt = options(4);
        let (_, start) = disc(Q);
        let stepped = load_steps(&mut || Ok(disc(Q).0), &start, &opt.stop, &opt, true).unwrap();
        assert!(stepped.done.is_none());
        assert!(!stepped.outcome.converged);
        assert!(stepped.outcome.residual_n.is_finite());
        assert_eq!(stepped.outcome.iterations, 4);
        assert_eq!(
            stepped.note,
            "load steps (fraction of the pressure: 0.500 failed (1 its), 0.250 failed (1 its), \
             0.125 failed (1 its), 0.062 failed (1 its)): reached 0.000 of the load"
        );
    }
}
