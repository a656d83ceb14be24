//! Solvers for R(x) = 0 (R the nodal force): Newton on the total potential
//! (or on the residual when a load has no potential), the seeds' relaxation
//! (seed 001 Algorithm 3) and their combination (Algorithm 2).

mod combined;
mod continuation;
mod load_steps;
mod newton;
mod relax;

pub use combined::combined;
pub use continuation::{merge, newton_with_continuation, set_projected};
pub use load_steps::{Stepped, load_steps};
pub use newton::{
    Creep, MAX_STEP_GROWTH, NONMONOTONE, NewtonOptions, Plateau, newton, newton_reusing,
};
pub use relax::{RelaxOptions, relax};

use serde::Serialize;

/// When to stop.
#[derive(Debug, Clone, Serialize)]
pub struct Stop {
    /// Absolute tolerance on the Euclidean norm of the residual (N).
    pub abs_n: f64,
    /// Relative reduction of the residual norm.
    pub rel: f64,
    pub max_iterations: usize,
    pub max_seconds: f64,
    /// A stalled Newton counts as converged when its exact correction moves
    /// no node farther than this (mm; 0: never) and the residual is at most
    /// `step_residual_n` (N). See `newton.rs`, "converged by the step".
    pub step_mm: f64,
    pub step_residual_n: f64,
}

impl Default for Stop {
    fn default() -> Self {
        // The seeds' KINSOL setting: 1e-4 mN, or a 1e7 reduction.
        Stop {
            abs_n: 1e-7,
            rel: 1e-7,
            max_iterations: 200,
            max_seconds: 600.0,
            step_mm: 0.0,
            step_residual_n: 0.0,
        }
    }
}

/// One iteration of the history written to `closure.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Record {
    pub phase: &'static str,
    pub iteration: usize,
    /// ‖R‖₂ (N) before the step.
    pub residual_n: f64,
    /// Largest nodal force (N) before the step.
    pub max_force_n: f64,
    /// Newton: fraction of the Newton step taken (line-search α times a
    /// barrier's collision-free limit); relaxation: λ (mm/N).
    pub step: f64,
    /// Levenberg shift relative to the mean diagonal (Newton).
    pub shift: f64,
    /// Newton: the largest nodal move (mm) of the step as solved, before the
    /// cap, the barrier's limit and the line search (0 for relaxation).
    pub correction_mm: f64,
    pub contact_pairs: usize,
    /// Newton: how the step's linear system was solved: "cholesky"
    /// (symmetric tangent), "gmres" (non-symmetric, preconditioned with
    /// the symmetric part's Cholesky) or "lu" (GMRES's fallback); "" for
    /// relaxation.
    pub linear_solver: &'static str,
    /// GMRES iterations of the step.
    pub gmres_iterations: usize,
}

/// What stopped a solve, for programs (a cohort's scripts, the benchmarks)
/// to branch on; `Outcome::reason` says it in words with the numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stopped {
    /// Not stopped: no step was taken yet.
    NotStarted,
    Converged,
    /// A phase of a staged solve ended to let the next phase go on (its
    /// tangent made it creep; see `NewtonOptions::creep`).
    HandedOver,
    IterationLimit,
    TimeLimit,
    /// The line search refused `max_rejections` steps in a row.
    LineSearch,
    /// The tangent could not be factorised even with a large shift.
    Singular,
    /// A triangle inverted or collapsed.
    Inadmissible,
    /// The residual stopped being a finite number (relaxation).
    NonFinite,
    /// Suturing (seed 001 Algorithm 1) failed before the closure started.
    SuturingFailed,
    /// Reported converged, but the residual is large against the pressure
    /// load: the relative tolerance was met from an absurd start.
    NotAnEquilibrium,
    /// Nodes ran off to many times the leaflets' size.
    Diverged,
    /// Triangles of different leaflets cross in the final state (true
    /// contact; pairs where neighbours are sewn to one post excepted).
    LeafletsCross,
}

#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    pub converged: bool,
    pub stopped_by: Stopped,
    /// Why it stopped, in words.
    pub reason: String,
    pub iterations: usize,
    pub residual_n: f64,
    pub initial_residual_n: f64,
    pub seconds: f64,
    pub history: Vec<Record>,
}

impl Outcome {
    /// Nothing done yet.
    pub fn start() -> Outcome {
        Outcome {
            converged: false,
            stopped_by: Stopped::NotStarted,
            reason: String::new(),
            iterations: 0,
            residual_n: f64::NAN,
            initial_residual_n: f64::NAN,
            seconds: 0.0,
            history: Vec::new(),
        }
    }

    pub(crate) fn done(&self, r: f64, stop: &Stop) -> bool {
        r <= stop.abs_n || r <= stop.rel * self.initial_residual_n
    }
}

pub(crate) fn contact_pairs(sys: &super::system::System) -> usize {
    sys.terms
        .iter()
        .filter_map(|t| t.stats())
        .map(|s| s.1)
        .sum()
}
