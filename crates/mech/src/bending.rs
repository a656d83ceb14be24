//! Bending of a thin leaflet as a sum over interior edges (hinges) of the
//! discrete-shell energy
//!
//! ```text
//! W = Σ_e k_e (θ_e − θ̄_e)²,   k_e = (D/2) · |ē|² / (Ā₁ + Ā₂),   D = E' t³/12
//! ```
//!
//! θ_e is the signed dihedral angle at edge e, θ̄_e and the weights are taken
//! in the stress-free reference (so the placed, curved leaflet has no
//! bending stress), E' the plane-strain modulus. With this weight a strip
//! rolled onto a cylinder stores D/2 ∫κ² dA (within 2 % on equilateral
//! meshes of any orientation, about 12 % more on jittered right-triangle
//! grids); a sphere stores 8/3 of that, so the hinges bend like a plate
//! with ν = 1/3 whatever the membrane's ν. That is accurate enough for what
//! the term is here for: giving folds a width that does not depend on h.
//!
//! Why a membrane model needs it: a leaflet is longer along its free edge
//! than the closed valve has room for, and a pure membrane can store that
//! slack in folds of any width, so the state it reaches follows the mesh
//! (folds one element wide). With t = 0.5 mm and E = 1 MPa at 80 mmHg the
//! bending length (D/P)^(1/3) is about 1 mm: the resolved meshes are at
//! that scale, and bending fixes the width of the folds independently of h.

use nalgebra::{Matrix3, SMatrix, SVector};
use rayon::prelude::*;

use super::element::V3;
use super::sparse::{Dofs, Pattern};
use super::system::Term;

pub type Grad12 = SVector<f64, 12>;
pub type Hess12 = SMatrix<f64, 12, 12>;
type M3 = Matrix3<f64>;

/// One interior edge: nodes [a, b, c, d] with a→b the edge as triangle
/// (a, b, c) runs it and d the opposite node of the other triangle.
#[derive(Debug, Clone, Copy)]
pub struct Hinge {
    pub nodes: [u32; 4],
    pub k: f64,
    pub rest: f64,
    /// θ − θ̄ at the last [`Term::update`], unwrapped: the branch the angle
    /// is read on until the next update (0 at the rest state).
    pub near: f64,
}

/// Signed dihedral angle of the hinge (0 flat, positive when the wing d
/// turns towards the normal of triangle (a, b, c)); `None` when a wing is
/// degenerate.
pub fn angle(p: &[V3; 4]) -> Option<f64> {
    let [a, b, c, d] = *p;
    let e = b - a;
    let n1 = e.cross(&(c - a));
    let n2 = (d - a).cross(&e);
    let l = e.norm();
    if !(n1.norm() > 0.0 && n2.norm() > 0.0 && l > 0.0) {
        return None;
    }
    Some(n1.cross(&n2).dot(&e).atan2(n1.dot(&n2) * l))
}

/// ∂θ/∂(a, b, c, d): each wing tip moves the angle by 1/height along its
/// wing's normal; the edge nodes take the reaction split by where the tips
/// project onto the edge (so rigid motions do not change θ).
pub fn angle_gradient(p: &[V3; 4]) -> Option<Grad12> {
    let [a, b, c, d] = *p;
    let e = b - a;
    let l2 = e.norm_squared();
    let n1 = e.cross(&(c - a));
    let n2 = (d - a).cross(&e);
    let (m1, m2) = (n1.norm_squared(), n2.norm_squared());
    if !(m1 > 0.0 && m2 > 0.0 && l2 > 0.0) {
        return None;
    }
    let l = l2.sqrt();
    let gc = n1 * (-l / m1);
    let gd = n2 * (-l / m2);
    let sc = (c - a).dot(&e) / l2;
    let sd = (d - a).dot(&e) / l2;
    let ga = -gc * (1.0 - sc) - gd * (1.0 - sd);
    let gb = -gc * sc - gd * sd;
    let mut g = Grad12::zeros();
    for (k, v) in [ga, gb, gc, gd].iter().enumerate() {
        g.fixed_rows_mut::<3>(3 * k).copy_from(v);
    }
    Some(g)
}

