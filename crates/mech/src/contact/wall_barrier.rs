//! Leaflet-to-wall contact as a [`Term`] (`wall_contact = true`): every
//! free leaflet node against the fixed aortic wall, with the log barrier of
//! `barrier.rs`, so that a leaflet pushed towards the wall (the sinus side
//! of the belly, a leaflet turned inside out by a reversed load) lies on
//! it instead of passing through it.
//!
//! # Distance and energy
//!
//! A node i at mid-surface distance d from the wall has s = d − ξᵢ and
//! energy κ aᵢ b(s) (b of [`barrier::barrier`], C² in s, zero from s = d̂
//! on, +∞ at s = 0; aᵢ the node's reference lumped area).
//!
//! - Cylinder (benchmarks, tests): d = R − r, r the distance from the
//!   axis: smooth everywhere but on the axis, where s ≥ d̂ anyway.
//! - Mesh (aorta.vtp's wall triangles): as between leaflets, the sum over
//!   the wall triangles within reach of the barrier of the node–triangle
//!   distance (IPC), not the barrier of the distance to the whole wall:
//!   the minimum over triangles has a kink where two faces of a fold in
//!   the segmented wall are equally near; each pair's distance is C¹
//!   across its closest-point regions (C² inside each), so the sum is C¹.
//!   A node over a wall edge or vertex counts the triangles around it, and
//!   with ξ large against a segmented wall's triangles (t/2 = 0.25 mm,
//!   edges of 0.3 mm) a node over a face feels its neighbours too: a
//!   sheet pressed on a mesh rests farther off than on the exact surface
//!   (a clamped patch blown onto a 12 mm cylinder at 80 mmHg, d̂ =
//!   0.25 mm: centre at s = 0.143 mm off a 0.31 mm mesh of it, 0.107 mm
//!   off the analytic cylinder; the tests
//!   `a_patch_blown_outward_stays_off_the_*`).
//!
//! The wall does not move, so only the node's three coordinates enter:
//! ∇d = u = (x − p)/d, and ∇²d = 0 over a face, (I − eeᵀ − uuᵀ)/d over an
//! edge e, (I − uuᵀ)/d over a vertex (the cylinder: ∇d = −ρ̂,
//! ∇²d = −(I − aaᵀ − ρ̂ρ̂ᵀ)/r). The exact 3×3 Hessian is
//! κa(b″ ∇d∇dᵀ + b′ ∇²d). For a mesh pair ∇²d is PSD and orthogonal to u
//! while b′ < 0 < b″, so its PSD projection is exactly κa b″ uuᵀ (what the
//! projected tangent uses); for the cylinder both parts are PSD already
//! (the wall is concave seen from the lumen) and the projection is the
//! exact Hessian.
//!
//! # Offset, margin, stiffness
//!
//! ξ = t/2 (`offset`): the leaflet's mid-surface never comes closer to
//! the wall than half its thickness (its wall-side face never enters the
//! wall). κ is such that a sheet pressed onto the wall by the closing
//! pressure P rests at s = d̂/2 over a face: one node–wall pair per node
//! (the wall has no nodes pushing back), so κ(−b′(d̂/2)) = P, twice the
//! leaflet barrier's κ. d̂ is `contact_margin`.
//!
//! # Nodes that start within the margin
//!
//! Next to the suture line (sutured nodes lie on the wall, to 0.012 mm on
//! the sample) free nodes start closer than ξ + d̂, some closer than ξ
//! (on the sample, GOH, h 0.5 mm, sutured: 973 of 4818 free nodes). Such
//! a node, d₀ from the wall at the start, gets its own offset and margin:
//! ξᵢ = min(ξ, d₀/2), d̂ᵢ = d₀ − ξᵢ. It starts exactly at its margin, so
//! the barrier neither explodes nor pushes at the start, and still never
//! reaches the wall (it keeps at least ξᵢ, the full t/2 where d₀ ≥ t).
//! Lowering only the offset as between leaflets ([`start_offset`]:
//! ξᵢ = min(ξ, max(d₀ − d̂, d₀/2)), margin d̂) leaves nodes closer than 2d̂
//! inside the margin at the start: on the sample the closure started at
//! 3.4 N instead of 0.2 N, those nodes pushed off the wall they are sewn
//! next to.
//!
//! Nodes that start on the wall or on its far side are exempt (d₀ = 0, or
//! outside the lumen: r ≥ R, or the wrong side of the mesh by the sign of
//! (x − p)·n summed over the nearest triangles' face normals, the lumen
//! side being the one most free nodes start on): the barrier is of the
//! unsigned distance, so it would hold such a node outside, against the
//! membrane pulling it in, where nothing holds it without the term.
//! Suturing turns the sutured triangles into the wall's tangent planes,
//! which lie outside a convex wall, so much of the row next to the suture
//! line is exempt (sample: 151 of 4818 free nodes; peer cylinder, h 1 mm:
//! 36 of 389). The price: under a load that pushes the leaflet onto the
//! wall that row may still pass it (the peer leaflet at −80 mmHg: up to
//! 0.55 mm outside, while every acting node stays inside). A signed
//! distance for those nodes would close that gap. Nodes with no free
//! coordinate never act.
//!
//! # No crossing
//!
//! [`Term::max_step`] keeps every node–wall s above [`KEEP`] × its start
//! over a step: the cylinder in closed form (r(t)² is quadratic in the
//! step fraction), the mesh by additive CCD against every triangle the
//! node could reach over its move (the wall is fixed, so a pair's distance
//! falls at most by the node's move). Candidate triangles are found in the
//! wall's tree (built once: the wall does not move) at every evaluation,
//! for the node where it is then, within ξᵢ + d̂: no lists to keep valid,
//! and a node far from the wall costs one failed descent of the tree.
//!
//! # Contact mask
//!
//! Bit 7 ([`WALL_BIT`]) marks nodes within the margin of the wall
//! (s < d̂). The leaflet barrier uses bits 0–2 (leaflets), the planes
//! bits 0–5 (two per leaflet), so bit 7 collides with neither for up to
//! three leaflets.

