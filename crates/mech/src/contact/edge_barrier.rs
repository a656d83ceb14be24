//! The barrier of `barrier.rs` between an edge of one leaflet and an edge
//! of another (IPC's edge–edge pairs, Li et al. 2020 §4).
//!
//! # Why
//!
//! Node–triangle pairs see a node coming at a face, never an edge of one
//! leaflet coming across an edge of another: two edges can cross with all
//! four nodes far from the other leaflet's faces (the test
//! `an_edge_pushed_onto_an_edge_is_held_by_the_edge_pair`). Without the
//! pair nothing pushes back there; only the crossing test refuses the step.
//!
//! # Energy
//!
//! With d the unsigned segment–segment distance (`geom::segment_distance`),
//! s = d − ξ and b(s) the barrier of `barrier.rs`:
//!
//! ```text
//! e = κ w m(c) b(s),   c = |e₁ × e₂|²,
//! m(c) = (2 − c/ε)(c/ε) for c < ε, 1 beyond,   ε = 1e-3 |e₁⁰|² |e₂⁰|²
//! ```
//!
//! The mollifier m (IPC's, ε from the rest lengths) makes the pair C¹
//! where the edges turn parallel: there the closest points of the two
//! segments jump from one end to the other, so ∇d jumps; m and ∇m vanish
//! at c = 0 (∇c = 0 there too), so the product's gradient is continuous.
//! Nearly parallel edges in contact are held by the node–triangle pairs of
//! their endpoints instead.
//!
//! # Derivatives
//!
//! With D = d², f(D, c) = m(c) b(√D − ξ): ∇e = κw (f_D ∇D + f_c ∇c) and
//! ∇²e = κw (f_D ∇²D + f_c ∇²c + f_DD ∇D∇Dᵀ + f_cc ∇c∇cᵀ + f_Dc (∇D∇cᵀ +
//! ∇c∇Dᵀ)). ∇D = 2 r (1 − s, s, −(1 − t), −t), r = a(s) − b(t), holds in
//! every region (d is a minimum over s, t: the envelope theorem); ∇²D and
//! ∇²c come from the region's closed form differentiated by [`Jet`].

use super::barrier::{
    BarrierParams, Hess12, PairEval, additive_toi, barrier, cross, dot, gated, gated_psd, sub,
};
use super::jet::{Jet, Num};
use crate::element::V3;
use coapt_geom::segment_distance::{SegProximity, SegRegion, segment_segment};

/// ε = MOLLIFIER |e₁⁰|² |e₂⁰|²: the mollifier acts below an angle of about
/// 1.8° between the edges (IPC's choice).
pub const MOLLIFIER: f64 = 1e-3;

/// D = d² of segments (p[0], p[1]) and (p[2], p[3]) in `region`'s closed form.
pub fn dist2<T: Num>(p: &[[T; 3]; 4], region: SegRegion) -> T {
    match region {
        SegRegion::Interior => {
            let n = cross(sub(p[1], p[0]), sub(p[3], p[2]));
            let h = dot(sub(p[0], p[2]), n);
            (h * h).div(dot(n, n))
        }
        SegRegion::PointEdge(k) => {
            let (x, q0, q1) = match k {
                0 => (p[0], p[2], p[3]),
                1 => (p[1], p[2], p[3]),
                2 => (p[2], p[0], p[1]),
                _ => (p[3], p[0], p[1]),
            };
            let e = sub(q1, q0);
            let r = sub(x, q0);
            let t = dot(r, e);
            dot(r, r) - (t * t).div(dot(e, e))
        }
        SegRegion::PointPoint(i, j) => {
            let r = sub(p[i as usize], p[j as usize]);
            dot(r, r)
        }
    }
}

/// c = |e₁ × e₂|².
pub fn cross2<T: Num>(p: &[[T; 3]; 4]) -> T {
    let n = cross(sub(p[1], p[0]), sub(p[3], p[2]));
    dot(n, n)
}

/// m(c), m′(c), m″(c) of the module documentation.
pub fn mollifier(c: f64, eps: f64) -> (f64, f64, f64) {
    if c >= eps {
        return (1.0, 0.0, 0.0);
    }
    let r = c / eps;
    ((2.0 - r) * r, (2.0 - 2.0 * r) / eps, -2.0 / (eps * eps))
}

/// ε of a pair from the two edges' rest squared lengths (mm²).
pub fn mollifier_eps(rest_len2_a: f64, rest_len2_b: f64) -> f64 {
    MOLLIFIER * rest_len2_a * rest_len2_b
}

pub fn proximity(q: &[V3; 4]) -> SegProximity {
    segment_segment(&q[0], &q[1], &q[2], &q[3])
}

fn jets(q: &[V3; 4]) -> [[Jet; 3]; 4] {
    let mut p = [[Jet::cst(0.0); 3]; 4];
    for (k, v) in q.iter().enumerate() {
        for c in 0..3 {
            p[k][c] = Jet::var(v[c], 3 * k + c);
        }
    }
    p
}

type Vec12 = nalgebra::SVector<f64, 12>;

