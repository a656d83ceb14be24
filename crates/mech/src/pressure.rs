//! Pressure on the leaflets.
//!
//! * Follower load (seed 000: F_i = P ΣA⃗/3): each triangle pushes its three
//!   nodes by (P/3)·a, a = ½ (Q₂−Q₁)×(Q₃−Q₁) its current oriented area. Its
//!   derivative ∂f_i/∂Q_j = (P/6)[Q_{j+2} − Q_{j+1}]_× is not symmetric per
//!   element. On a surface whose boundary is fixed (a closed sphere with its
//!   rigid modes pinned, a membrane clamped all round) the assembled load is
//!   the gradient of P·V and the tangent is symmetric; on a leaflet, whose
//!   free edge moves, it is not (no potential exists), and Newton uses LU.
//! * Volume potential U = −P·V, V = Σ_T (1/6) a₁·(a₂×a₃) with a_i = Q_i − c:
//!   the conservative form, exact where the boundary is fixed, used for the
//!   energy line search in that case.

use super::element::{Grad9, Hess9, V3};

fn skew(v: &V3) -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Follower force on the three nodes of a triangle: `p` in MPa (signed: the
/// load pushes along +a for p > 0), result in N.
pub fn follower_force(q: &[V3; 3], p: f64) -> [V3; 3] {
    let a = (q[1] - q[0]).cross(&(q[2] - q[0])) * 0.5;
    let f = a * (p / 3.0);
    [f, f, f]
}

/// ∂f_i/∂Q_j of the follower force (9×9, the same row block for each i).
pub fn follower_jacobian(q: &[V3; 3], p: f64) -> Hess9 {
    let mut k = Hess9::zeros();
    for j in 0..3 {
        let b = skew(&(q[(j + 2) % 3] - q[(j + 1) % 3])) * (p / 6.0);
        for i in 0..3 {
            k.fixed_view_mut::<3, 3>(3 * i, 3 * j).copy_from(&b);
        }
    }
    k
}

/// Energy −p·V_T about `c`, its gradient and Hessian (conservative form).
pub fn volume_potential(
    q: &[V3; 3],
    c: &V3,
    p: f64,
    want_hess: bool,
) -> (f64, Grad9, Option<Hess9>) {
    let a = [q[0] - c, q[1] - c, q[2] - c];
    let k = -p / 6.0;
    let e = k * a[0].dot(&a[1].cross(&a[2]));
    let mut g = Grad9::zeros();
    for i in 0..3 {
        let v = a[(i + 1) % 3].cross(&a[(i + 2) % 3]) * k;
        g.fixed_rows_mut::<3>(3 * i).copy_from(&v);
    }
    let h = want_hess.then(|| {
        let mut h = Hess9::zeros();
        for i in 0..3 {
            let (j, l) = ((i + 1) % 3, (i + 2) % 3);
            // g_i = k a_j × a_l: ∂/∂a_j = −k[a_l]_×, ∂/∂a_l = k[a_j]_×.
            h.fixed_view_mut::<3, 3>(3 * i, 3 * j)
                .copy_from(&(skew(&a[l]) * -k));
            h.fixed_view_mut::<3, 3>(3 * i, 3 * l)
                .copy_from(&(skew(&a[j]) * k));
        }
        h
    });
    (e, g, h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;

    fn random_tri(r: &mut SplitMix64) -> [V3; 3] {
        [0, 1, 2].map(|_| V3::new(r.range(-2.0, 2.0), r.range(-2.0, 2.0), r.range(-2.0, 2.0)))
    }

    #[test]
    fn follower_jacobian_matches_finite_differences() {
        let mut r = SplitMix64::new(7);
        for _ in 0..20 {
            let q = random_tri(&mut r);
            let k = follower_jacobian(&q, 0.0107);
            let eps = 1e-6;
            for j in 0..9 {
                let (mut qp, mut qm) = (q, q);
                qp[j / 3][j % 3] += eps;
                qm[j / 3][j % 3] -= eps;
                let (fp, fm) = (follower_force(&qp, 0.0107), follower_force(&qm, 0.0107));
                for i in 0..9 {
                    let fd = (fp[i / 3][i % 3] - fm[i / 3][i % 3]) / (2.0 * eps);
                    assert!(
                        (fd - k[(i, j)]).abs() < 1e-9,
                        "{i} {j}: {fd} vs {}",
                        k[(i, j)]
                    );
                }
            }
        }
    }

    #[test]
    fn volume_potential_derivatives_and_closed_surface_agree_with_follower_load() {
        let mut r = SplitMix64::new(9);
        let c = V3::new(0.1, -0.3, 0.2);
        for _ in 0..20 {
            let q = random_tri(&mut r);
            let (_, g, h) = volume_potential(&q, &c, 0.02, true);
            let h = h.unwrap();
            assert!((h - h.transpose()).norm() < 1e-14);
            let eps = 1e-6;
            for j in 0..9 {
                let (mut qp, mut qm) = (q, q);
                qp[j / 3][j % 3] += eps;
                qm[j / 3][j % 3] -= eps;
                let (ep, gp, _) = volume_potential(&qp, &c, 0.02, false);
                let (em, gm, _) = volume_potential(&qm, &c, 0.02, false);
                assert!(((ep - em) / (2.0 * eps) - g[j]).abs() < 1e-8);
                for i in 0..9 {
                    assert!(((gp[i] - gm[i]) / (2.0 * eps) - h[(i, j)]).abs() < 1e-8);
                }
            }
        }
        // On a closed surface (a tetrahedron, outward faces) −∇(−P V) equals
        // the follower load node by node, whatever the origin.
        let v = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
            V3::new(0.2, 0.3, 1.0),
        ];
        let faces = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let (mut fa, mut fb) = ([V3::zeros(); 4], [V3::zeros(); 4]);
        for f in faces {
            let q = f.map(|i| v[i]);
            let ff = follower_force(&q, 0.5);
            let (_, g, _) = volume_potential(&q, &c, 0.5, false);
            for k in 0..3 {
                fa[f[k]] += ff[k];
                fb[f[k]] -= V3::new(g[3 * k], g[3 * k + 1], g[3 * k + 2]);
            }
        }
        for k in 0..4 {
            assert!((fa[k] - fb[k]).norm() < 1e-14, "{k}");
        }
    }
}