use std::sync::Arc;

use nalgebra::Matrix3;
use rayon::prelude::*;
use serde::Serialize;

#[cfg(doc)]
use super::barrier::start_offset;
use super::barrier::{self, BarrierParams, CCD_ITER, KEEP};
use crate::element::V3;
use crate::sparse::{Dofs, Pattern};
use crate::system::Term;
use crate::wall::Wall;
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::{Feature, closest_point};

/// Contact-mask bit of a node within the margin of the wall.
pub const WALL_BIT: u8 = 1 << 7;

/// Farthest (mm) a node's start distance and side are looked for; a node
/// farther from the wall counts as inside the lumen with the full offset.
const START_SEARCH_MM: f64 = 4.0;

/// What the term records in `closure.json`.
#[derive(Debug, Clone, Serialize)]
pub struct WallSummary {
    pub wall: &'static str,
    pub offset_mm: f64,
    pub margin_mm: f64,
    pub kappa_n_per_mm3: f64,
    /// Nodes the barrier acts on.
    pub acting_nodes: usize,
    /// Free nodes exempt: on the wall or outside the lumen at the start.
    pub exempt_nodes: usize,
    /// Acting nodes whose margin (and where d₀ < t, offset) was narrowed:
    /// they start within ξ + d̂ of the wall.
    pub started_within_margin: usize,
    /// Acting nodes within the margin (s < d̂) at the final state.
    pub nodes_touching: usize,
    /// Node–triangle pairs within the margin (mesh; the cylinder: nodes).
    pub pairs_touching: usize,
    /// Least mid-surface distance (mm) of an acting node to the wall, and
    /// of one with the full offset (t/2 at least, by construction).
    pub min_distance_mm: Option<f64>,
    pub min_distance_full_offset_mm: Option<f64>,
}

/// Everything fixed after the start: wall, offsets, areas, who acts.
pub struct WallGeometry {
    shape: Wall,
    pub params: BarrierParams,
    /// The offset ξ before lowering (mm).
    offset: f64,
    /// Per node: offset ξᵢ and margin d̂ᵢ (mm), meaningful where `acts`.
    xi: Vec<f64>,
    dhat: Vec<f64>,
    acts: Vec<bool>,
    area: Vec<f64>,
    exempt: usize,
    narrowed: usize,
}

/// One node's share: energy, gradient and (when asked) Hessian; `None`
/// when inadmissible (s ≤ 0 for some pair).
type NodeEval = (f64, V3, Option<Matrix3<f64>>);

