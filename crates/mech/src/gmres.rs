//! Right-preconditioned GMRES (Saad & Schultz 1986; Saad, *Iterative
//! Methods for Sparse Linear Systems*, §9.3.2) without restarts.
//!
//! It solves the valve's non-symmetric Newton systems with the Cholesky
//! factor of their symmetric part as preconditioner: the follower pressure
//! and the suturing force are non-symmetric only on the free edge and the
//! first row, so the preconditioned operator is the identity plus a small,
//! low-rank part and a handful of iterations reach what an LU would give,
//! at a fraction of the LU's cost.

/// What a solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GmresOutcome {
    pub iterations: usize,
    /// ‖b − A x‖ / ‖b‖ as estimated by the Arnoldi recurrence.
    pub relative_residual: f64,
    pub converged: bool,
}

/// Solve A x = b. `apply` computes y = A v, `precondition` overwrites v
/// with M⁻¹ v. Stops when the residual estimate falls to `tol`·‖b‖ or after
/// `max_iterations`; x is the best iterate either way.
pub fn gmres(
    b: &[f64],
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&mut [f64]),
    tol: f64,
    max_iterations: usize,
) -> (Vec<f64>, GmresOutcome) {
    let n = b.len();
    let beta = dot(b, b).sqrt();
    let mut x = vec![0.0; n];
    if beta == 0.0 || !beta.is_finite() {
        let converged = beta == 0.0;
        return (
            x,
            GmresOutcome {
                iterations: 0,
                relative_residual: if converged { 0.0 } else { f64::NAN },
                converged,
            },
        );
    }
    let m = max_iterations.max(1);
    // Krylov basis V, preconditioned directions Z = M⁻¹V (kept, so the
    // solution needs no second pass through the preconditioner), the
    // Hessenberg matrix column by column, its Givens rotations, and the
    // rotated right-hand side g.
    let mut v: Vec<Vec<f64>> = vec![b.iter().map(|bi| bi / beta).collect()];
    let mut z: Vec<Vec<f64>> = Vec::with_capacity(m);
    let mut h: Vec<Vec<f64>> = Vec::with_capacity(m);
    let mut rot: Vec<(f64, f64)> = Vec::with_capacity(m);
    let mut g = vec![beta];
    let mut w = vec![0.0; n];
    let mut rel = 1.0;
    let mut k = 0;
    while k < m {
        let mut zk = v[k].clone();
        precondition(&mut zk);
        apply(&zk, &mut w);
        z.push(zk);
        // Modified Gram–Schmidt, twice: the suturing systems reach condition
        // numbers of 1e9, where one pass loses orthogonality.
        let mut col = vec![0.0; k + 2];
        for _ in 0..2 {
            for (i, vi) in v.iter().enumerate() {
                let c = dot(&w, vi);
                col[i] += c;
                axpy(-c, vi, &mut w);
            }
        }
        let norm_w = dot(&w, &w).sqrt();
        col[k + 1] = norm_w;
        for (i, &(c, s)) in rot.iter().enumerate() {
            let (a, b2) = (col[i], col[i + 1]);
            col[i] = c * a + s * b2;
            col[i + 1] = -s * a + c * b2;
        }
        let (a, b2) = (col[k], col[k + 1]);
        let r = a.hypot(b2);
        let (c, s) = if r == 0.0 {
            (1.0, 0.0)
        } else {
            (a / r, b2 / r)
        };
        col[k] = r;
        col[k + 1] = 0.0;
        rot.push((c, s));
        let gk = g[k];
        g[k] = c * gk;
        g.push(-s * gk);
        h.push(col);
        k += 1;
        rel = g[k].abs() / beta;
        if !rel.is_finite() || rel <= tol || norm_w == 0.0 {
            break;
        }
        v.push(w.iter().map(|wi| wi / norm_w).collect());
    }
    // Back substitution on the triangular Hessenberg part.
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let mut s = g[i];
        for j in i + 1..k {
            s -= h[j][i] * y[j];
        }
        y[i] = if h[i][i] != 0.0 { s / h[i][i] } else { 0.0 };
    }
    for (yi, zi) in y.iter().zip(&z) {
        axpy(*yi, zi, &mut x);
    }
    let converged = rel.is_finite() && rel <= tol && x.iter().all(|v| v.is_finite());
    (
        x,
        GmresOutcome {
            iterations: k,
            relative_residual: rel,
            converged,
        },
    )
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;
    use nalgebra::{DMatrix, DVector};

    fn random(n: usize, seed: u64) -> DMatrix<f64> {
        let mut rng = SplitMix64::new(seed);
        DMatrix::from_fn(n, n, |_, _| rng.range(-1.0, 1.0))
    }

    #[test]
    fn unpreconditioned_gmres_solves_a_general_system_in_n_steps() {
        let n = 12;
        let a = random(n, 1) + DMatrix::identity(n, n) * 4.0;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
        let (x, out) = gmres(
            &b,
            |v, y| y.copy_from_slice((&a * DVector::from_column_slice(v)).as_slice()),
            |_| {},
            1e-12,
            n,
        );
        assert!(out.converged, "{out:?}");
        let r = &a * DVector::from_vec(x) - DVector::from_vec(b.clone());
        assert!(r.norm() <= 1e-11 * DVector::from_vec(b).norm());
    }

    #[test]
    fn the_symmetric_part_as_preconditioner_needs_about_rank_of_the_skew_part_steps() {
        // A = S + N with S symmetric positive definite and N non-zero only
        // in a 2×2 block: (I + S⁻¹N) has at most 2 eigenvalues ≠ 1, so
        // GMRES is exact after 3 iterations.
        let n = 30;
        let m = random(n, 2);
        let s = &m * m.transpose() + DMatrix::identity(n, n);
        let mut a = s.clone();
        a[(3, 7)] += 0.9;
        a[(7, 3)] -= 0.4;
        let sym = (&a + a.transpose()) * 0.5;
        let chol = sym.clone().cholesky().unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let (x, out) = gmres(
            &b,
            |v, y| y.copy_from_slice((&a * DVector::from_column_slice(v)).as_slice()),
            |v| {
                let s = chol.solve(&DVector::from_column_slice(v));
                v.copy_from_slice(s.as_slice());
            },
            1e-12,
            n,
        );
        assert!(out.converged && out.iterations <= 3, "{out:?}");
        let want = a.clone().lu().solve(&DVector::from_vec(b)).unwrap();
        for i in 0..n {
            assert!((x[i] - want[i]).abs() < 1e-10 * want.amax());
        }
    }

    #[test]
    fn a_zero_right_hand_side_is_solved_by_zero_and_a_stall_is_not_called_converged() {
        let (x, out) = gmres(&[0.0; 4], |v, y| y.copy_from_slice(v), |_| {}, 1e-12, 4);
        assert!(out.converged && x == vec![0.0; 4]);
        // A rotation by 90°: the Krylov space of b is orthogonal to A b, so
        // one step makes no progress.
        let (_, out) = gmres(
            &[1.0, 0.0],
            |v, y| {
                y[0] = -v[1];
                y[1] = v[0];
            },
            |_| {},
            1e-12,
            1,
        );
        assert!(!out.converged && (out.relative_residual - 1.0).abs() < 1e-12);
    }
}
