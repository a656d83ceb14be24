//! Surface invariants of one triangle and their derivatives over the 9
//! current coordinates (seed 001 eq. 30–31; the 9×9 Hessians for Newton's
//! consistent tangent).
//!
//! * I₁ = ‖F‖²_F = Σ_ij G_ij Q_i·Q_j, ∂I₁/∂Q_i = 2 F D_i, H_I1 = 2 G ⊗ I₃.
//! * J = A_Q / A_P, ∂A_Q/∂Q_i = ½ n × (Q_k − Q_j) (i, j, k cyclic),
//!   H_A[i][l] = B_iᵀ (I − n nᵀ) B_l / A_Q + C_il with B_i = ½[Q_k − Q_j]_×,
//!   C_il = −½[n]_× for l = i+1, +½[n]_× for l = i−1, 0 for l = i.
//! * I₄ = |F M|² = |Σ m_i Q_i|², ∂I₄/∂Q_i = 2 m_i F M, H_I4 = 2 (m mᵀ) ⊗ I₃.
//! * s = I₁ + J⁻² − 3 (the incompressible 3-D I₁ minus 3):
//!   g_s = g_I1 − 2J⁻³ g_J, H_s = H_I1 − 2J⁻³ H_J + 6J⁻⁴ g_J g_Jᵀ.
//!
//! Everything is fixed-size and allocation-free.

use crate::element::{Grad9, Hess9, RefTri, V3};
use nalgebra::Matrix3;

/// Current triangles with A_Q ≤ this × A_P count as collapsed.
pub const COLLAPSE_RATIO: f64 = 1e-14;
/// J-based models reject states with J below this.
pub const J_MIN: f64 = 1e-6;

/// Per-evaluation kinematics of one triangle.
#[derive(Debug, Clone)]
pub struct Kin {
    /// F = Σ_i Q_i ⊗ D_i.
    pub f: Matrix3<f64>,
    /// Current area A_Q.
    pub area: f64,
    /// Unit current normal n_Q.
    pub normal: V3,
    /// J = A_Q / A_P.
    pub j: f64,
    /// I₁ = ‖F‖²_F.
    pub i1: f64,
    /// Current edges e_i = Q_k − Q_j (opposite vertex i, (i, j, k) cyclic).
    pub edge: [V3; 3],
}

/// Write a 3-vector into block `i` of a 9-vector.
#[inline]
pub fn set_block(g: &mut Grad9, i: usize, v: &V3) {
    g[3 * i] = v.x;
    g[3 * i + 1] = v.y;
    g[3 * i + 2] = v.z;
}

/// Add `m` to block (i, j) of a 9×9 matrix.
#[inline]
pub fn add_block(h: &mut Hess9, i: usize, j: usize, m: &Matrix3<f64>) {
    for a in 0..3 {
        for b in 0..3 {
            h[(3 * i + a, 3 * j + b)] += m[(a, b)];
        }
    }
}

/// h += c · a bᵀ (a = b gives a symmetric rank-one update).
#[inline]
pub fn add_outer(h: &mut Hess9, c: f64, a: &Grad9, b: &Grad9) {
    for col in 0..9 {
        let cb = c * b[col];
        for row in 0..9 {
            h[(row, col)] += a[row] * cb;
        }
    }
}

/// Cross-product matrix [v]_× (so [v]_× x = v × x).
#[inline]
pub fn skew(v: &V3) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// All of `e` finite.
#[inline]
pub fn finite_eval(energy: f64, g: &Grad9, h: Option<&Hess9>) -> bool {
    energy.is_finite()
        && g.iter().all(|x| x.is_finite())
        && h.is_none_or(|h| h.iter().all(|x| x.is_finite()))
}