/// Hessian of the point–triangle distance with respect to the point, for
/// the closest feature: 0 over a face (d is linear there), the projection
/// off the edge and u over an edge, off u at a vertex; all over d.
fn dist_hessian(u: &V3, d: f64, feature: Feature, v: &[V3; 3]) -> Matrix3<f64> {
    let i3 = Matrix3::identity();
    match feature {
        Feature::Face => Matrix3::zeros(),
        Feature::Edge(k) => {
            let e = v[(k as usize + 2) % 3] - v[(k as usize + 1) % 3];
            let n = e.norm();
            if n > 0.0 {
                let e = e / n;
                (i3 - e * e.transpose() - u * u.transpose()) / d
            } else {
                (i3 - u * u.transpose()) / d
            }
        }
        Feature::Vertex(_) => (i3 - u * u.transpose()) / d,
    }
}

impl WallGeometry {
    /// `x`: the start; `tris`: the leaflets' triangles (for node areas);
    /// `free`: nodes with a free coordinate; `offset`: ξ (half the
    /// thickness).
    pub fn new(
        shape: Wall,
        x: &[V3],
        tris: &[[u32; 3]],
        free: &[bool],
        params: BarrierParams,
        offset: f64,
    ) -> WallGeometry {
        let mut area = vec![0.0; x.len()];
        for t in tris {
            let a = 0.5
                * (x[t[1] as usize] - x[t[0] as usize])
                    .cross(&(x[t[2] as usize] - x[t[0] as usize]))
                    .norm()
                / 3.0;
            for &i in t {
                area[i as usize] += a;
            }
        }
        // Per node: start distance (∞ beyond the search) and side
        // (+1 lumen, −1 beyond the wall, 0 on it or unknown).
        let start: Vec<(f64, f64)> = match &shape {
            Wall::Cylinder {
                origin,
                dir,
                radius,
            } => x
                .iter()
                .map(|p| {
                    let d = radius - Wall::radial(origin, dir, p).norm();
                    (d.abs(), d.signum() * (d != 0.0) as u8 as f64)
                })
                .collect(),
            Wall::Mesh {
                x: wx,
                tris: wt,
                bvh,
            } => {
                let raw: Vec<(f64, f64)> = (0..x.len())
                    .into_par_iter()
                    .with_min_len(64)
                    .map(|i| {
                        if !free[i] {
                            return (f64::INFINITY, 0.0);
                        }
                        mesh_start(&x[i], wx, wt, bvh)
                    })
                    .collect();
                // The mesh's orientation says which side is which: the
                // lumen is where most free nodes start.
                let pos = raw.iter().filter(|r| r.1 > 0.0).count();
                let neg = raw.iter().filter(|r| r.1 < 0.0).count();
                let lumen = if neg > pos { -1.0 } else { 1.0 };
                raw.into_iter().map(|(d, s)| (d, s * lumen)).collect()
            }
        };
        let mut xi = vec![offset; x.len()];
        let mut dhat = vec![params.dhat; x.len()];
        let mut acts = vec![false; x.len()];
        let (mut exempt, mut narrowed) = (0, 0);
        for i in 0..x.len() {
            if !free[i] {
                continue;
            }
            let (d0, side) = start[i];
            if d0.is_infinite() {
                acts[i] = true;
                continue;
            }
            if !(side > 0.0 && d0 > 0.0) {
                exempt += 1;
                continue;
            }
            acts[i] = true;
            if d0 < offset + params.dhat {
                xi[i] = offset.min(0.5 * d0);
                dhat[i] = d0 - xi[i];
                narrowed += 1;
            }
        }
        WallGeometry {
            shape,
            params,
            offset,
            xi,
            dhat,
            acts,
            area,
            exempt,
            narrowed,
        }
    }

    pub fn offsets(&self) -> &[f64] {
        &self.xi
    }

    pub fn margins(&self) -> &[f64] {
        &self.dhat
    }

    pub fn acts(&self) -> &[bool] {
        &self.acts
    }

