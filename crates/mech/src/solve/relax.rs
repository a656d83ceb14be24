//! The seeds' relaxation (seed 001 Algorithm 3): x ← x + λ_i R(x) with an
//! adaptive λ that is cut when the step λ·R grows beyond r_bad times the
//! first one too often.

use std::time::Instant;

use serde::Serialize;

use super::{Outcome, Record, Stop, Stopped, contact_pairs};
use crate::element::V3;
use crate::system::{System, max_norm, norm};

#[derive(Debug, Clone, Serialize)]
pub struct RelaxOptions {
    pub stop: Stop,
    /// λ₀ in mm/N (the seeds' 1e-4 m/N = 0.1 mm/N for membranes).
    pub lambda0: f64,
    pub n_bad: usize,
    pub r_scl: f64,
    pub r_bad: f64,
    /// Refresh contact (broad phase) every this many iterations.
    pub update_every: usize,
    /// Keep one history record every this many iterations.
    pub record_every: usize,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        RelaxOptions {
            stop: Stop {
                max_iterations: 1000,
                ..Stop::default()
            },
            lambda0: 0.1,
            n_bad: 15,
            r_scl: 0.8,
            r_bad: 3.0,
            update_every: 10,
            record_every: 10,
        }
    }
}

pub fn relax(sys: &mut System, x: &mut Vec<V3>, opt: &RelaxOptions) -> Outcome {
    let t0 = Instant::now();
    let mut out = Outcome::start();
    let mut lambda = opt.lambda0;
    let mut n_bad = 0usize;
    let mut r0 = f64::NAN;
    loop {
        if out.iterations % opt.update_every.max(1) == 0 {
            for term in sys.terms.iter_mut() {
                term.update(x);
            }
        }
        let r = match sys.residual(x) {
            Ok(r) => r,
            Err(e) => {
                out.stopped_by = Stopped::Inadmissible;
                out.reason = format!(
                    "inadmissible state: triangle {} inverted or collapsed",
                    e.triangle
                );
                break;
            }
        };
        let rn = norm(&r);
        if out.iterations == 0 {
            out.initial_residual_n = rn;
            r0 = rn;
        }
        out.residual_n = rn;
        if !rn.is_finite() {
            out.stopped_by = Stopped::NonFinite;
            out.reason = "residual is not finite".into();
            break;
        }
        if out.done(rn, &opt.stop) {
            out.converged = true;
            out.stopped_by = Stopped::Converged;
            out.reason = format!("residual {:.3e} N reached the tolerance", rn);
            break;
        }
        if out.iterations >= opt.stop.max_iterations {
            out.stopped_by = Stopped::IterationLimit;
            out.reason = format!(
                "iteration limit {} reached at residual {:.3e} N",
                opt.stop.max_iterations, rn
            );
            break;
        }
        if t0.elapsed().as_secs_f64() > opt.stop.max_seconds {
            out.stopped_by = Stopped::TimeLimit;
            out.reason = format!(
                "time limit {:.1} s reached at residual {:.3e} N",
                opt.stop.max_seconds, rn
            );
            break;
        }
        let li = if lambda * rn > opt.r_bad * opt.lambda0 * r0 {
            n_bad += 1;
            opt.lambda0 * r0 / rn
        } else {
            lambda
        };
        if n_bad >= opt.n_bad {
            lambda *= opt.r_scl;
            n_bad = 0;
        }
        if out.iterations % opt.record_every.max(1) == 0 {
            out.history.push(Record {
                phase: "relax",
                iteration: out.iterations,
                residual_n: rn,
                max_force_n: max_norm(&r),
                step: li,
                shift: 0.0,
                correction_mm: 0.0,
                contact_pairs: contact_pairs(sys),
                linear_solver: "",
                gmres_iterations: 0,
            });
        }
        let mut xn = x.clone();
        for (v, f) in xn.iter_mut().zip(&r) {
            *v += f * li;
        }
        // A step that inverts a triangle is refused: shrink λ instead.
        if sys.residual(&xn).is_err() {
            lambda *= 0.5;
            n_bad = 0;
            out.iterations += 1;
            continue;
        }
        *x = xn;
        out.iterations += 1;
    }
    out.seconds = t0.elapsed().as_secs_f64();
    out
}
