//! St Venant–Kirchhoff membrane as Delingette's biquadratic triangular
//! springs (seed 000's "TBS"; Delingette 2008).
//!
//! With Δ_k = ℓ_k² − L_k² (edge k opposite vertex k, current length ℓ, rest
//! length L), the *rest* angles α_k and the rest area A₀:
//!
//!   W_T = Σ_k (k_k/4) Δ_k² + Σ_k (c_k/2) Δ_i Δ_j = ½ Δᵀ M Δ,
//!   k_k = E H (2 cot²α_k + 1 − ν) / (16 A₀ (1 − ν²)),
//!   c_k = E H (2 cot α_i cot α_j + ν − 1) / (16 A₀ (1 − ν²)),
//!
//! (M_kk = k_k/2, M_ij = c_k/2 for k the third vertex). This is exactly
//! A₀ H (λ/2 (tr E)² + μ tr E²) with the plane-stress λ = Eν/(1−ν²) and
//! μ = E/(2(1+ν)) (tested). Gradient: ∂W/∂Q = Σ_e (MΔ)_e ∇Δ_e with
//! ∇Δ_e = ±2 (Q_j − Q_i) on the edge's two vertices; Hessian:
//! Σ_ab M_ab ∇Δ_a ∇Δ_bᵀ + Σ_e (MΔ)_e ∇²Δ_e, ∇²Δ_e = 2 [[I, −I], [−I, I]].
//! Rest angles are used throughout: recomputing them from the current
//! triangle (as the public `TRQS.c` does) is not Delingette's model.

use super::invariants::{COLLAPSE_RATIO, add_outer, finite_eval};
use crate::element::{Eval, Grad9, Hess9, Membrane, RefTri, V3};
use nalgebra::{Matrix3, Vector3};

/// St Venant–Kirchhoff membrane (plane stress) via Delingette's springs.
#[derive(Debug, Clone, Copy)]
pub struct StVenantKirchhoff {
    /// Young's modulus E (MPa).
    pub young: f64,
    /// Poisson's ratio ν (−1 < ν < 1; the seeds use 0.45).
    pub poisson: f64,
}

impl StVenantKirchhoff {
    /// The quadratic form M (W = ½ Δᵀ M Δ) of one reference triangle.
    pub fn spring_matrix(&self, r: &RefTri) -> Matrix3<f64> {
        let nu = self.poisson;
        let c0 = self.young * r.thickness / (16.0 * r.area * (1.0 - nu * nu));
        let ct = &r.cot;
        let mut m = Matrix3::zeros();
        for k in 0..3 {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            m[(k, k)] = 0.5 * c0 * (2.0 * ct[k] * ct[k] + 1.0 - nu);
            let c = 0.5 * c0 * (2.0 * ct[i] * ct[j] + nu - 1.0);
            m[(i, j)] = c;
            m[(j, i)] = c;
        }
        m
    }
}

impl Membrane for StVenantKirchhoff {
    fn name(&self) -> &'static str {
        "svk"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let area = 0.5 * (q[1] - q[0]).cross(&(q[2] - q[0])).norm();
        if !area.is_finite() || area <= COLLAPSE_RATIO * r.area {
            return None;
        }
        let m = self.spring_matrix(r);
        let edge = [q[2] - q[1], q[0] - q[2], q[1] - q[0]];
        let delta = Vector3::new(
            edge[0].norm_squared() - r.rest_len2[0],
            edge[1].norm_squared() - r.rest_len2[1],
            edge[2].norm_squared() - r.rest_len2[2],
        );
        let md = m * delta;
        let energy = 0.5 * delta.dot(&md);
        // ∇Δ_e: +2 e on vertex e+2, −2 e on vertex e+1 (e = Q_{e+2} − Q_{e+1}).
        let gd = [0, 1, 2].map(|e| {
            let mut g = Grad9::zeros();
            let (i, j) = ((e + 1) % 3, (e + 2) % 3);
            for c in 0..3 {
                g[3 * j + c] = 2.0 * edge[e][c];
                g[3 * i + c] = -2.0 * edge[e][c];
            }
            g
        });
        let grad = gd[0] * md[0] + gd[1] * md[1] + gd[2] * md[2];
        let hess = want_hess.then(|| {
            let mut h = Hess9::zeros();
            for a in 0..3 {
                for b in 0..3 {
                    add_outer(&mut h, m[(a, b)], &gd[a], &gd[b]);
                }
                let (i, j) = ((a + 1) % 3, (a + 2) % 3);
                let w = 2.0 * md[a];
                for c in 0..3 {
                    h[(3 * i + c, 3 * i + c)] += w;
                    h[(3 * j + c, 3 * j + c)] += w;
                    h[(3 * i + c, 3 * j + c)] -= w;
                    h[(3 * j + c, 3 * i + c)] -= w;
                }
            }
            h
        });
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