    /// Node i's barrier at `y`.
    fn node_eval(&self, i: usize, y: &V3, want_hess: bool) -> Option<NodeEval> {
        let (xi, dhat) = (self.xi[i], self.dhat[i]);
        let ka = self.params.kappa * self.area[i];
        match &self.shape {
            Wall::Cylinder {
                origin,
                dir,
                radius,
            } => {
                let rv = Wall::radial(origin, dir, y);
                let r = rv.norm();
                let s = radius - r - xi;
                if !(s > 0.0) {
                    return None;
                }
                if s >= dhat {
                    return Some((0.0, V3::zeros(), want_hess.then(Matrix3::zeros)));
                }
                // s < d̂ < R − ξ, so r > 0.
                let rho = rv / r;
                let (b, b1, b2) = barrier::barrier(s, dhat);
                let g = -rho * (ka * b1);
                let h = want_hess.then(|| {
                    let perp = Matrix3::identity() - dir * dir.transpose() - rho * rho.transpose();
                    (rho * rho.transpose() * b2 - perp * (b1 / r)) * ka
                });
                Some((ka * b, g, h))
            }
            Wall::Mesh {
                x: wx,
                tris: wt,
                bvh,
            } => {
                let (mut e, mut g) = (0.0, V3::zeros());
                let mut h = want_hess.then(Matrix3::zeros);
                let mut ok = true;
                bvh.query_sphere(y, xi + dhat, |t| {
                    if !ok {
                        return;
                    }
                    let v = wt[t as usize].map(|k| wx[k as usize]);
                    let pr = barrier::proximity(y, &v[0], &v[1], &v[2]);
                    let s = pr.dist - xi;
                    if !(s > 0.0) {
                        ok = false;
                        return;
                    }
                    if s >= dhat {
                        return;
                    }
                    let (b, b1, b2) = barrier::barrier(s, dhat);
                    let u = pr.r / pr.dist;
                    e += ka * b;
                    g += u * (ka * b1);
                    if let Some(h) = h.as_mut() {
                        *h += (u * u.transpose() * b2
                            + dist_hessian(&u, pr.dist, pr.feature, &v) * b1)
                            * ka;
                    }
                });
                let finite = e.is_finite() && g.iter().all(|c| c.is_finite());
                (ok && finite).then_some((e, g, h))
            }
        }
    }

    /// The PSD part of node i's Hessian at `y` (see the module doc).
    fn node_psd(&self, i: usize, y: &V3) -> Option<Matrix3<f64>> {
        if let Wall::Cylinder { .. } = self.shape {
            return self.node_eval(i, y, true)?.2;
        }
        let Wall::Mesh {
            x: wx,
            tris: wt,
            bvh,
        } = &self.shape
        else {
            unreachable!("matched above")
        };
        let (xi, dhat) = (self.xi[i], self.dhat[i]);
        let ka = self.params.kappa * self.area[i];
        let mut h = Matrix3::zeros();
        let mut ok = true;
        bvh.query_sphere(y, xi + dhat, |t| {
            let v = wt[t as usize].map(|k| wx[k as usize]);
            let pr = barrier::proximity(y, &v[0], &v[1], &v[2]);
            let s = pr.dist - xi;
            if !(s > 0.0) {
                ok = false;
            } else if s < dhat {
                let u = pr.r / pr.dist;
                h += u * u.transpose() * (ka * barrier::barrier(s, dhat).2);
            }
        });
        (ok && h.iter().all(|c| c.is_finite())).then_some(h)
    }

    /// Node i's least s = d − ξᵢ over the wall within `reach` of it
    /// (∞ when none) and the number of pairs with s < d̂.
    fn node_gap(&self, i: usize, y: &V3, reach: f64) -> (f64, usize) {
        let xi = self.xi[i];
        match &self.shape {
            Wall::Cylinder {
                origin,
                dir,
                radius,
            } => {
                let s = radius - Wall::radial(origin, dir, y).norm() - xi;
                (s, (s < self.dhat[i]) as usize)
            }
            Wall::Mesh {
                x: wx,
                tris: wt,
                bvh,
            } => {
                let (mut m, mut n) = (f64::INFINITY, 0);
                bvh.query_sphere(y, xi + reach, |t| {
                    let v = wt[t as usize].map(|k| wx[k as usize]);
                    let s = barrier::proximity(y, &v[0], &v[1], &v[2]).dist - xi;
                    m = m.min(s);
                    n += (s < self.dhat[i]) as usize;
                });
                (m, n)
            }
        }
    }