impl Kin {
    /// `None` when the current triangle is collapsed (A_Q ≤ 1e-14 A_P) or
    /// the input is not finite.
    pub fn new(r: &RefTri, q: &[V3; 3]) -> Option<Kin> {
        let f = q[0] * r.d[0].transpose() + q[1] * r.d[1].transpose() + q[2] * r.d[2].transpose();
        let cross = (q[1] - q[0]).cross(&(q[2] - q[0]));
        let twice = cross.norm();
        let area = 0.5 * twice;
        if !area.is_finite() || area <= COLLAPSE_RATIO * r.area {
            return None;
        }
        let normal = cross / twice;
        let i1 = f.norm_squared();
        let edge = [q[2] - q[1], q[0] - q[2], q[1] - q[0]];
        Some(Kin {
            f,
            area,
            normal,
            j: area / r.area,
            i1,
            edge,
        })
    }

    /// ∂I₁/∂Q.
    pub fn grad_i1(&self, r: &RefTri) -> Grad9 {
        let mut g = Grad9::zeros();
        for i in 0..3 {
            set_block(&mut g, i, &(self.f * r.d[i] * 2.0));
        }
        g
    }

    /// ∂J/∂Q.
    pub fn grad_j(&self, r: &RefTri) -> Grad9 {
        let mut g = Grad9::zeros();
        let c = 0.5 / r.area;
        for i in 0..3 {
            set_block(&mut g, i, &(self.normal.cross(&self.edge[i]) * c));
        }
        g
    }

    /// ∂²J/∂Q².
    pub fn hess_j(&self, r: &RefTri) -> Hess9 {
        let mut h = Hess9::zeros();
        let p = Matrix3::identity() - self.normal * self.normal.transpose();
        let b = self.edge.map(|e| skew(&e) * 0.5);
        let nx = skew(&self.normal) * (0.5 / r.area);
        let inv = 1.0 / (self.area * r.area);
        for i in 0..3 {
            let bp = b[i].transpose() * p * inv;
            for (l, bl) in b.iter().enumerate() {
                add_block(&mut h, i, l, &(bp * bl));
            }
            add_block(&mut h, i, (i + 1) % 3, &(-nx));
            add_block(&mut h, i, (i + 2) % 3, &nx);
        }
        h
    }

    /// s = I₁ + J⁻² − 3 with its gradient and (optionally) Hessian.
    pub fn s(&self, r: &RefTri, want_hess: bool) -> (f64, Grad9, Option<Hess9>) {
        let j = self.j;
        let j2 = 1.0 / (j * j);
        let s = self.i1 + j2 - 3.0;
        let gj = self.grad_j(r);
        let g = self.grad_i1(r) - gj * (2.0 * j2 / j);
        let h = want_hess.then(|| {
            let mut h = hess_i1(r) - self.hess_j(r) * (2.0 * j2 / j);
            add_outer(&mut h, 6.0 * j2 * j2, &gj, &gj);
            h
        });
        (s, g, h)
    }

    /// I₄ of fibre family `a` and its gradient; `None` when the family is
    /// absent (zero fibre vector).
    pub fn i4(&self, r: &RefTri, a: usize) -> Option<(f64, Grad9)> {
        if r.fiber[a].norm_squared() == 0.0 {
            return None;
        }
        let fm = self.f * r.fiber[a];
        let mut g = Grad9::zeros();
        for i in 0..3 {
            set_block(&mut g, i, &(fm * (2.0 * r.m[a][i])));
        }
        Some((fm.norm_squared(), g))
    }
}

/// H_I1 = 2 G ⊗ I₃ (constant).
pub fn hess_i1(r: &RefTri) -> Hess9 {
    let mut h = Hess9::zeros();
    for i in 0..3 {
        for j in 0..3 {
            let v = 2.0 * r.g[(i, j)];
            for a in 0..3 {
                h[(3 * i + a, 3 * j + a)] = v;
            }
        }
    }
    h
}

/// H_I4 = 2 (m mᵀ) ⊗ I₃ for fibre family `a` (constant).
pub fn hess_i4(r: &RefTri, a: usize) -> Hess9 {
    let mut h = Hess9::zeros();
    let m = &r.m[a];
    for i in 0..3 {
        for j in 0..3 {
            let v = 2.0 * m[i] * m[j];
            for c in 0..3 {
                h[(3 * i + c, 3 * j + c)] = v;
            }
        }
    }
    h
}