fn flat(g: &[V3; 4]) -> Vec12 {
    Vec12::from_fn(|i, _| g[i / 3][i % 3])
}

/// ∇D and ∇c as blocks over (a0, a1, b0, b1).
fn grads(q: &[V3; 4], pr: &SegProximity) -> ([V3; 4], [V3; 4]) {
    let r = (q[0] + (q[1] - q[0]) * pr.s) - (q[2] + (q[3] - q[2]) * pr.t);
    let gd = [
        r * (2.0 * (1.0 - pr.s)),
        r * (2.0 * pr.s),
        r * (-2.0 * (1.0 - pr.t)),
        r * (-2.0 * pr.t),
    ];
    let (e1, e2) = (q[1] - q[0], q[3] - q[2]);
    let n = e1.cross(&e2);
    let ga = e2.cross(&n) * 2.0;
    let gb = n.cross(&e1) * 2.0;
    (gd, [-ga, ga, -gb, gb])
}

/// Energy (N·mm), gradient blocks (N; a0, a1, b0, b1) and optional exact
/// Hessian (N/mm) of one edge–edge pair with offset `xi`, weight `weight`
/// (mm²) and mollifier threshold `eps` (mm⁴). `None` when s ≤ 0.
pub fn pair_eval(
    q: &[V3; 4],
    xi: f64,
    weight: f64,
    eps: f64,
    prm: &BarrierParams,
    want_hess: bool,
) -> Option<PairEval> {
    pair_eval_at(q, &proximity(q), xi, weight, eps, prm, want_hess)
}

/// [`pair_eval`] with the proximity already known.
pub fn pair_eval_at(
    q: &[V3; 4],
    pr: &SegProximity,
    xi: f64,
    weight: f64,
    eps: f64,
    prm: &BarrierParams,
    want_hess: bool,
) -> Option<PairEval> {
    let d = pr.dist;
    gated(d, xi, prm.dhat, want_hess, |s| {
        let (b, b1, b2) = barrier(s, prm.dhat);
        let (e1, e2) = (q[1] - q[0], q[3] - q[2]);
        let c = e1.cross(&e2).norm_squared();
        let (m, m1, m2) = mollifier(c, eps);
        let kw = prm.kappa * weight;
        let dd = d * d;
        let f_d = m * b1 / (2.0 * d);
        let f_c = m1 * b;
        let (gd, gc) = grads(q, pr);
        let grad = [0, 1, 2, 3].map(|k| (gd[k] * f_d + gc[k] * f_c) * kw);
        let hess = want_hess.then(|| {
            let p = jets(q);
            let jd = dist2(&p, pr.region);
            let hd = Hess12::from_fn(|r, c| jd.h[r][c]);
            let (vd, vc) = (flat(&gd), flat(&gc));
            let f_dd = m * (b2 / (4.0 * dd) - b1 / (4.0 * dd * d));
            let mut h = hd * f_d + vd * vd.transpose() * f_dd;
            if m1 != 0.0 {
                let jc = cross2(&p);
                let hc = Hess12::from_fn(|r, c| jc.h[r][c]);
                let f_cc = m2 * b;
                let f_dc = m1 * b1 / (2.0 * d);
                let x = vd * vc.transpose();
                h += hc * f_c + vc * vc.transpose() * f_cc + (x + x.transpose()) * f_dc;
            }
            h * kw
        });
        (kw * m * b, grad, hess)
    })
}

/// The positive semi-definite part κ w m b″ ∇d ∇dᵀ of the pair Hessian
/// (m ≥ 0, b″ > 0); see `barrier::pair_gauss_newton`. `None` when s ≤ 0.
pub fn pair_gauss_newton(
    q: &[V3; 4],
    xi: f64,
    weight: f64,
    eps: f64,
    prm: &BarrierParams,
) -> Option<Hess12> {
    let pr = proximity(q);
    gated_psd(pr.dist, xi, prm.dhat, |s| {
        let b2 = barrier(s, prm.dhat).2;
        let c = (q[1] - q[0]).cross(&(q[3] - q[2])).norm_squared();
        let m = mollifier(c, eps).0;
        // ∇d = ∇D / (2d).
        let vd = flat(&grads(q, &pr).0) / (2.0 * pr.dist);
        vd * vd.transpose() * (prm.kappa * weight * m * b2)
    })
}

/// Largest fraction of the move `dq` of the pair over which s = d − ξ
/// keeps `keep` × its start value: additive CCD as `barrier::toi`, with the
/// bound l = max |Δa − m| + max |Δb − m| on how fast the segments' distance
/// can fall (m the mean move).
pub fn toi(q: &[V3; 4], dq: &[V3; 4], xi: f64, keep: f64, max_iter: usize) -> f64 {
    let m = (dq[0] + dq[1] + dq[2] + dq[3]) / 4.0;
    let p = dq.map(|v| v - m);
    let l = p[0].norm().max(p[1].norm()) + p[2].norm().max(p[3].norm());
    additive_toi(q, dq, xi, keep, max_iter, l, |y| proximity(y).dist)
}