    /// Largest fraction of node i's move `dx` from `y` keeping every pair's
    /// s above KEEP × its start value.
    fn node_max_step(&self, i: usize, y: &V3, dx: &V3) -> f64 {
        let m = dx.norm();
        if m == 0.0 {
            return 1.0;
        }
        let xi = self.xi[i];
        match &self.shape {
            Wall::Cylinder {
                origin,
                dir,
                radius,
            } => {
                // s(t) ≥ KEEP s₀ ⇔ |ρ₀ + t ρ_d|² ≤ r_max², a quadratic in t
                // that is negative at t = 0: the step may go to its
                // larger root.
                let r0 = Wall::radial(origin, dir, y);
                let rd = dx - dir * dx.dot(dir);
                let s0 = radius - r0.norm() - xi;
                if !(s0 > 0.0) {
                    return 0.0;
                }
                let rmax = radius - xi - KEEP * s0;
                let a = rd.norm_squared();
                if a == 0.0 {
                    return 1.0;
                }
                let b = 2.0 * r0.dot(&rd);
                let c = r0.norm_squared() - rmax * rmax;
                let disc = (b * b - 4.0 * a * c).max(0.0);
                // The larger root, written to avoid cancellation.
                let t = if b >= 0.0 {
                    -2.0 * c / (b + disc.sqrt())
                } else {
                    (-b + disc.sqrt()) / (2.0 * a)
                };
                t.clamp(0.0, 1.0)
            }
            Wall::Mesh {
                x: wx,
                tris: wt,
                bvh,
            } => {
                let mut tmin: f64 = 1.0;
                // A triangle farther than m / (1 − KEEP) keeps its share.
                bvh.query_sphere(y, xi + m / (1.0 - KEEP), |t| {
                    let v = wt[t as usize].map(|k| wx[k as usize]);
                    let q = [*y, v[0], v[1], v[2]];
                    let s = barrier::proximity(y, &v[0], &v[1], &v[2]).dist - xi;
                    if s >= m / (1.0 - KEEP) {
                        return;
                    }
                    let dq = [*dx, V3::zeros(), V3::zeros(), V3::zeros()];
                    let toi = barrier::additive_toi(&q, &dq, xi, KEEP, CCD_ITER, m, |p| {
                        barrier::proximity(&p[0], &p[1], &p[2], &p[3]).dist
                    });
                    tmin = tmin.min(toi);
                });
                tmin
            }
        }
    }

    /// Per acting node, `f(i)`, in parallel, in node order.
    fn per_node<R: Send>(&self, f: impl Fn(usize) -> R + Sync) -> Vec<(usize, R)> {
        (0..self.acts.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&i| self.acts[i])
            .map(|i| (i, f(i)))
            .collect()
    }

    /// [`WALL_BIT`] on the acting nodes within the margin of the wall.
    pub fn mask(&self, x: &[V3]) -> Vec<u8> {
        let mut m = vec![0u8; x.len()];
        for (i, (s, _)) in self.per_node(|i| self.node_gap(i, &x[i], self.dhat[i])) {
            if s < self.dhat[i] {
                m[i] |= WALL_BIT;
            }
        }
        m
    }

    /// The record of the term at `x` (the final state).
    pub fn summary(&self, x: &[V3]) -> WallSummary {
        let reach = START_SEARCH_MM;
        let gaps = self.per_node(|i| self.node_gap(i, &x[i], reach));
        let mut out = WallSummary {
            wall: match self.shape {
                Wall::Cylinder { .. } => "cylinder",
                Wall::Mesh { .. } => "mesh",
            },
            offset_mm: self.offset,
            margin_mm: self.params.dhat,
            kappa_n_per_mm3: self.params.kappa,
            acting_nodes: self.acts.iter().filter(|&&a| a).count(),
            exempt_nodes: self.exempt,
            started_within_margin: self.narrowed,
            nodes_touching: 0,
            pairs_touching: 0,
            min_distance_mm: None,
            min_distance_full_offset_mm: None,
        };
        for (i, (s, n)) in gaps {
            if s < self.dhat[i] {
                out.nodes_touching += 1;
            }
            out.pairs_touching += n;
            if s.is_finite() {
                let d = s + self.xi[i];
                let least = |m: Option<f64>| Some(m.map_or(d, |m: f64| m.min(d)));
                out.min_distance_mm = least(out.min_distance_mm);
                if self.xi[i] == self.offset {
                    out.min_distance_full_offset_mm = least(out.min_distance_full_offset_mm);
                }
            }
        }
        out
    }
}

