//! Seed 001 Algorithm 2: rounds of relaxation followed by Newton until the
//! residual is below the tolerance or the rounds run out.

use std::time::Instant;

use super::{NewtonOptions, Outcome, RelaxOptions, Stopped, newton, relax};
use crate::element::V3;
use crate::system::System;

pub fn combined(
    sys: &mut System,
    x: &mut Vec<V3>,
    relax_opt: &RelaxOptions,
    newton_opt: &NewtonOptions,
    rounds: usize,
) -> Outcome {
    let t0 = Instant::now();
    let mut all = Outcome::start();
    // Newton's time limit bounds the whole solve: every phase gets what is
    // left of it, not the whole limit again.
    let limit = newton_opt.stop.max_seconds;
    let left = || limit - t0.elapsed().as_secs_f64();
    for round in 0..rounds.max(1) {
        if left() <= 0.0 {
            all.stopped_by = Stopped::TimeLimit;
            all.reason = format!("time limit {limit} s reached after {round} rounds");
            break;
        }
        let mut ropt = relax_opt.clone();
        ropt.stop.max_seconds = ropt.stop.max_seconds.min(left());
        let r = relax(sys, x, &ropt);
        if round == 0 {
            all.initial_residual_n = r.initial_residual_n;
        }
        all.iterations += r.iterations;
        all.history.extend(r.history);
        all.residual_n = r.residual_n;
        if r.converged {
            all.converged = true;
            all.stopped_by = r.stopped_by;
            all.reason = format!("relaxation round {}: {}", round + 1, r.reason);
            break;
        }
        // Newton is judged against the initial residual of the whole solve.
        let mut nopt = newton_opt.clone();
        nopt.stop.max_seconds = left().max(0.0);
        if all.initial_residual_n.is_finite() && r.residual_n > 0.0 {
            nopt.stop.rel = newton_opt.stop.rel * all.initial_residual_n / r.residual_n;
        }
        let n = newton(sys, x, &nopt);
        all.iterations += n.iterations;
        all.history.extend(n.history);
        all.residual_n = n.residual_n;
        all.stopped_by = n.stopped_by;
        all.reason = format!("round {}: Newton: {}", round + 1, n.reason);
        if n.converged {
            all.converged = true;
            break;
        }
    }
    all.seconds = t0.elapsed().as_secs_f64();
    all
}
