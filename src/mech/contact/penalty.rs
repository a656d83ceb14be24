//! Node-to-triangle penalty contact between different bodies (leaflets),
//! ALGORITHMS.md §7.2.
//!
//! # Potential
//!
//! For a node x (body a, lumped area a_n, mm²) and a triangle T = (A, B, C)
//! of another body b, let p be the closest point of T to x (barycentrics w),
//! n_T the unit normal of T and s = ±1 the remembered side. The gap (mm) is
//!
//! * face region (p inside T):      g = s·(x − p)·n_T − m   (signed distance to the plane of T)
//! * edge or vertex region:         g = |x − p| − m          (unsigned distance to T)
//!
//! with m = [`ContactParams::margin`]. The two agree where the regions meet
//! when the node is on its remembered side (s·(x − p)·n_T = |x − p| there),
//! so for every node that has not tunnelled the gap is the distance to the
//! other body's surface minus the margin: continuous in all positions.
//! A node on the wrong side (tunnelled, s·(x−p)·n_T < 0) has g < −m while it
//! projects into a face, and is pushed back to its side; once it leaves the
//! face regions (it went round a free edge) it is released and its side is
//! re-learned at the next [`Sides::commit`]. That release is the one place
//! where the energy jumps (by a k [φ(−|h|−m) − φ(|h|−m)], h the plane distance
//! at the face border).
//!
//! The energy of the pair is
//!
//! ```text
//! e = a_n · k · φ(g)                       (N·mm; k = stiffness, N/mm³)
//! φ(g) = 0                                  g ≥ 0
//! φ(g) = −g³/(6δ)                           −δ ≤ g < 0
//! φ(g) = g²/2 + δg/2 + δ²/6                 g < −δ
//! ```
//!
//! with δ = m/2 (the quadratic force ramp of ALGORITHMS.md §7.2). φ is C²
//! and convex; the contact pressure is k·(−φ'(g)) (MPa): zero at g = 0,
//! k·g²/(2δ) on the ramp, k·(−g − δ/2) beyond it. Under a pressure P the
//! equilibrium gap is g = −√(2δP/k) when P ≤ kδ/2 (on the ramp), else
//! g = −P/k − δ/2.
//!
//! # Derivatives (what is exact)
//!
//! ∂g/∂(x, A, B, C) = (u, −w_A u, −w_B u, −w_C u) with u = s n_T in the face
//! region and u = (x − p)/|x − p| in the edge and vertex regions. This is
//! the EXACT gradient of the gap as defined above in every region (moving
//! a vertex rotates the plane/edge about p, which changes the distance only
//! at second order because x − p is normal to it). So the returned gradient
//! a_n k φ'(g) ∂g is the exact gradient of e, and Σ_i grad_i = 0 (Σ w = 1),
//! i.e. momentum is conserved; the gap is also rotation invariant, so
//! angular momentum is conserved as well. The area a_n is a constant
//! parameter of the pair.
//!
//! The Hessian is the Gauss–Newton part a_n k φ''(g) ∂g ∂gᵀ
//! (= k_c [1, −w]ᵀ[1, −w] ⊗ u uᵀ), positive semi-definite; it neglects
//! φ'(g) ∂²g (the dn/dx and dw/dx terms).
//!
//! Degenerate triangles (area ≤ 1e-14 × squared longest edge, the rule of
//! `RefTri::new`) and non-finite positions never form pairs and evaluate to
//! zero.

use std::collections::BTreeMap;

use nalgebra::SMatrix;
use rayon::prelude::*;

use crate::geom::bvh::Bvh;
use crate::geom::closest_point::{Feature, closest_point};
use crate::mech::element::V3;

/// 12×12 pair Hessian over (node, A, B, C).
pub type Hess12 = SMatrix<f64, 12, 12>;

/// Penalty parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Margin m (mm): the gap is measured from m off the surface; force
    /// starts at distance m.
    pub margin: f64,
    /// Stiffness k (N/mm³): pressure per mm of penetration beyond the ramp.
    pub stiffness: f64,
}

impl ContactParams {
    /// Width δ = m/2 of the cubic ramp of φ (mm).
    pub fn ramp(&self) -> f64 {
        0.5 * self.margin
    }

