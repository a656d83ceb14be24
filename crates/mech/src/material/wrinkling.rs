//! Incompressible neo-Hookean membrane that carries no compression
//! (tension-field theory: Pipkin's relaxed energy).
//!
//! A pericardial leaflet sutured from a flat template is gathered along its
//! attachment and lies on a surface of smaller area than the template: a
//! membrane with compressive stiffness either buckles at the mesh scale or
//! pushes the excess into spurious folds, and Newton cycles among them. A
//! real sheet wrinkles instead, at no cost in energy. With principal
//! in-plane stretches λ₁ ≥ λ₂ (λ₁² = a, the larger eigenvalue of the
//! surface metric C) the relaxed energy per unit reference volume is
//!
//! * taut, λ₁² λ₂⁴ ≥ 1 (both principal stresses ≥ 0): the neo-Hookean
//!   W = μ/2 (λ₁² + λ₂² + λ₁⁻²λ₂⁻² − 3);
//! * wrinkled, λ₁ > 1 and λ₁² λ₂⁴ < 1 (λ₂ below the width a strip pulled
//!   along λ₁ would take, λ₁^(−1/2)): the uniaxial energy
//!   W = μ/2 (a + 2a^(−1/2) − 3), which depends on λ₁ alone;
//! * slack, λ₁ ≤ 1: W = 0.
//!
//! W is C¹ (the lateral stress of the neo-Hookean law vanishes where the
//! taut and wrinkled states meet, and W' vanishes at a = 1); the Hessian
//! jumps there, as the GOH fibre term's does at I* = 1.
//!
//! The wrinkled state's derivatives follow the principal direction n of C
//! (m ⊥ n, the other one, b = λ₂²): with c_i = (D_i·e₁, D_i·e₂) in an
//! orthonormal basis of the reference plane, p_i = c_i·n, u = F n, v = F m,
//!
//!   ∂a/∂Q_i = 2 p_i u,
//!   ∂²a/∂Q² = 2 (p pᵀ) ⊗ I₃ + 2/(a − b) w wᵀ,  w_i = (c_i·n) v + (c_i·m) u,
//!
//! both positive semi-definite, and W' ≥ 0 there, so the element tangent
//! needs no projection. a − b > a − a^(−1/2) ≈ 1.5 (a − 1) while
//! W' ≈ 0.75 μ (a − 1): the 1/(a − b) term stays bounded at the unstrained
//! corner.

use super::NeoHookean;
use super::invariants::{J_MIN, Kin, add_outer, finite_eval, set_block};
use crate::element::{Eval, Grad9, Hess9, Membrane, RefTri, V3};

/// Neo-Hookean membrane relaxed to carry no compression.
#[derive(Debug, Clone, Copy)]
pub struct WrinklingNeoHookean {
    /// Shear modulus μ (MPa).
    pub mu: f64,
    /// Fraction c ∈ [0, 1] of the neo-Hookean energy kept where the sheet
    /// is wrinkled or slack: W = W_rel + c (W_nh − W_rel). With c = 0 a slack
    /// triangle has no stiffness at all and a gathered sheet's triangles
    /// collapse (measured on the sample's flat-referenced leaflets); a small
    /// c keeps the mesh while the compressive stress stays c times the
    /// neo-Hookean one.
    pub residual: f64,
}

/// Which of the three tension-field states a triangle is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TensionState {
    /// Both principal stresses ≥ 0.
    Taut,
    /// Tension along one principal direction only.
    Wrinkled,
    /// No tension.
    Slack,
}

/// The surface metric C in an orthonormal basis (e₁, e₂) of the reference
/// plane, with the images f_a = F e_a and the basis coefficients of D_i.
struct Metric {
    c: [[f64; 2]; 2],
    f: [V3; 2],
    coef: [[f64; 2]; 3],
}

impl Metric {
    fn new(r: &RefTri, k: &Kin) -> Metric {
        // D₀ is never zero on a non-degenerate reference triangle.
        let e1 = r.d[0].normalize();
        let e2 = r.normal.cross(&e1);
        let f = [k.f * e1, k.f * e2];
        let coef = r.d.map(|d| [d.dot(&e1), d.dot(&e2)]);
        let c = [
            [f[0].dot(&f[0]), f[0].dot(&f[1])],
            [f[0].dot(&f[1]), f[1].dot(&f[1])],
        ];
        Metric { c, f, coef }
    }

    /// Eigenvalues a ≥ b of C.
    fn eigenvalues(&self) -> (f64, f64) {
        let [[c11, c12], [_, c22]] = self.c;
        let mean = 0.5 * (c11 + c22);
        let half = (0.25 * (c11 - c22).powi(2) + c12 * c12).sqrt();
        (mean + half, mean - half)
    }

