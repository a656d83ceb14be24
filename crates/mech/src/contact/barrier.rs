//! Unsigned-distance log barrier between a node and a triangle of another
//! body (IPC, Li et al. 2020), with a physical thickness offset.
//!
//! # Why a barrier and not the signed penalty
//!
//! The signed node-to-triangle penalty that came first (since removed)
//! needed each node's side of the other leaflet; free-edge nodes slipped
//! round the other leaflet's free edge, their side was re-learned, and on a
//! valve the contact set grew without bound. The distance d = |x − p| to the closest point p of the
//! triangle has no side: nothing to learn, nothing to re-learn. Instead the
//! energy grows without bound as d falls to the offset ξ, and the solver's
//! step filter ([`toi`], additive CCD) never lets a step reach it, so a
//! state that starts apart stays apart.
//!
//! # Energy
//!
//! With s = d − ξ (ξ = mid-surface offset: about the thickness, two half
//! thicknesses meeting; `leaflet_barrier` "Offset"), margin d̂ and node
//! area a (reference lumped area):
//!
//! ```text
//! e = κ a b(s),   b(s) = −(s − d̂)² ln(s/d̂)   0 < s < d̂;   0 for s ≥ d̂;   +∞ for s ≤ 0
//! b'(s)  = −2(s − d̂) ln(s/d̂) − (s − d̂)²/s
//! b''(s) = −2 ln(s/d̂) − 4(s − d̂)/s + (s − d̂)²/s²
//! ```
//!
//! b, b′, b″ vanish at s = d̂ (C²). κ a (−b′(s)) is the force on the node.
//!
//! # Derivatives
//!
//! ∂d/∂(x, A, B, C) = u (1, −w_A, −w_B, −w_C), u = (x − p)/d: exact in
//! every region (the envelope theorem: d is a minimum over the triangle's
//! barycentrics, so moving a vertex changes d only through p's weight).
//! The Hessian of d is exact too: d² has a closed form per region (face:
//! ((x − A)·N)²/|N|²; edge: |x − P|² − ((x − P)·e)²/|e|²; vertex: |x − V|²)
//! differentiated twice by [`Jet`]; ∇²d = ∇²d²/(2d) − ∇d² ∇d²ᵀ/(4d³).
//! Across region borders d is C¹ (the Hessian jumps), as it is for any
//! point–triangle distance.

use nalgebra::SMatrix;
use rayon::prelude::*;

use super::jet::{Jet, Num};
use crate::element::V3;
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::{Feature, closest_point};

/// Fraction of its gap a pair keeps over one step (additive CCD's s).
pub(super) const KEEP: f64 = 0.1;
/// Work bound of one pair's CCD.
pub(super) const CCD_ITER: usize = 60;

/// The offset of an item (node or edge) that starts `d0` from another
/// leaflet: ξ, lowered to d₀ − d̂ where that is closer (no force at the
/// start), but not below d₀/2 (the start is admissible).
pub(super) fn start_offset(xi: f64, dhat: f64, d0: f64) -> f64 {
    xi.min((d0 - dhat).max(0.5 * d0))
}

/// Per item i (in parallel) the least of `f(i, t)` over the triangles t
/// whose boxes the tree finds within `sphere(i)` = (centre, radius); ∞
/// when there are none. What both halves of the barrier ask of the tree:
/// start distances (offsets) and times of impact (collision-free steps).
pub(super) fn least_near(
    bvh: &Bvh,
    n: usize,
    sphere: impl Fn(usize) -> (V3, f64) + Sync,
    f: impl Fn(usize, u32) -> f64 + Sync,
) -> Vec<f64> {
    (0..n)
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let (c, r) = sphere(i);
            let mut m = f64::INFINITY;
            bvh.query_sphere(&c, r, |t| m = m.min(f(i, t)));
            m
        })
        .collect()
}

/// 12×12 pair Hessian over (node, A, B, C).
pub type Hess12 = SMatrix<f64, 12, 12>;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierParams {
    /// Margin d̂ (mm): the barrier acts for s = d − ξ < d̂.
    pub dhat: f64,
    /// κ (N/mm³): e = κ a b(s) with a in mm² and b in mm²; the contact
    /// pressure is κ(−b′(s)) per pair.
    pub kappa: f64,
}

/// −b′(d̂/2)/d̂ = ln 2 + 1/2.
const HALF_SLOPE: f64 = std::f64::consts::LN_2 + 0.5;

impl BarrierParams {
    /// κ such that two parallel sheets pressed together by `pressure` (MPa)
    /// rest at s = d̂/2. Each sheet's nodes push on the other's triangles
    /// and are pushed by the other's nodes, so the contact pressure on a
    /// sheet is 2κ(−b′(s)): κ = P / (2 d̂ (ln 2 + 1/2)).
    pub fn from_pressure(dhat: f64, pressure: f64) -> BarrierParams {
        BarrierParams {
            dhat,
            kappa: pressure / (2.0 * dhat * HALF_SLOPE),
        }
    }