    /// Equilibrium gap g (mm, ≤ 0) under a contact pressure `pressure`
    /// (MPa): the g with k·(−φ'(g)) = P.
    pub fn equilibrium_gap(&self, pressure: f64) -> f64 {
        let d = self.ramp();
        let p = pressure.max(0.0);
        if p <= self.stiffness * d / 2.0 {
            -(2.0 * d * p / self.stiffness).sqrt()
        } else {
            -p / self.stiffness - d / 2.0
        }
    }

    /// Stiffness from a design pressure (ALGORITHMS.md §7.2: k_c ≈ α P A / m
    /// per node, i.e. k = α P / m per unit area). Under the pressure
    /// `pressure` (MPa) the penetration past g = 0 is m/√α for α ≥ 4 (on
    /// the cubic ramp; e.g. α = 25: 0.2 m), and m/α + m/4 for α < 4.
    pub fn from_pressure(margin: f64, pressure: f64, alpha: f64) -> ContactParams {
        ContactParams {
            margin,
            stiffness: alpha * pressure / margin,
        }
    }
}

/// φ(g), φ'(g), φ''(g) of the module documentation, ramp width `delta`
/// (δ ≤ 0 gives the plain quadratic g²/2).
pub fn potential(g: f64, delta: f64) -> (f64, f64, f64) {
    if g >= 0.0 {
        (0.0, 0.0, 0.0)
    } else if delta > 0.0 && g >= -delta {
        (
            -g * g * g / (6.0 * delta),
            -g * g / (2.0 * delta),
            -g / delta,
        )
    } else {
        let d = delta.max(0.0);
        (g * g / 2.0 + d * g / 2.0 + d * d / 6.0, g + d / 2.0, 1.0)
    }
}

/// One node–triangle contact pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    pub node: u32,
    pub tri: u32,
    /// Body of the triangle (the node's body differs).
    pub body: u16,
    /// Side s = ±1 of the node relative to n_T.
    pub side: i8,
    /// Lumped node area a_n (mm²).
    pub area: f64,
    /// Gap g (mm) at the positions `find_pairs` saw.
    pub gap: f64,
    /// Closest feature at those positions.
    pub feature: Feature,
}

impl Pair {
    /// Global node indices of the four blocks (node, A, B, C).
    pub fn dofs(&self, tris: &[[u32; 3]]) -> [u32; 4] {
        let t = tris[self.tri as usize];
        [self.node, t[0], t[1], t[2]]
    }
}

/// Geometry of a node against a triangle.
#[derive(Debug, Clone, Copy)]
pub struct GapEval {
    /// Gap g (mm).
    pub gap: f64,
    /// Distance |x − p| (mm).
    pub dist: f64,
    /// Signed plane distance h = (x − p)·n_T (mm).
    pub plane: f64,
    /// Unit ∂g/∂x.
    pub dir: V3,
    /// Barycentrics of the closest point.
    pub w: [f64; 3],
    pub feature: Feature,
}

