//! Incompressible Gent membrane (nodal forces as seed 001 eq. 33; seed 000):
//! W = −(μ J_m / 2) ln(1 − s/J_m), s = I₁ + J⁻² − 3, per unit reference
//! volume; the element energy is A_P H W.
//! W_s = (μ/2)/(1 − s/J_m), W_ss = (μ/2)/(J_m (1 − s/J_m)²);
//! Hessian A_P H (W_ss g_s g_sᵀ + W_s H_s). States with s ≥ J_m (beyond
//! lock-up) are inadmissible: `eval` returns `None` and the solver must
//! shorten its step.

use super::invariants::{J_MIN, Kin, add_outer, finite_eval};
use crate::element::{Eval, Membrane, RefTri, V3};

/// Incompressible Gent membrane.
#[derive(Debug, Clone, Copy)]
pub struct Gent {
    /// Shear modulus μ (MPa); the seeds use μ = E/3.
    pub mu: f64,
    /// Lock-up parameter J_m (dimensionless, seeds: 2.3).
    pub jm: f64,
}

impl Membrane for Gent {
    fn name(&self) -> &'static str {
        "gent"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let k = Kin::new(r, q)?;
        if k.j < J_MIN {
            return None;
        }
        let (s, gs, hs) = k.s(r, want_hess);
        let x = 1.0 - s / self.jm;
        if x.is_nan() || x <= 0.0 {
            return None;
        }
        let vol = r.area * r.thickness;
        // ln_1p keeps the energy accurate for large J_m (Gent → neo-Hookean).
        let energy = -vol * 0.5 * self.mu * self.jm * (-s / self.jm).ln_1p();
        let ws = vol * 0.5 * self.mu / x;
        let wss = ws / (self.jm * x);
        let grad = gs * ws;
        let hess = hs.map(|h| {
            let mut h = h * ws;
            add_outer(&mut h, wss, &gs, &gs);
            h
        });
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