/// ∇²θ, exact. Differentiates the gradient above as written: the wing-tip
/// terms g_c = −l n₁/|n₁|², g_d = −l n₂/|n₂|² through l and the normals,
/// and the edge-node terms through the tips' projections s_c, s_d as well.
/// Done block-wise because every edge, wing and normal derivative is a
/// constant coefficient (−1, 0 or 1 per node) times one 3×3 matrix; about
/// the cost of two gradient evaluations instead of 24, and no step size.
/// `None` when a wing is degenerate.
pub fn angle_hessian(p: &[V3; 4]) -> Option<Hess12> {
    let [a, b, c, d] = *p;
    let e = b - a;
    let u = c - a;
    let w = d - a;
    let l2 = e.norm_squared();
    let n1 = e.cross(&u);
    let n2 = w.cross(&e);
    let (m1, m2) = (n1.norm_squared(), n2.norm_squared());
    if !(m1 > 0.0 && m2 > 0.0 && l2 > 0.0) {
        return None;
    }
    let l = l2.sqrt();
    let eh = e / l;
    let gc = n1 * (-l / m1);
    let gd = n2 * (-l / m2);
    let (ue, we) = (u.dot(&e), w.dot(&e));
    let sc = ue / l2;
    let sd = we / l2;
    // d(n/|n|²)/dn = (I − 2 n nᵀ/|n|²)/|n|².
    let f1 = (M3::identity() - n1 * n1.transpose() * (2.0 / m1)) / m1;
    let f2 = (M3::identity() - n2 * n2.transpose() * (2.0 / m2)) / m2;
    let (ex, ux, wx) = (e.cross_matrix(), u.cross_matrix(), w.cross_matrix());
    // dn₁ = −[u]× de + [e]× du,  dn₂ = [w]× de − [e]× dw,  dl = êᵀ de.
    let gc_e = n1 * eh.transpose() * (-1.0 / m1) + f1 * ux * l;
    let gc_u = f1 * ex * (-l);
    let gd_e = n2 * eh.transpose() * (-1.0 / m2) - f2 * wx * l;
    let gd_w = f2 * ex * l;
    let sc_e = u / l2 - e * (2.0 * ue / (l2 * l2));
    let sc_u = e / l2;
    let sd_e = w / l2 - e * (2.0 * we / (l2 * l2));
    let sd_w = e / l2;
    // de, du, dw per node a, b, c, d.
    const CE: [f64; 4] = [-1.0, 1.0, 0.0, 0.0];
    const CU: [f64; 4] = [-1.0, 0.0, 1.0, 0.0];
    const CW: [f64; 4] = [-1.0, 0.0, 0.0, 1.0];
    let mut h = Hess12::zeros();
    for k in 0..4 {
        let dgc = gc_e * CE[k] + gc_u * CU[k];
        let dgd = gd_e * CE[k] + gd_w * CW[k];
        let dsc = sc_e * CE[k] + sc_u * CU[k];
        let dsd = sd_e * CE[k] + sd_w * CW[k];
        let rows = [
            -dgc * (1.0 - sc) + gc * dsc.transpose() - dgd * (1.0 - sd) + gd * dsd.transpose(),
            -dgc * sc - gc * dsc.transpose() - dgd * sd - gd * dsd.transpose(),
            dgc,
            dgd,
        ];
        for (i, r) in rows.iter().enumerate() {
            h.fixed_view_mut::<3, 3>(3 * i, 3 * k).copy_from(r);
        }
    }
    // Symmetric in exact arithmetic; averaging removes the rounding skew so
    // the assembled tangent is symmetric to the last bit.
    Some((h + h.transpose()) * 0.5)
}

/// θ − θ̄ on the circle, in (−π, π].
fn wrap(v: f64) -> f64 {
    let t = std::f64::consts::TAU;
    v - t * ((v + std::f64::consts::PI) / t).ceil() + t
}

/// θ − θ̄ on the turn of the circle nearest `near`. A hinge folded past
/// flat (|θ − θ̄| through π) keeps its energy rising and its force pushing
/// it back, where read on the circle it jumped to the other side: the
/// residual then leapt from 0.067 to 0.35 N at any step however short
/// (stress case 26, an MSM with bending, held there for 1400 iterations).
fn unwrap_near(v: f64, near: f64) -> f64 {
    let d = wrap(v);
    let t = std::f64::consts::TAU;
    d + t * ((near - d) / t).round()
}

