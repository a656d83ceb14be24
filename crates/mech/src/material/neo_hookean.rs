//! Incompressible neo-Hookean membrane (nodal forces as seed 001 eq. 33;
//! seed 001 eq. 17–18 with k₁ = 0): W = μ/2 · s, s = I₁ + J⁻² − 3, per unit
//! reference volume; the element energy is A_P H W.

use super::invariants::{J_MIN, Kin, finite_eval};
use crate::element::{Eval, Membrane, RefTri, V3};

/// Incompressible neo-Hookean membrane.
#[derive(Debug, Clone, Copy)]
pub struct NeoHookean {
    /// Shear modulus μ (MPa); the seeds use μ = E/3.
    pub mu: f64,
}

impl Membrane for NeoHookean {
    fn name(&self) -> &'static str {
        "neo-hookean"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let k = Kin::new(r, q)?;
        if k.j < J_MIN {
            return None;
        }
        let (s, gs, hs) = k.s(r, want_hess);
        let c = r.area * r.thickness * 0.5 * self.mu;
        let energy = c * s;
        let grad = gs * c;
        let hess = hs.map(|h| h * c);
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