    /// The s (mm) at which two parallel sheets carry `pressure` (MPa):
    /// the root of 2κ(−b′(s)) = P (−b′ falls monotonically from +∞ to 0
    /// on (0, d̂)); bisection to round-off.
    pub fn sheet_gap(&self, pressure: f64) -> f64 {
        let (mut lo, mut hi) = (0.0f64, self.dhat);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if 2.0 * self.kappa * -barrier(mid, self.dhat).1 > pressure {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// b(s), b′(s), b″(s) of the module documentation. s ≤ 0: (+∞, −∞, +∞).
pub fn barrier(s: f64, dhat: f64) -> (f64, f64, f64) {
    if s >= dhat {
        return (0.0, 0.0, 0.0);
    }
    if s <= 0.0 {
        return (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
    }
    let l = (s / dhat).ln();
    let r = s - dhat;
    (
        -r * r * l,
        -2.0 * r * l - r * r / s,
        -2.0 * l - 4.0 * r / s + r * r / (s * s),
    )
}

pub(super) fn sub<T: Num>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot<T: Num>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross<T: Num>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// d² of node p[0] to triangle (p[1], p[2], p[3]) in the closed form of
/// `feature`'s region.
pub fn dist2<T: Num>(p: &[[T; 3]; 4], feature: Feature) -> T {
    let x = p[0];
    let v = [p[1], p[2], p[3]];
    match feature {
        Feature::Face => {
            let n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
            let h = dot(sub(x, v[0]), n);
            (h * h).div(dot(n, n))
        }
        Feature::Edge(i) => {
            let (a, b) = (v[(i as usize + 1) % 3], v[(i as usize + 2) % 3]);
            let e = sub(b, a);
            let r = sub(x, a);
            let t = dot(r, e);
            dot(r, r) - (t * t).div(dot(e, e))
        }
        Feature::Vertex(i) => {
            let r = sub(x, v[i as usize]);
            dot(r, r)
        }
    }
}

/// Where a node is relative to a triangle.
#[derive(Debug, Clone, Copy)]
pub struct Proximity {
    /// Distance d = |x − p| (mm).
    pub dist: f64,
    /// Barycentrics of p.
    pub w: [f64; 3],
    pub feature: Feature,
    /// x − p.
    pub r: V3,
}

pub fn proximity(x: &V3, a: &V3, b: &V3, c: &V3) -> Proximity {
    let cp = closest_point(x, a, b, c);
    let r = x - cp.point;
    Proximity {
        dist: r.norm(),
        w: cp.w,
        feature: cp.feature,
        r,
    }
}

/// Energy (N·mm), gradient blocks (N; node, A, B, C) and optional exact
/// Hessian (N/mm) of one node–triangle pair with offset `xi` and node area
/// `area`. `None` when s = d − ξ ≤ 0 (the state is inadmissible).
pub fn pair_eval(
    q: &[V3; 4],
    xi: f64,
    area: f64,
    prm: &BarrierParams,
    want_hess: bool,
) -> Option<PairEval> {
    let pr = proximity(&q[0], &q[1], &q[2], &q[3]);
    pair_eval_at(q, &pr, xi, area, prm, want_hess)
}

/// [`pair_eval`] with the proximity already known.
pub fn pair_eval_at(
    q: &[V3; 4],
    pr: &Proximity,
    xi: f64,
    area: f64,
    prm: &BarrierParams,
    want_hess: bool,
) -> Option<PairEval> {
    let d = pr.dist;
    gated(d, xi, prm.dhat, want_hess, |s| {
        let (b, b1, b2) = barrier(s, prm.dhat);
        let ka = prm.kappa * area;
        let u = pr.r / d;
        let coef = [1.0, -pr.w[0], -pr.w[1], -pr.w[2]];
        let grad = coef.map(|c| u * (ka * b1 * c));
        let hess = want_hess.then(|| {
            let mut p = [[Jet::cst(0.0); 3]; 4];
            for (k, v) in q.iter().enumerate() {
                for c in 0..3 {
                    p[k][c] = Jet::var(v[c], 3 * k + c);
                }
            }
            let j = dist2(&p, pr.feature);
            let gs = nalgebra::SVector::<f64, 12>::from_column_slice(&j.g);
            let hs = Hess12::from_fn(|r, c| j.h[r][c]);
            // ∇d from the closed form, not ∇d²/(2d): the same to round-off, and
            // consistent with the gradient above.
            let mut gd = nalgebra::SVector::<f64, 12>::zeros();
            for k in 0..4 {
                for c in 0..3 {
                    gd[3 * k + c] = u[c] * coef[k];
                }
            }
            let hd = hs / (2.0 * d) - gs * gs.transpose() / (4.0 * d * d * d);
            (gd * gd.transpose() * b2 + hd * b1) * ka
        });
        (ka * b, grad, hess)
    })
}

/// Energy (N·mm), gradient blocks (N) and optional Hessian (N/mm) of a pair.
pub type PairEval = (f64, [V3; 4], Option<Hess12>);

/// The gate every pair evaluation shares (node–triangle and edge–edge):
/// `None` when s = d − ξ ≤ 0 (inadmissible), zeros from the margin on,
/// else `acting(s)`, refused (`None`) when it is not finite.
pub(super) fn gated(
    d: f64,
    xi: f64,
    dhat: f64,
    want_hess: bool,
    acting: impl FnOnce(f64) -> PairEval,
) -> Option<PairEval> {
    let s = d - xi;
    if !(s > 0.0) {
        return None;
    }
    if s >= dhat {
        return Some((0.0, [V3::zeros(); 4], want_hess.then(Hess12::zeros)));
    }
    let (e, grad, hess) = acting(s);
    if !(e.is_finite() && grad.iter().all(|g| g.iter().all(|v| v.is_finite()))) {
        return None;
    }
    Some((e, grad, hess))
}

/// The gate of the PSD parts: `None` when s ≤ 0, zero from the margin on,
/// else `acting(s)` when finite.
pub(super) fn gated_psd(
    d: f64,
    xi: f64,
    dhat: f64,
    acting: impl FnOnce(f64) -> Hess12,
) -> Option<Hess12> {
    let s = d - xi;
    if !(s > 0.0) {
        return None;
    }
    if s >= dhat {
        return Some(Hess12::zeros());
    }
    let h = acting(s);
    h.iter().all(|v| v.is_finite()).then_some(h)
}

/// The positive semi-definite part κ a b″(s) ∇d ∇dᵀ of the pair Hessian
/// (b″ > 0 on (0, d̂)); it drops κ a b′(s) ∇²d, which is negative
/// semi-definite wherever ∇²d is PSD (b′ < 0). What a solver's PSD phase
/// wants, at a fraction of an eigen-decomposition's cost. `None` when
/// inadmissible.
pub fn pair_gauss_newton(q: &[V3; 4], xi: f64, area: f64, prm: &BarrierParams) -> Option<Hess12> {
    let pr = proximity(&q[0], &q[1], &q[2], &q[3]);
    gated_psd(pr.dist, xi, prm.dhat, |s| {
        let b2 = barrier(s, prm.dhat).2;
        let u = pr.r / pr.dist;
        let coef = [1.0, -pr.w[0], -pr.w[1], -pr.w[2]];
        let mut gd = nalgebra::SVector::<f64, 12>::zeros();
        for k in 0..4 {
            for c in 0..3 {
                gd[3 * k + c] = u[c] * coef[k];
            }
        }
        gd * gd.transpose() * (prm.kappa * area * b2)
    })
}

/// Largest fraction t ∈ [0, 1] of the move `dq` from `q` (node, A, B, C)
/// over which s = d − ξ stays at least `keep` × its value at the start:
/// additive CCD (Li et al. 2021). The distance of the pair can fall at most
/// by l·Δt over Δt, l = |Δx − m| + max |Δv − m| (m the mean move, which
/// changes no distance), so advancing by 0.9 s/l at a time never crosses;
/// the last position with s ≥ keep·s₀ is returned. `max_iter` bounds the
/// work (the answer is then short of the true one, never past it). 0 when
/// the pair starts at s ≤ 0.
pub fn toi(q: &[V3; 4], dq: &[V3; 4], xi: f64, keep: f64, max_iter: usize) -> f64 {
    let m = (dq[0] + dq[1] + dq[2] + dq[3]) / 4.0;
    let p = dq.map(|v| v - m);
    let l = p[0].norm() + p[1].norm().max(p[2].norm()).max(p[3].norm());
    additive_toi(q, dq, xi, keep, max_iter, l, |y| {
        proximity(&y[0], &y[1], &y[2], &y[3]).dist
    })
}

/// The additive CCD loop of [`toi`] for any pair distance `dist` of four
/// points whose rate of decrease along the move is at most `l` (per unit
/// of the step fraction).
pub fn additive_toi(
    q: &[V3; 4],
    dq: &[V3; 4],
    xi: f64,
    keep: f64,
    max_iter: usize,
    l: f64,
    dist: impl Fn(&[V3; 4]) -> f64,
) -> f64 {
    let s0 = dist(q) - xi;
    if !(s0 > 0.0) {
        return 0.0;
    }
    if l == 0.0 {
        return 1.0;
    }
    let target = keep * s0;
    let mut t = 0.0;
    let mut tl = (1.0 - keep) * s0 / l;
    for _ in 0..max_iter {
        let tt = t + tl;
        if tt >= 1.0 {
            // The whole move fits once the bound reaches past its end,
            // provided the end itself keeps the gap.
            let e = [0, 1, 2, 3].map(|k| q[k] + dq[k]);
            return if dist(&e) - xi >= target { 1.0 } else { t };
        }
        let y = [0, 1, 2, 3].map(|k| q[k] + dq[k] * tt);
        let s = dist(&y) - xi;
        if s < target {
            return if t > 0.0 {
                t
            } else {
                tt.min((1.0 - keep) * s0 / l)
            };
        }
        t = tt;
        tl = 0.9 * s / l;
    }
    t
}