impl Hinge {
    /// Energy, gradient and (optionally) Hessian; `gauss_newton` keeps only
    /// 2k ∇θ∇θᵀ, which is positive semi-definite. `None` when a wing is
    /// degenerate.
    pub fn eval(&self, p: &[V3; 4], hess: bool, gauss_newton: bool) -> Option<HingeEval> {
        let th = angle(p)?;
        let g = angle_gradient(p)?;
        let dt = unwrap_near(th - self.rest, self.near);
        let energy = self.k * dt * dt;
        let grad = g * (2.0 * self.k * dt);
        let hess = if hess {
            let mut h = g * g.transpose() * (2.0 * self.k);
            if !gauss_newton && dt != 0.0 {
                h += angle_hessian(p)? * (2.0 * self.k * dt);
            }
            Some(h)
        } else {
            None
        };
        Some(HingeEval { energy, grad, hess })
    }
}

pub struct HingeEval {
    pub energy: f64,
    pub grad: Grad12,
    pub hess: Option<Hess12>,
}

/// Plane-strain bending stiffness D = E' t³/12 (N·mm) from E' (MPa) and t (mm).
pub fn stiffness(plane_strain_modulus: f64, thickness: f64) -> f64 {
    plane_strain_modulus * thickness.powi(3) / 12.0
}

/// The hinges of a triangle mesh, with weights and rest angles from the
/// reference positions `x_ref`. Edges shared by other than two consistently
/// oriented triangles are left out (no bending across them).
pub fn hinges(x_ref: &[V3], tris: &[[u32; 3]], d: f64) -> Vec<Hinge> {
    let mut edges: Vec<([u32; 2], u32, usize)> = Vec::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            edges.push(([a.min(b), a.max(b)], c, t));
        }
    }
    // Sorting by edge (then triangle) fixes the hinge order whatever the
    // input order of equal edges: assembly stays deterministic.
    edges.sort_unstable_by_key(|&(e, _, t)| (e, t));
    let area = |t: usize| {
        let [i, j, k] = tris[t].map(|v| x_ref[v as usize]);
        0.5 * (j - i).cross(&(k - i)).norm()
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (_, c, t1) = edges[i];
            let (_, dnode, t2) = edges[i + 1];
            // Orient a→b as triangle t1 runs it.
            let tri = tris[t1];
            let k = (0..3)
                .find(|&k| tri[k] != c && tri[(k + 1) % 3] != c)
                .unwrap();
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            // The other triangle must run it b→a (consistent orientation).
            let o = tris[t2];
            let consistent = (0..3).any(|m| o[m] == b && o[(m + 1) % 3] == a);
            let nodes = [a, b, c, dnode];
            let p = nodes.map(|v| x_ref[v as usize]);
            let total = area(t1) + area(t2);
            if consistent && total > 0.0 {
                if let Some(rest) = angle(&p) {
                    let l2 = (p[1] - p[0]).norm_squared();
                    out.push(Hinge {
                        nodes,
                        k: 0.5 * d * l2 / total,
                        rest,
                        near: 0.0,
                    });
                }
            }
        }
        i = j;
    }
    out
}

/// Bending as a model term. Between `update`s and for a fixed tangent mode
/// it is an exact potential.
pub struct Bending {
    pub hinges: Vec<Hinge>,
    /// Tangent from 2k ∇θ∇θᵀ only (positive semi-definite), for the
    /// continuation phase of the solver.
    pub gauss_newton: bool,
}

impl Bending {
    pub fn new(x_ref: &[V3], tris: &[[u32; 3]], d: f64) -> Bending {
        Bending::from_hinges(hinges(x_ref, tris, d))
    }

    pub fn from_hinges(hinges: Vec<Hinge>) -> Bending {
        Bending {
            hinges,
            gauss_newton: false,
        }
    }

    fn points(&self, h: &Hinge, x: &[V3]) -> [V3; 4] {
        h.nodes.map(|i| x[i as usize])
    }

    /// Energies and gradients of every hinge, evaluated in parallel and
    /// returned in hinge order (the caller sums in that order: the same
    /// result whatever the thread count).
    fn grads(&self, x: &[V3]) -> Vec<Option<(f64, Grad12)>> {
        self.hinges
            .par_iter()
            .with_min_len(512)
            .map(|h| {
                h.eval(&self.points(h, x), false, true)
                    .map(|e| (e.energy, e.grad))
            })
            .collect()
    }
}

/// The node pairs a four-node hinge stencil couples.
pub(super) fn couple(d: [u32; 4], out: &mut Vec<[u32; 2]>) {
    for a in 0..4 {
        for b in a + 1..4 {
            out.push([d[a], d[b]]);
        }
    }
}