fn finite(v: &V3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// Unit normal of a non-degenerate triangle (area > 1e-14 × longest²).
pub fn tri_normal(a: &V3, b: &V3, c: &V3) -> Option<V3> {
    if !(finite(a) && finite(b) && finite(c)) {
        return None;
    }
    let cr = (b - a).cross(&(c - a));
    let twice = cr.norm();
    let longest = [(b - a), (c - b), (a - c)]
        .iter()
        .map(|e| e.norm_squared())
        .fold(0.0, f64::max);
    if twice > 1e-14 * longest && twice.is_finite() {
        Some(cr / twice)
    } else {
        None
    }
}

/// Gap of node `x` against triangle `(a, b, c)` with side `side`
/// (`None`: take the current side, sign of h, + when h = 0). `None` for a
/// degenerate triangle or non-finite input.
pub fn gap(x: &V3, a: &V3, b: &V3, c: &V3, side: Option<i8>, margin: f64) -> Option<GapEval> {
    let n = tri_normal(a, b, c)?;
    if !finite(x) {
        return None;
    }
    let cp = closest_point(x, a, b, c);
    let r = x - cp.point;
    let h = r.dot(&n);
    let s = side.unwrap_or(if h >= 0.0 { 1 } else { -1 }) as f64;
    let dist = r.norm();
    let (g, dir) = match cp.feature {
        Feature::Face => (s * h - margin, n * s),
        _ => {
            if dist > 0.0 {
                (dist - margin, r / dist)
            } else {
                (-margin, n * s)
            }
        }
    };
    Some(GapEval {
        gap: g,
        dist,
        plane: h,
        dir,
        w: cp.w,
        feature: cp.feature,
    })
}

/// Remembered sides s per (node, other body), from the last converged
/// state.
#[derive(Debug, Clone, Default)]
pub struct Sides {
    map: BTreeMap<(u32, u16), i8>,
}

impl Sides {
    pub fn new() -> Sides {
        Sides::default()
    }

    pub fn get(&self, node: u32, body: u16) -> Option<i8> {
        self.map.get(&(node, body)).copied()
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }

    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// Records the converged state `x`: replaces the store by the sides of
    /// `pairs` (pairs out of reach are forgotten). A pair whose node
    /// projects into the face keeps its side (a tunnelled node stays
    /// tunnelled and keeps being pushed back); otherwise the side is
    /// re-learned from the geometry, sign((x − p)·n_T).
    pub fn commit(&mut self, x: &[V3], tris: &[[u32; 3]], pairs: &[Pair]) {
        self.map.clear();
        for p in pairs {
            let t = tris[p.tri as usize];
            let (a, b, c) = (&x[t[0] as usize], &x[t[1] as usize], &x[t[2] as usize]);
            let s =
                match gap(&x[p.node as usize], a, b, c, Some(p.side), 0.0) {
                    Some(ge) if ge.feature != Feature::Face && ge.plane != 0.0 => {
                        if ge.plane > 0.0 { 1 } else { -1 }
                    }
                    _ => p.side,
                };
            self.map.insert((p.node, p.body), s);
        }
    }
}

/// Lumped node areas: a third of the incident (non-degenerate) triangle
/// areas (mm²).
pub fn node_areas(x: &[V3], tris: &[[u32; 3]]) -> Vec<f64> {
    let mut a = vec![0.0; x.len()];
    for t in tris {
        let (p, q, r) = (&x[t[0] as usize], &x[t[1] as usize], &x[t[2] as usize]);
        if tri_normal(p, q, r).is_none() {
            continue;
        }
        let ar = 0.5 * (q - p).cross(&(r - p)).norm() / 3.0;
        for &i in t {
            a[i as usize] += ar;
        }
    }
    a
}

/// Broad and narrow phase: every node i of body a = `node_body[i]` is
/// tested against the triangles of every other body within reach
/// `margin + extra_reach` (distance to the closed triangle, mm) found with
/// `bvh` (a tree over the triangles of all bodies, refitted to `x`). Per
/// (node, other body) only the pair with the smallest gap is kept (ties:
/// smaller triangle index). Pairs with g ≥ 0 are returned too (they carry no
/// force now but may engage during a line search). Nodes with a
/// non-positive or non-finite area are skipped, as are triangles that
/// contain the node. The result is sorted by (node, body).
#[allow(clippy::too_many_arguments)]
pub fn find_pairs(
    x: &[V3],
    tris: &[[u32; 3]],
    node_body: &[u16],
    tri_body: &[u16],
    node_area: &[f64],
    bvh: &Bvh,
    params: &ContactParams,
    sides: &Sides,
    extra_reach: f64,
) -> Vec<Pair> {
    assert_eq!(node_body.len(), x.len());
    assert_eq!(node_area.len(), x.len());
    assert_eq!(tri_body.len(), tris.len());
    let reach = params.margin + extra_reach.max(0.0);
    let chunk = 256;
    let per_chunk: Vec<Vec<Pair>> = (0..x.len().div_ceil(chunk))
        .into_par_iter()
        .map(|ci| {
            let mut out = Vec::new();
            let mut best: Vec<Pair> = Vec::new();
            for i in ci * chunk..((ci + 1) * chunk).min(x.len()) {
                let area = node_area[i];
                let xi = x[i];
                if !(area > 0.0 && area.is_finite() && finite(&xi)) {
                    continue;
                }
                let body = node_body[i];
                best.clear();
                bvh.query_sphere(&xi, reach, |t| {
                    let tb = tri_body[t as usize];
                    let tv = tris[t as usize];
                    if tb == body || tv.contains(&(i as u32)) {
                        return;
                    }
                    let (a, b, c) = (&x[tv[0] as usize], &x[tv[1] as usize], &x[tv[2] as usize]);
                    let Some(ge) = gap(&xi, a, b, c, sides.get(i as u32, tb), params.margin) else {
                        return;
                    };
                    if ge.dist > reach {
                        return;
                    }
                    let side =
                        sides
                            .get(i as u32, tb)
                            .unwrap_or(if ge.plane >= 0.0 { 1 } else { -1 });
                    let cand = Pair {
                        node: i as u32,
                        tri: t,
                        body: tb,
                        side,
                        area,
                        gap: ge.gap,
                        feature: ge.feature,
                    };
                    match best.iter_mut().find(|p| p.body == tb) {
                        Some(p) => {
                            if cand.gap < p.gap || (cand.gap == p.gap && cand.tri < p.tri) {
                                *p = cand;
                            }
                        }
                        None => best.push(cand),
                    }
                });
                best.sort_by_key(|p| p.body);
                out.extend_from_slice(&best);
            }
            out
        })
        .collect();
    per_chunk.concat()
}

/// Energy (N·mm), gradient blocks (N; node, A, B, C; force = −grad) and
/// optional Gauss–Newton Hessian (N/mm; row/column 3·block + coordinate,
/// blocks in the order of [`Pair::dofs`]) of one pair at positions `x`. The
/// closest point and feature are recomputed at `x`; the side and area are
/// the pair's. A degenerate triangle or non-finite input gives zeros.
pub fn pair_eval(
    x: &[V3],
    tris: &[[u32; 3]],
    pair: &Pair,
    params: &ContactParams,
    want_hess: bool,
) -> (f64, [V3; 4], Option<Hess12>) {
    let zero = (0.0, [V3::zeros(); 4], want_hess.then(Hess12::zeros));
    let t = tris[pair.tri as usize];
    let (a, b, c) = (&x[t[0] as usize], &x[t[1] as usize], &x[t[2] as usize]);
    let Some(ge) = gap(
        &x[pair.node as usize],
        a,
        b,
        c,
        Some(pair.side),
        params.margin,
    ) else {
        return zero;
    };
    let (phi, dphi, ddphi) = potential(ge.gap, params.ramp());
    let ka = pair.area * params.stiffness;
    let e = ka * phi;
    if !(e.is_finite() && ge.dir.iter().all(|v| v.is_finite())) {
        return zero;
    }
    let coef = [1.0, -ge.w[0], -ge.w[1], -ge.w[2]];
    let grad = coef.map(|cf| ge.dir * (ka * dphi * cf));
    let hess = want_hess.then(|| {
        let mut h = Hess12::zeros();
        if ddphi > 0.0 {
            let uu = ge.dir * ge.dir.transpose() * (ka * ddphi);
            for i in 0..4 {
                for j in 0..4 {
                    h.fixed_view_mut::<3, 3>(3 * i, 3 * j)
                        .copy_from(&(uu * (coef[i] * coef[j])));
                }
            }
        }
        h
    });
    (e, grad, hess)
}

/// Sum of the pair energies at `x`; adds the gradients to `grad` (indexed
/// by node).
pub fn eval_all(
    x: &[V3],
    tris: &[[u32; 3]],
    pairs: &[Pair],
    params: &ContactParams,
    grad: &mut [V3],
) -> f64 {
    let mut e = 0.0;
    for p in pairs {
        let (ep, g, _) = pair_eval(x, tris, p, params, false);
        e += ep;
        for (k, &d) in p.dofs(tris).iter().enumerate() {
            grad[d as usize] += g[k];
        }
    }
    e
}

/// Recomputes `gap` and `feature` of every pair at positions `x` (same
/// triangles and sides), e.g. before [`contact_mask`] at a state other than
/// the one `find_pairs` saw. A degenerate triangle gets gap = +∞.
pub fn update_gaps(x: &[V3], tris: &[[u32; 3]], pairs: &mut [Pair], params: &ContactParams) {
    for p in pairs.iter_mut() {
        let t = tris[p.tri as usize];
        let (a, b, c) = (&x[t[0] as usize], &x[t[1] as usize], &x[t[2] as usize]);
        match gap(&x[p.node as usize], a, b, c, Some(p.side), params.margin) {
            Some(ge) => {
                p.gap = ge.gap;
                p.feature = ge.feature;
            }
            None => p.gap = f64::INFINITY,
        }
    }
}

/// Per node, bit b set when the node touches body b (a pair with gap < 0;
/// bodies ≥ 8 are not representable and ignored). `pairs` should come from
/// [`find_pairs`] at the state being reported.
pub fn contact_mask(n_nodes: usize, pairs: &[Pair]) -> Vec<u8> {
    let mut m = vec![0u8; n_nodes];
    for p in pairs {
        if p.gap < 0.0 && p.body < 8 {
            m[p.node as usize] |= 1 << p.body;
        }
    }
    m
}