    /// Unit eigenvector of C for its larger eigenvalue `a`.
    fn major_direction(&self, a: f64) -> [f64; 2] {
        let [[c11, c12], [_, c22]] = self.c;
        // (C − a I) n = 0: of the two rows' null vectors take the longer,
        // which is well conditioned whichever diagonal entry dominates.
        let v1 = [a - c22, c12];
        let v2 = [c12, a - c11];
        let n1 = v1[0].hypot(v1[1]);
        let n2 = v2[0].hypot(v2[1]);
        if n1 >= n2 && n1 > 0.0 {
            [v1[0] / n1, v1[1] / n1]
        } else if n2 > 0.0 {
            [v2[0] / n2, v2[1] / n2]
        } else {
            [1.0, 0.0]
        }
    }
}

fn state_of(a: f64, b: f64) -> TensionState {
    if a <= 1.0 {
        TensionState::Slack
    } else if a * b * b >= 1.0 {
        TensionState::Taut
    } else {
        TensionState::Wrinkled
    }
}

impl WrinklingNeoHookean {
    /// The tension-field state of the triangle at `q` (`None` when the
    /// triangle has collapsed).
    pub fn state(r: &RefTri, q: &[V3; 3]) -> Option<TensionState> {
        let k = Kin::new(r, q)?;
        let (a, b) = Metric::new(r, &k).eigenvalues();
        Some(state_of(a, b))
    }
}

impl Membrane for WrinklingNeoHookean {
    fn name(&self) -> &'static str {
        "neo-hookean, wrinkling"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let k = Kin::new(r, q)?;
        if k.j < J_MIN {
            return None;
        }
        let g = Metric::new(r, &k);
        let (a, b) = g.eigenvalues();
        let state = state_of(a, b);
        let full = NeoHookean { mu: self.mu };
        if state == TensionState::Taut {
            return full.eval(r, q, want_hess);
        }
        let relaxed = self.relaxed(r, &g, a, b, want_hess)?;
        if self.residual == 0.0 {
            return Some(relaxed);
        }
        let nh = full.eval(r, q, want_hess)?;
        let c = self.residual;
        let energy = relaxed.energy + c * (nh.energy - relaxed.energy);
        let grad = relaxed.grad + (nh.grad - relaxed.grad) * c;
        let hess = match (relaxed.hess, nh.hess) {
            (Some(hr), Some(hn)) => Some(hr + (hn - hr) * c),
            _ => None,
        };
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}

impl WrinklingNeoHookean {
    /// The relaxed energy of a wrinkled triangle (a slack one has none).
    fn relaxed(&self, r: &RefTri, g: &Metric, a: f64, b: f64, want_hess: bool) -> Option<Eval> {
        if state_of(a, b) == TensionState::Slack {
            return Some(Eval {
                energy: 0.0,
                grad: Grad9::zeros(),
                hess: want_hess.then(Hess9::zeros),
            });
        }
        let n = g.major_direction(a);
        let m = [-n[1], n[0]];
        let u = g.f[0] * n[0] + g.f[1] * n[1];
        let v = g.f[0] * m[0] + g.f[1] * m[1];
        let p = g.coef.map(|c| c[0] * n[0] + c[1] * n[1]);
        let pm = g.coef.map(|c| c[0] * m[0] + c[1] * m[1]);
        let mut ga = Grad9::zeros();
        for i in 0..3 {
            set_block(&mut ga, i, &(u * (2.0 * p[i])));
        }
        let vol = r.area * r.thickness;
        let half_mu = 0.5 * self.mu;
        let w = half_mu * (a + 2.0 / a.sqrt() - 3.0);
        let w1 = half_mu * (1.0 - a.powf(-1.5));
        let w2 = 0.75 * self.mu * a.powf(-2.5);
        let energy = vol * w;
        let grad = ga * (vol * w1);
        let hess = want_hess.then(|| {
            let mut h = Hess9::zeros();
            for i in 0..3 {
                for j in 0..3 {
                    let s = 2.0 * p[i] * p[j] * vol * w1;
                    for c in 0..3 {
                        h[(3 * i + c, 3 * j + c)] += s;
                    }
                }
            }
            let mut wv = Grad9::zeros();
            for i in 0..3 {
                set_block(&mut wv, i, &(v * p[i] + u * pm[i]));
            }
            add_outer(&mut h, 2.0 * vol * w1 / (a - b), &wv, &wv);
            add_outer(&mut h, vol * w2, &ga, &ga);
            h
        });
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