/// Hinges whose Hessians are evaluated together before they are added in
/// order (bounds the buffer: 1 kB per hinge).
const TANGENT_CHUNK: usize = 2048;

impl Term for Bending {
    fn name(&self) -> &'static str {
        "bending"
    }

    fn update(&mut self, x: &[V3]) {
        let near: Vec<Option<f64>> = self
            .hinges
            .par_iter()
            .with_min_len(512)
            .map(|h| angle(&self.points(h, x)).map(|th| unwrap_near(th - h.rest, h.near)))
            .collect();
        for (h, n) in self.hinges.iter_mut().zip(near) {
            if let Some(n) = n {
                h.near = n;
            }
        }
    }

    fn energy(&self, x: &[V3]) -> Option<f64> {
        Some(self.grads(x).into_iter().flatten().map(|e| e.0).sum())
    }

    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        for (h, e) in self.hinges.iter().zip(self.grads(x)) {
            if let Some((_, grad)) = e {
                for (k, &n) in h.nodes.iter().enumerate() {
                    f[n as usize] -= grad.fixed_rows::<3>(3 * k).into_owned();
                }
            }
        }
    }

    fn couplings(&self, out: &mut Vec<[u32; 2]>) {
        for h in &self.hinges {
            couple(h.nodes, out);
        }
    }

    fn add_tangent(&self, x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        let nodes: Vec<[u32; 4]> = self.hinges.iter().map(|h| h.nodes).collect();
        let slots = pat.element_slots(dofs, &nodes);
        for (hs, ss) in self
            .hinges
            .chunks(TANGENT_CHUNK)
            .zip(slots.chunks(144 * TANGENT_CHUNK))
        {
            let blocks: Vec<Option<Hess12>> = hs
                .par_iter()
                .with_min_len(256)
                .map(|h| {
                    h.eval(&self.points(h, x), true, self.gauss_newton)
                        .and_then(|e| e.hess)
                })
                .collect();
            for (b, s) in blocks.iter().zip(ss.chunks_exact(144)) {
                if let Some(b) = b {
                    Pattern::add_block_at(vals, s, b);
                }
            }
        }
    }

    fn set_projected(&mut self, projected: bool) {
        self.gauss_newton = projected;
    }
}