/// A node's start distance to the mesh wall (∞ beyond the search) and its
/// side by the mesh's orientation: the sign of Σ (x − p)·n over the
/// triangles at that distance (one over a face; at an edge the two faces'
/// normals sum to its pseudo-normal).
fn mesh_start(p: &V3, wx: &[V3], wt: &[[u32; 3]], bvh: &Bvh) -> (f64, f64) {
    let mut r = 0.5;
    while r <= START_SEARCH_MM {
        let mut near: Vec<(f64, f64)> = vec![];
        bvh.query_sphere(p, r, |t| {
            let v = wt[t as usize].map(|k| wx[k as usize]);
            let c = closest_point(p, &v[0], &v[1], &v[2]);
            let n = (v[1] - v[0]).cross(&(v[2] - v[0]));
            let nn = n.norm();
            let side = if nn > 0.0 {
                (p - c.point).dot(&n) / nn
            } else {
                0.0
            };
            near.push(((p - c.point).norm(), side));
        });
        let d0 = near.iter().map(|n| n.0).fold(f64::INFINITY, f64::min);
        if d0 <= r {
            let tol = 1e-9 * (1.0 + d0);
            let side: f64 = near.iter().filter(|n| n.0 <= d0 + tol).map(|n| n.1).sum();
            let sign = if side > 0.0 {
                1.0
            } else if side < 0.0 {
                -1.0
            } else {
                0.0
            };
            return (d0, sign);
        }
        r *= 2.0;
    }
    (f64::INFINITY, 0.0)
}

/// The term: a shared [`WallGeometry`] and the solver's wishes. It keeps
/// no state between updates (candidates are found where each node is).
pub struct WallBarrier {
    geo: Arc<WallGeometry>,
    projected: bool,
}

impl WallBarrier {
    pub fn new(geo: Arc<WallGeometry>) -> WallBarrier {
        WallBarrier {
            geo,
            projected: false,
        }
    }

    pub fn geometry(&self) -> &Arc<WallGeometry> {
        &self.geo
    }
}

impl Term for WallBarrier {
    fn name(&self) -> &'static str {
        "wall-barrier"
    }

    /// +∞ when a node is at or beyond its offset (the line search refuses
    /// such a state).
    fn energy(&self, x: &[V3]) -> Option<f64> {
        let g = &self.geo;
        let mut e = 0.0;
        // A sum in node order: the same whatever the thread count.
        for (_, v) in g.per_node(|i| g.node_eval(i, &x[i], false).map(|r| r.0)) {
            match v {
                Some(v) => e += v,
                None => return Some(f64::INFINITY),
            }
        }
        Some(e)
    }

    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        let g = &self.geo;
        for (i, v) in g.per_node(|i| g.node_eval(i, &x[i], false)) {
            if let Some((_, grad, _)) = v {
                f[i] -= grad;
            }
        }
    }

    fn add_tangent(&self, x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        let g = &self.geo;
        let blocks = g.per_node(|i| {
            if self.projected {
                g.node_psd(i, &x[i])
            } else {
                g.node_eval(i, &x[i], true).and_then(|r| r.2)
            }
        });
        for (i, h) in blocks {
            if let Some(h) = h.filter(|h| h.iter().any(|&v| v != 0.0)) {
                pat.add_block(dofs, vals, &[i as u32], &h);
            }
        }
    }

    fn set_projected(&mut self, projected: bool) {
        self.projected = projected;
    }

    fn contact_mask(&self, x: &[V3]) -> Option<Vec<u8>> {
        Some(self.geo.mask(x))
    }

    fn max_step(&self, x: &[V3], dx: &[V3]) -> f64 {
        let g = &self.geo;
        if dx.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
            return 0.0;
        }
        g.per_node(|i| g.node_max_step(i, &x[i], &dx[i]))
            .into_iter()
            // min is exact in any order.
            .fold(1.0, |a, (_, t)| a.min(t))
    }

    fn admissible(&self, x: &[V3]) -> bool {
        let g = &self.geo;
        g.per_node(|i| g.node_eval(i, &x[i], false).is_some())
            .iter()
            .all(|v| v.1)
    }
}

#[cfg(test)]
#[path = "wall_barrier_tests.rs"]
mod tests;
