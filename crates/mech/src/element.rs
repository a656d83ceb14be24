//! What every membrane element shares: the reference (stress-free) triangle
//! and the energy / gradient / Hessian triple a material returns for it.
//!
//! Sign convention: `grad` is ∂U/∂x over the 9 coordinates (Q₁, Q₂, Q₃), so
//! the nodal force is −grad; `hess` is ∂²U/∂x² (symmetric).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

pub type V3 = Vector3<f64>;
pub type Grad9 = SVector<f64, 9>;
pub type Hess9 = SMatrix<f64, 9, 9>;

/// Reference triangle P₁P₂P₃ (seed 001 eq. 30–31). Built once; everything a
/// material needs that does not depend on the current position.
#[derive(Debug, Clone)]
pub struct RefTri {
    /// Reference area A_P (mm²).
    pub area: f64,
    /// Unit normal n_P.
    pub normal: V3,
    /// Barycentric gradients D_i = n_P × (P_k − P_j) / (2 A_P).
    pub d: [V3; 3],
    /// G_ij = D_i · D_j.
    pub g: Matrix3<f64>,
    /// Squared rest length of edge k (opposite vertex k).
    pub rest_len2: [f64; 3],
    /// cot of the rest angle at vertex k.
    pub cot: [f64; 3],
    /// Unit fibre directions M_α in the plane of the reference triangle
    /// (zero vectors when the material has no fibres).
    pub fiber: [V3; 2],
    /// m_i^α = D_i · M_α.
    pub m: [[f64; 3]; 2],
    /// Thickness H (mm).
    pub thickness: f64,
}

impl RefTri {
    /// `None` when the triangle is degenerate (area below 1e-14 of the
    /// squared longest edge) or the input is not finite.
    pub fn new(p: [V3; 3], thickness: f64, fibers: Option<[V3; 2]>) -> Option<RefTri> {
        let e = [p[2] - p[1], p[0] - p[2], p[1] - p[0]];
        let cross = (p[1] - p[0]).cross(&(p[2] - p[0]));
        let twice = cross.norm();
        let longest = e.iter().map(|v| v.norm_squared()).fold(0.0, f64::max);
        if !twice.is_finite() || !(twice > 1e-14 * longest) || !(thickness > 0.0) {
            return None;
        }
        let area = 0.5 * twice;
        let normal = cross / twice;
        let d = [0, 1, 2].map(|i| normal.cross(&e[i]) / twice);
        let mut g = Matrix3::zeros();
        for i in 0..3 {
            for j in 0..3 {
                g[(i, j)] = d[i].dot(&d[j]);
            }
        }
        let rest_len2 = e.map(|v| v.norm_squared());
        // Angle at vertex k lies between the edges (k+1 − k) and (k+2 − k).
        let cot = [0, 1, 2].map(|k| {
            let a = p[(k + 1) % 3] - p[k];
            let b = p[(k + 2) % 3] - p[k];
            a.dot(&b) / a.cross(&b).norm()
        });
        let mut fiber = [V3::zeros(); 2];
        let mut m = [[0.0; 3]; 2];
        if let Some(f) = fibers {
            for a in 0..2 {
                // Project onto the reference plane and normalise (one reading
                // of seed 001's "e_x are Cartesian vectors"; the leaflets stage
                // already pushes the template's fibres forward, the other).
                let t = f[a] - normal * normal.dot(&f[a]);
                let n = t.norm();
                if n > 1e-12 {
                    fiber[a] = t / n;
                    for i in 0..3 {
                        m[a][i] = d[i].dot(&fiber[a]);
                    }
                }
            }
        }
        Some(RefTri {
            area,
            normal,
            d,
            g,
            rest_len2,
            cot,
            fiber,
            m,
            thickness,
        })
    }
}

/// Energy (N·mm), gradient (N) and optional Hessian (N/mm) of one element.
#[derive(Debug, Clone)]
pub struct Eval {
    pub energy: f64,
    pub grad: Grad9,
    pub hess: Option<Hess9>,
}

/// A membrane material evaluated on one triangle.
pub trait Membrane: Send + Sync {
    /// Short name for logs and `closure.json` ("neo-hookean", …).
    fn name(&self) -> &'static str;
    /// Energy, gradient and (when `want_hess`) the consistent Hessian at the
    /// current positions `q`. `None` when the state is inadmissible (an
    /// inverted or collapsed triangle, Gent beyond lock-up): the solver then
    /// shortens its step.
    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval>;
}

/// Clamp the negative eigenvalues of a symmetric 9×9 element Hessian to
/// zero, so the assembled tangent stays positive semi-definite (projected
/// Newton).
pub fn project_psd(h: &Hess9) -> Hess9 {
    let sym = (h + h.transpose()) * 0.5;
    // Most elements of a loaded membrane are in tension and already PSD: a
    // 9×9 Cholesky of the barely shifted matrix proves that for a fraction
    // of the eigen-decomposition's cost. The shift (1e-12 of the mean
    // diagonal) only lets the rigid-motion zero eigenvalues through.
    let tr = sym.trace().abs() / 9.0;
    if tr > 0.0
        && (sym + Hess9::identity() * (1e-12 * tr))
            .cholesky()
            .is_some()
    {
        return sym;
    }
    let eig = sym.symmetric_eigen();
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return sym;
    }
    let mut out = Hess9::zeros();
    for k in 0..9 {
        let l = eig.eigenvalues[k];
        if l > 0.0 {
            let v = eig.eigenvectors.column(k);
            out += v * v.transpose() * l;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_triangle_invariants() {
        let p = [
            V3::new(0.3, -0.2, 1.0),
            V3::new(2.0, 0.1, 0.7),
            V3::new(0.5, 1.7, 1.3),
        ];
        let r = RefTri::new(p, 0.4, None).unwrap();
        // Σ D_i = 0, D_i ⊥ n, D_i · (P_j − P_i) = −1 for j ≠ i (barycentric gradients).
        assert!((r.d[0] + r.d[1] + r.d[2]).norm() < 1e-14);
        for i in 0..3 {
            assert!(r.d[i].dot(&r.normal).abs() < 1e-14);
            let j = (i + 1) % 3;
            assert!((r.d[i].dot(&(p[j] - p[i])) + 1.0).abs() < 1e-12);
        }
        // −G_ij = cot α_k / (2 A_P) for i ≠ j, k the third vertex.
        for k in 0..3 {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            assert!((-r.g[(i, j)] - r.cot[k] / (2.0 * r.area)).abs() < 1e-12);
        }
        assert!(RefTri::new([p[0], p[0], p[1]], 0.4, None).is_none());
    }

    #[test]
    fn projection_keeps_psd_part() {
        let mut h = Hess9::identity();
        h[(0, 0)] = -3.0;
        h[(4, 4)] = 2.0;
        let p = project_psd(&h);
        assert_eq!(p[(0, 0)], 0.0);
        assert!((p[(4, 4)] - 2.0).abs() < 1e-12);
        assert!(p.symmetric_eigen().eigenvalues.iter().all(|&l| l >= -1e-12));
    }
}