/// A w × len rectangle as a structured grid of n × 3n/4 cells, diagonals
/// alternating, interior nodes jiggled by up to 0.2 of a cell (tests).
#[cfg(test)]
pub(crate) fn jiggled_grid(
    w: f64,
    len: f64,
    n: usize,
    r: &mut coapt_base::rng::SplitMix64,
) -> (Vec<(f64, f64)>, Vec<[u32; 3]>) {
    let (nx, ny) = (n, (n * 3) / 4);
    let mut uv = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (mut u, mut v) = (w * i as f64 / nx as f64, len * j as f64 / ny as f64);
            if i > 0 && i < nx && j > 0 && j < ny {
                u += r.range(-0.2, 0.2) * w / nx as f64;
                v += r.range(-0.2, 0.2) * len / ny as f64;
            }
            uv.push((u, v));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut tris = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            if (i + j) % 2 == 0 {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                tris.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                tris.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    (uv, tris)
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;
    use std::f64::consts::PI;

    fn random_hinge(r: &mut SplitMix64) -> [V3; 4] {
        let mut v = || V3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
        [v(), v(), v(), v()]
    }

    #[test]
    fn angle_gradient_and_hessian_match_finite_differences() {
        let mut r = SplitMix64::new(11);
        let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
        let mut n = 0;
        while n < 200 {
            let p = random_hinge(&mut r);
            let Some(th) = angle(&p) else { continue };
            // Stay away from the ±π branch cut of the FD stencil.
            if th.abs() > 2.8 {
                continue;
            }
            n += 1;
            let h = Hinge {
                nodes: [0, 1, 2, 3],
                k: r.range(0.1, 2.0),
                rest: r.range(-1.0, 1.0),
                near: 0.0,
            };
            let e = h.eval(&p, true, false).unwrap();
            let hs = e.hess.unwrap();
            let s = 1e-6;
            for j in 0..12 {
                let (mut pp, mut pm) = (p, p);
                pp[j / 3][j % 3] += s;
                pm[j / 3][j % 3] -= s;
                let (ep, em) = (
                    h.eval(&pp, false, false).unwrap(),
                    h.eval(&pm, false, false).unwrap(),
                );
                let fd = (ep.energy - em.energy) / (2.0 * s);
                worst_g = worst_g.max((fd - e.grad[j]).abs() / e.grad.norm().max(1e-9));
                let fdh = (ep.grad - em.grad) / (2.0 * s);
                worst_h = worst_h.max((fdh - hs.column(j)).norm() / hs.norm().max(1e-9));
            }
        }
        eprintln!("bending: FD gradient rel. error {worst_g:.2e}, Hessian {worst_h:.2e}");
        assert!(worst_g < 1e-6 && worst_h < 1e-6, "{worst_g} {worst_h}");
    }

    /// A hinge at dihedral angle ±`th` (0 flat), rigidly rotated, with edge
    /// length and tips jittered so the tips do not project onto the
    /// edge's midpoint.
    fn hinge_at(r: &mut SplitMix64, th: f64) -> [V3; 4] {
        let mut j = || r.range(-0.2, 0.2);
        let a = V3::new(j(), 0.0, 0.0);
        let b = V3::new(1.0 + j(), 0.0, 0.0);
        let c = V3::new(0.4 + j(), 1.0 + j(), 0.0);
        let (x, h) = (0.5 + j(), 0.8 + j());
        // The d wing turned by π − th out of the c wing's plane.
        let d = V3::new(x, -h * th.cos(), h * th.sin());
        let rot = nalgebra::Rotation3::from_euler_angles(j() * 5.0, j() * 5.0, j() * 5.0);
        [a, b, c, d].map(|v| rot * v)
    }

    /// The analytic ∇²θ against central differences of the analytic ∇θ, at
    /// random hinges and at near-flat and strongly bent ones (|θ| up to
    /// 3.1, where a fold is about to pass the ±π branch of the energy).
    #[test]
    // 3.14 below is a hinge angle just short of π, where the fold nears the
    // ±π branch, not an approximation of π itself.
    #[allow(clippy::approx_constant)]
    fn angle_hessian_matches_finite_differences_of_the_gradient() {
        let mut r = SplitMix64::new(23);
        let mut states: Vec<[V3; 4]> = Vec::new();
        while states.len() < 200 {
            let p = random_hinge(&mut r);
            if angle(&p).is_some() {
                states.push(p);
            }
        }
        for th in [
            0.0, 1e-8, -1e-6, 1e-3, 0.5, -1.5, 2.5, -3.0, 3.1, -3.1, 3.14,
        ] {
            for _ in 0..10 {
                let p = hinge_at(&mut r, th);
                assert!((angle(&p).unwrap().abs() - th.abs()).abs() < 1e-12, "{th}");
                states.push(p);
            }
        }
        let mut worst = 0.0f64;
        for p in &states {
            let h = angle_hessian(p).unwrap();
            let s = 1e-6;
            for j in 0..12 {
                let (mut pp, mut pm) = (*p, *p);
                pp[j / 3][j % 3] += s;
                pm[j / 3][j % 3] -= s;
                let fd = (angle_gradient(&pp).unwrap() - angle_gradient(&pm).unwrap()) / (2.0 * s);
                worst = worst.max((fd - h.column(j)).norm() / h.norm());
            }
            // Rigid translations leave θ unchanged: rows sum to zero per axis.
            for i in 0..12 {
                for ax in 0..3 {
                    let sum: f64 = (0..4).map(|k| h[(i, 3 * k + ax)]).sum();
                    assert!(sum.abs() <= 1e-10 * h.norm(), "{sum}");
                }
            }
        }
        eprintln!("bending: analytic ∇²θ vs FD of ∇θ, worst relative error {worst:.2e}");
        assert!(worst <= 1e-6, "{worst}");
    }

    #[test]
    fn rigid_motions_cost_nothing_and_the_sign_follows_the_wing() {
        let p = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.3, 1.0, 0.0),
            V3::new(0.6, -1.0, 0.0),
        ];
        assert!(angle(&p).unwrap().abs() < 1e-15);
        let mut q = p;
        q[3].z = 0.5;
        let up = angle(&q).unwrap();
        q[3].z = -0.5;
        assert!((angle(&q).unwrap() + up).abs() < 1e-14 && up.abs() > 0.1);
        // Rotating and translating the bent hinge keeps its angle.
        q[3].z = 0.5;
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, -1.1, 2.0);
        let moved = q.map(|v| rot * v + V3::new(3.0, -2.0, 1.0));
        assert!((angle(&moved).unwrap() - up).abs() < 1e-13);
        let g = angle_gradient(&q).unwrap();
        let sum: V3 = (0..4).map(|k| g.fixed_rows::<3>(3 * k).into_owned()).sum();
        assert!(sum.norm() < 1e-14);
        assert!(
            (wrap(3.0 * std::f64::consts::PI / 2.0) + std::f64::consts::PI / 2.0).abs() < 1e-15
        );
    }

    /// A flat strip rolled onto a cylinder of radius ρ stores about D/2 · A/ρ²
    /// whatever the mesh: the weight makes the hinge sum a consistent
    /// approximation of the continuum energy.
    #[test]
    fn cylinder_energy_is_mesh_consistent() {
        let (w, len, rho, d) = (4.0, 3.0, 5.0, 0.7);
        let exact = 0.5 * d * w * len / (rho * rho);
        let mut r = SplitMix64::new(5);
        let mut errs = Vec::new();
        for n in [8usize, 16, 32] {
            let (uv, tris) = jiggled_grid(w, len, n, &mut r);
            let flat: Vec<V3> = uv.iter().map(|&(u, v)| V3::new(u, v, 0.0)).collect();
            let rolled: Vec<V3> = uv
                .iter()
                .map(|&(u, v)| V3::new(rho * (u / rho).sin(), v, rho * (1.0 - (u / rho).cos())))
                .collect();
            let b = Bending::new(&flat, &tris, d);
            let e = b.energy(&rolled).unwrap();
            errs.push((e / exact - 1.0).abs());
        }
        eprintln!("bending: cylinder energy relative errors {errs:?}");
        assert!(errs.iter().all(|&e| e < 0.2), "{errs:?}");
    }

    #[test]
    fn a_hinge_folded_past_flat_keeps_pushing_back() {
        // The same hinge at π − 0.05 and π + 0.05 from flat (the second
        // reads −π + 0.05 on the circle).
        let at = |th: f64| hinge_at(&mut SplitMix64::new(11), th);
        let (p1, p2) = (at(PI - 0.05), at(PI + 0.05));
        let (a1, a2) = (angle(&p1).unwrap(), angle(&p2).unwrap());
        assert!((a1.abs() - (PI - 0.05)).abs() < 1e-9 && (a2.abs() - (PI - 0.05)).abs() < 1e-9);
        assert!(a1 * a2 < 0.0, "the circle reads the fold on the other side");
        let mut h = Hinge {
            nodes: [0, 1, 2, 3],
            k: 1.0,
            rest: 0.0,
            near: 0.0,
        };
        let wrapped = h.eval(&p2, false, false).unwrap().energy;
        // The update at p1 puts the hinge on p1's branch: at p2 it is 0.1
        // further round, so its energy is higher, not (π − 0.05)² again.
        h.near = unwrap_near(a1 - h.rest, 0.0);
        let e1 = h.eval(&p1, false, false).unwrap().energy;
        let e2 = h.eval(&p2, true, false).unwrap();
        assert!((e1 - (PI - 0.05).powi(2)).abs() < 1e-9, "{e1}");
        assert!(
            (e2.energy - (PI + 0.05).powi(2)).abs() < 1e-9,
            "{}",
            e2.energy
        );
        assert!((wrapped - (PI - 0.05).powi(2)).abs() < 1e-9, "{wrapped}");
        // Its force points back towards p1 (the way the fold came), and it
        // is the gradient of that energy: central differences on the branch.
        let back: Vec<f64> = (0..12)
            .map(|j| p1[j / 3][j % 3] - p2[j / 3][j % 3])
            .collect();
        let slope: f64 = (0..12).map(|j| e2.grad[j] * back[j]).sum();
        assert!(slope < 0.0, "energy falls towards p1: {slope}");
        let s = 1e-6;
        for j in 0..12 {
            let (mut pp, mut pm) = (p2, p2);
            pp[j / 3][j % 3] += s;
            pm[j / 3][j % 3] -= s;
            let fd = (h.eval(&pp, false, false).unwrap().energy
                - h.eval(&pm, false, false).unwrap().energy)
                / (2.0 * s);
            assert!(
                (fd - e2.grad[j]).abs() < 1e-6 * e2.grad.norm(),
                "{j}: {fd} {}",
                e2.grad[j]
            );
        }
        // At rest and on any hinge within π of its last update, nothing changes.
        assert_eq!(unwrap_near(0.3, 0.0), wrap(0.3));
        assert_eq!(unwrap_near(-2.0, 0.5), wrap(-2.0));
    }
}
