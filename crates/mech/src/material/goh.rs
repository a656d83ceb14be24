//! Gasser–Ogden–Holzapfel membrane with fibre dispersion, incompressible
//! (seed 001 eq. 17–19; nodal forces as its eq. 33, with the consistent
//! tangent):
//!
//!   W = μ/2 · s + Σ_α ψ(I*_α),  s = I₁ + J⁻² − 3,
//!   I*_α = κ (s + 3) + (1 − 3κ) I₄α,  I₄α = |F M_α|²,
//!   ψ(I*) = k₁/(2k₂) (exp(k₂ (I* − 1)²) − 1) for I* > 1, else 0,
//!
//! per unit reference volume; the element energy is A_P H W. The fibre
//! families are `RefTri::fiber[α]`; a zero fibre vector means the family is
//! absent (it contributes nothing, not even its isotropic κ part). With
//! κ = 1/3 the fibre term becomes isotropic, ψ((s + 3)/3).
//!
//! **Exponent guard.** With k₂ = 1000, exp(k₂ (I* − 1)²) overflows f64 once
//! |I* − 1| > 0.84. Beyond the point x_c = √(X_MAX/k₂) (x = I* − 1,
//! X_MAX = [`GOH_EXP_MAX`] = 100) ψ is continued by its second-order Taylor
//! polynomial at x_c. The modified ψ is C² and energy, gradient and Hessian
//! stay exactly mutually consistent everywhere; it differs from the true
//! GOH law only where the fibre stress is already ≈ k₁ x e¹⁰⁰, far outside
//! any physical state, so the guard only keeps Newton iterates finite.
//! ψ'' jumps from 0 to k₁ at I* = 1 (as in the original model).

use super::invariants::{J_MIN, Kin, add_outer, finite_eval, hess_i4};
use crate::element::{Eval, Membrane, RefTri, V3};

/// Largest exponent k₂ (I* − 1)² evaluated exactly (see the module doc).
pub const GOH_EXP_MAX: f64 = 100.0;

/// GOH membrane (incompressible, two fibre families with dispersion κ).
#[derive(Debug, Clone, Copy)]
pub struct Goh {
    /// Matrix shear modulus μ (MPa); seeds: 0.9 or 3.0.
    pub mu: f64,
    /// Fibre stiffness k₁ (MPa); seeds: 1.1.
    pub k1: f64,
    /// Fibre exponent k₂ (dimensionless, ≥ 0); seeds: 1000.
    pub k2: f64,
    /// Dispersion κ ∈ [0, 1/3]; seeds: 0.2, 0.29, 1/3.
    pub kappa: f64,
}

impl Goh {
    /// ψ, ψ′, ψ″ at x = I* − 1 > 0 (with the exponent guard).
    pub fn psi(&self, x: f64) -> (f64, f64, f64) {
        let (k1, k2) = (self.k1, self.k2);
        if k2.is_nan() || k2 <= 0.0 {
            // k₂ → 0 limit: ψ = k₁ x²/2.
            return (0.5 * k1 * x * x, k1 * x, k1);
        }
        let exact = |x: f64| {
            let xx = k2 * x * x;
            let e = xx.exp();
            (
                0.5 * k1 / k2 * xx.exp_m1(),
                k1 * x * e,
                k1 * (1.0 + 2.0 * xx) * e,
            )
        };
        let xc = (GOH_EXP_MAX / k2).sqrt();
        if x <= xc {
            exact(x)
        } else {
            let (p, d1, d2) = exact(xc);
            let t = x - xc;
            (p + d1 * t + 0.5 * d2 * t * t, d1 + d2 * t, d2)
        }
    }
}

impl Membrane for Goh {
    fn name(&self) -> &'static str {
        "goh"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let k = Kin::new(r, q)?;
        if k.j < J_MIN {
            return None;
        }
        let (s, gs, hs) = k.s(r, want_hess);
        let vol = r.area * r.thickness;
        let c = vol * 0.5 * self.mu;
        let mut energy = c * s;
        let mut grad = gs * c;
        let mut hess = hs.as_ref().map(|h| h * c);
        let (ka, kb) = (self.kappa, 1.0 - 3.0 * self.kappa);
        for a in 0..2 {
            let Some((i4, g4)) = k.i4(r, a) else { continue };
            let x = ka * (s + 3.0) + kb * i4 - 1.0;
            if x.is_nan() || x <= 0.0 {
                continue;
            }
            let (p, d1, d2) = self.psi(x);
            let gstar = gs * ka + g4 * kb;
            energy += vol * p;
            grad += gstar * (vol * d1);
            if let (Some(h), Some(hs)) = (hess.as_mut(), hs.as_ref()) {
                *h += (hs * ka + hess_i4(r, a) * kb) * (vol * d1);
                add_outer(h, vol * d2, &gstar, &gstar);
            }
        }
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
