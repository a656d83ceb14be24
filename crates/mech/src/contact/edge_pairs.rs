//! The edge–edge half of the leaflet barrier: which edges of different
//! leaflets are paired, their weights and offsets, their energy, forces,
//! tangent and collision-free step (`edge_barrier.rs` for one pair).
//!
//! # Weight
//!
//! Each edge carries w_e = a third of its (one or two) triangles' rest
//! areas, a pair (w_a + w_b)/2 (symmetric in the leaflets). The edge
//! weights sum to the mesh area, as the node areas of the node–triangle
//! pairs do, so neither kind of pair dominates: between two parallel
//! sheets at gap s each edge crosses two or three of the other sheet's
//! edges at distance s, and the edge pairs add roughly as much pressure
//! as the node pairs (the sheets rest somewhat wider apart than
//! `BarrierParams::from_pressure`'s d̂/2, still inside the margin).
//!
//! # Pairs
//!
//! Each unordered pair once (the lower edge number lists the higher),
//! edges of the same leaflet never (so no pair shares a node). A pair of
//! two edges that both end on the suture line is left out: such edges meet
//! only at the commissures, where the leaflets are sewn side by side onto
//! the same wall points; their distance there is set by the suturing (on
//! the sample down to 0 at a shared suture point, an inadmissible start),
//! not by contact, and the node–triangle pairs of their free nodes still
//! act. Candidates are the pairs within ξ + d̂ + reach where the leaflet
//! barrier's lists were found, through the triangle tree (an edge is
//! reached when one of its triangles is); the leaflet barrier keeps them.
//!
//! # Offsets
//!
//! As for the nodes: where an edge starts within ξ + d̂ of an edge of
//! another leaflet (sewn side by side at the commissures) its offset is
//! lowered to d₀ − d̂, but not below d₀/2; a pair uses the smaller of its
//! edges' offsets, so every start state is admissible and unforced.

use rayon::prelude::*;

use super::barrier::{BarrierParams, CCD_ITER, Hess12, KEEP, least_near, start_offset};
use super::edge_barrier::{self, mollifier_eps};
use crate::element::V3;
use crate::sparse::{Dofs, Pattern};
use coapt_geom::bvh::{Aabb, Bvh};
use coapt_geom::segment_distance::SegProximity;

pub struct EdgePairs {
    edges: Vec<[u32; 2]>,
    body: Vec<u16>,
    weight: Vec<f64>,
    rest_len2: Vec<f64>,
    xi: Vec<f64>,
    /// A node of the edge is fixed (on the suture line).
    fixed: Vec<bool>,
    tri_edges: Vec<[u32; 3]>,
    /// The lowest-numbered triangle of each edge: a pair is found once,
    /// from its two edges' owners.
    owner: Vec<u32>,
    /// Pairs within the margin at the last update (the tangent's).
    active: Vec<(u32, u32)>,
}

/// A pair's forces are those of one acting pair.
type Acting = (u32, u32, f64, [V3; 4]);

/// A candidate pair (lower edge, higher edge) and its s = d − ξ at the
/// state its list was found at.
pub type Cand = (u32, u32, f64);

/// Below this (mm) a lower bound of s is not trusted to rule a pair out:
/// far above the round-off of the bound, far below any s that matters.
const BOUND_MARGIN: f64 = 1e-9;

/// Per node, how far it moved from `x0` (the candidates' state) to `x`;
/// ∞ when `x0` is not a state of the same mesh (nothing is ruled out).
fn moves(x0: &[V3], x: &[V3]) -> Vec<f64> {
    if x0.len() != x.len() {
        return vec![f64::INFINITY; x.len()];
    }
    x0.par_iter()
        .with_min_len(1024)
        .zip(x.par_iter())
        .map(|(p, q)| (q - p).norm())
        .collect()
}

impl EdgePairs {
    pub fn new(
        x: &[V3],
        tris: &[[u32; 3]],
        tri_body: &[u16],
        node_fixed: &[bool],
        bvh: &Bvh,
        params: &BarrierParams,
        xi: f64,
    ) -> EdgePairs {
        let mut keyed: Vec<([u32; 2], u32)> = Vec::with_capacity(3 * tris.len());
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                keyed.push(([a.min(b), a.max(b)], t as u32));
            }
        }
        keyed.sort_unstable();
        let mut edges: Vec<[u32; 2]> = vec![];
        let mut body = vec![];
        let mut weight = vec![];
        let mut tri_edges = vec![[0u32; 3]; tris.len()];
        let mut slot = vec![0u8; tris.len()];
        let mut owner = vec![];
        for (e, t) in keyed {
            if edges.last() != Some(&e) {
                // Sorted by (edge, triangle): the first is the lowest.
                owner.push(t);
                edges.push(e);
                body.push(tri_body[t as usize]);
                weight.push(0.0);
            }
            let id = (edges.len() - 1) as u32;
            let v = tris[t as usize].map(|i| x[i as usize]);
            weight[id as usize] += 0.5 * (v[1] - v[0]).cross(&(v[2] - v[0])).norm() / 3.0;
            tri_edges[t as usize][slot[t as usize] as usize] = id;
            slot[t as usize] += 1;
        }
        let rest_len2 = edges
            .iter()
            .map(|e| (x[e[1] as usize] - x[e[0] as usize]).norm_squared())
            .collect();
        let fixed = edges
            .iter()
            .map(|e| node_fixed[e[0] as usize] || node_fixed[e[1] as usize])
            .collect();
        let mut me = EdgePairs {
            edges,
            body,
            weight,
            rest_len2,
            xi: vec![],
            fixed,
            tri_edges,
            owner,
            active: vec![],
        };
        let dmin = least_near(
            bvh,
            me.edges.len(),
            |a| me.sphere(x, a as u32, xi + params.dhat),
            |a, t| {
                me.least_over(t, a as u32, |b| {
                    edge_barrier::proximity(&me.quad(x, a as u32, b)).dist
                })
            },
        );
        me.xi = dmin
            .into_iter()
            .map(|d| start_offset(xi, params.dhat, d))
            .collect();
        me
    }

    fn quad(&self, x: &[V3], a: u32, b: u32) -> [V3; 4] {
        let (ea, eb) = (self.edges[a as usize], self.edges[b as usize]);
        [
            x[ea[0] as usize],
            x[ea[1] as usize],
            x[eb[0] as usize],
            x[eb[1] as usize],
        ]
    }

    fn nodes(&self, a: u32, b: u32) -> [u32; 4] {
        let (ea, eb) = (self.edges[a as usize], self.edges[b as usize]);
        [ea[0], ea[1], eb[0], eb[1]]
    }

    /// A lower bound of the pair's s at a state whose nodes moved `mv`
    /// from where the pair had `s0`: the distance of two segments falls by
    /// at most the largest move of each one's ends.
    fn s_below(&self, mv: &[f64], a: u32, b: u32, s0: f64) -> f64 {
        let (ea, eb) = (self.edges[a as usize], self.edges[b as usize]);
        s0 - (mv[ea[0] as usize].max(mv[ea[1] as usize])
            + mv[eb[0] as usize].max(mv[eb[1] as usize]))
    }

    fn pair_xi(&self, a: u32, b: u32) -> f64 {
        self.xi[a as usize].min(self.xi[b as usize])
    }

    fn eps(&self, a: u32, b: u32) -> f64 {
        mollifier_eps(self.rest_len2[a as usize], self.rest_len2[b as usize])
    }

    fn pair_weight(&self, a: u32, b: u32) -> f64 {
        0.5 * (self.weight[a as usize] + self.weight[b as usize])
    }

    /// The query sphere of edge `a` at `x` holding every point within `r`
    /// of the edge.
    fn sphere(&self, x: &[V3], a: u32, r: f64) -> (V3, f64) {
        let e = self.edges[a as usize];
        let (p, q) = (x[e[0] as usize], x[e[1] as usize]);
        ((p + q) * 0.5, r + 0.5 * (q - p).norm())
    }

    /// The least of `f(b)` over the edges b that triangle `t` owns and
    /// that can pair with `a`; ∞
    /// when none. An edge whose distance to `a` is below a radius is found
    /// through its owner as well as its other triangle (its box is inside
    /// both), so each edge is met once.
    fn least_over(&self, t: u32, a: u32, f: impl Fn(u32) -> f64) -> f64 {
        let mut m = f64::INFINITY;
        for b in self.tri_edges[t as usize] {
            if self.owner[b as usize] == t
                && self.body[b as usize] != self.body[a as usize]
                && !(self.fixed[a as usize] && self.fixed[b as usize])
            {
                m = m.min(f(b));
            }
        }
        m
    }

    /// The pairs with s < d̂ + `reach` at `y` (`bvh` fitted to a state
    /// within `slack` of `y`: both triangles of a pair may have moved that
    /// far from their boxes). Searched per triangle rather than per edge
    /// (a third fewer tree queries) and kept per owner pair, so no pair is
    /// met twice and nothing needs sorting; the order follows the
    /// triangles and the tree, both fixed by the states: thread-independent.
    pub fn find(
        &self,
        y: &[V3],
        bvh: &Bvh,
        params: &BarrierParams,
        reach: f64,
        slack: f64,
    ) -> Vec<Cand> {
        let xi_max = self.xi.iter().fold(0.0, |m: f64, &v| m.max(v));
        let r = xi_max + params.dhat + reach + 2.0 * slack;
        let (mid, half) = self.spheres(y);
        let tris = bvh.len() as u32;
        let per: Vec<Vec<Cand>> = (0..tris)
            .into_par_iter()
            .with_min_len(32)
            .map(|ta| {
                let mut out = vec![];
                let own: Vec<u32> = self.tri_edges[ta as usize]
                    .into_iter()
                    .filter(|&a| self.owner[a as usize] == ta)
                    .collect();
                if own.is_empty() {
                    return out;
                }
                let body = self.body[own[0] as usize];
                let bx = bvh.tri_box(ta);
                let query = Aabb {
                    min: bx.min - V3::repeat(r),
                    max: bx.max + V3::repeat(r),
                };
                bvh.query_aabb_apart(&query, body, |tb| {
                    for b in self.tri_edges[tb as usize] {
                        if self.owner[b as usize] != tb || self.body[b as usize] == body {
                            continue;
                        }
                        for &a in &own {
                            // The pair is met from both owners: kept from
                            // the lower edge's.
                            if a > b {
                                continue;
                            }
                            let (lo, hi) = (a, b);
                            if self.fixed[lo as usize] && self.fixed[hi as usize] {
                                continue;
                            }
                            let far = params.dhat + reach + self.pair_xi(lo, hi);
                            let gap = (mid[lo as usize] - mid[hi as usize]).norm()
                                - half[lo as usize]
                                - half[hi as usize];
                            if gap >= far {
                                continue;
                            }
                            let q = self.quad(y, lo, hi);
                            let s = edge_barrier::proximity(&q).dist - self.pair_xi(lo, hi);
                            if s < params.dhat + reach {
                                out.push((lo, hi, s));
                            }
                        }
                    }
                });
                out
            })
            .collect();
        per.into_iter().flatten().collect()
    }

    /// Keeps the pairs of `cand` within the margin at `x` for the tangent.
    pub fn set_active(&mut self, x: &[V3], x0: &[V3], cand: &[Cand], params: &BarrierParams) {
        let (mid, half) = self.spheres(x);
        let mv = moves(x0, x);
        self.active = cand
            .par_iter()
            .with_min_len(256)
            .filter(|&&c| self.within_reach(&mv, &mid, &half, x, params, c).is_some())
            .map(|&(a, b, _)| (a, b))
            .collect();
    }

    /// A candidate pair that acts at `x` (s < d̂), with its points,
    /// proximity and offset; `None` when the bound from its distance at
    /// discovery, the edges' spheres or the exact distance rule it out.
    /// `mv`, `mid`, `half`: [`moves`] and [`EdgePairs::spheres`] at `x`.
    fn within_reach(
        &self,
        mv: &[f64],
        mid: &[V3],
        half: &[f64],
        x: &[V3],
        params: &BarrierParams,
        (a, b, s0): Cand,
    ) -> Option<([V3; 4], SegProximity, f64)> {
        if self.s_below(mv, a, b, s0) >= params.dhat + BOUND_MARGIN {
            return None;
        }
        let xi = self.pair_xi(a, b);
        let gap = (mid[a as usize] - mid[b as usize]).norm() - half[a as usize] - half[b as usize];
        if gap - xi >= params.dhat {
            return None;
        }
        let q = self.quad(x, a, b);
        let pr = edge_barrier::proximity(&q);
        (!(pr.dist - xi >= params.dhat)).then_some((q, pr, xi))
    }

    /// Per edge its midpoint and half length at `x`: a pair whose spheres
    /// are farther apart than a distance is farther apart too.
    fn spheres(&self, x: &[V3]) -> (Vec<V3>, Vec<f64>) {
        self.edges
            .par_iter()
            .with_min_len(256)
            .map(|e| {
                let (p, q) = (x[e[0] as usize], x[e[1] as usize]);
                ((p + q) * 0.5, 0.5 * (q - p).norm())
            })
            .unzip()
    }

    pub fn active_len(&self) -> usize {
        self.active.len()
    }

    /// The candidate pairs within the margin at `x` with their energy and
    /// gradient blocks, in candidate order; `None` when a pair has s ≤ 0.
    pub fn acting(
        &self,
        cand: &[Cand],
        x0: &[V3],
        x: &[V3],
        params: &BarrierParams,
    ) -> Option<Vec<Acting>> {
        let (mid, half) = self.spheres(x);
        let mv = moves(x0, x);
        let v: Vec<Option<Acting>> = cand
            .par_iter()
            .with_min_len(256)
            .filter_map(|&c| {
                let (a, b, _) = c;
                let (q, pr, xi) = self.within_reach(&mv, &mid, &half, x, params, c)?;
                let r = edge_barrier::pair_eval_at(
                    &q,
                    &pr,
                    xi,
                    self.pair_weight(a, b),
                    self.eps(a, b),
                    params,
                    false,
                );
                Some(r.map(|(e, g, _)| (a, b, e, g)))
            })
            .collect();
        v.into_iter().collect()
    }

    /// `e0` plus the energy of the candidate pairs at `x`, added in
    /// candidate order (as [`EdgePairs::acting`] lists them); `None` when a
    /// pair has s ≤ 0.
    pub fn energy(
        &self,
        cand: &[Cand],
        x0: &[V3],
        x: &[V3],
        params: &BarrierParams,
        e0: f64,
    ) -> Option<f64> {
        let (mid, half) = self.spheres(x);
        let mv = moves(x0, x);
        let v: Vec<Option<f64>> = cand
            .par_iter()
            .with_min_len(256)
            .map(|&c| {
                let (a, b, _) = c;
                let Some((q, pr, xi)) = self.within_reach(&mv, &mid, &half, x, params, c) else {
                    return Some(0.0);
                };
                let r = edge_barrier::pair_eval_at(
                    &q,
                    &pr,
                    xi,
                    self.pair_weight(a, b),
                    self.eps(a, b),
                    params,
                    false,
                )?;
                Some(r.0)
            })
            .collect();
        let mut e = e0;
        for p in v {
            e += p?;
        }
        Some(e)
    }

    /// Adds −gradient of the acting pairs to `f`.
    pub fn add_force(&self, acting: &[Acting], f: &mut [V3]) {
        for &(a, b, _, g) in acting {
            for (k, n) in self.nodes(a, b).into_iter().enumerate() {
                f[n as usize] -= g[k];
            }
        }
    }

    pub fn couplings(&self, out: &mut Vec<[u32; 2]>) {
        // Each edge's own two nodes are a mesh edge already.
        for &(a, b) in &self.active {
            for i in self.edges[a as usize] {
                for j in self.edges[b as usize] {
                    out.push([i, j]);
                }
            }
        }
    }

    pub fn add_tangent(
        &self,
        x: &[V3],
        params: &BarrierParams,
        projected: bool,
        dofs: &Dofs,
        pat: &Pattern,
        vals: &mut [f64],
    ) {
        let blocks: Vec<Option<Hess12>> = self
            .active
            .par_iter()
            .with_min_len(16)
            .map(|&(a, b)| {
                let q = self.quad(x, a, b);
                let (xi, w, eps) = (self.pair_xi(a, b), self.pair_weight(a, b), self.eps(a, b));
                if projected {
                    return edge_barrier::pair_gauss_newton(&q, xi, w, eps, params);
                }
                edge_barrier::pair_eval(&q, xi, w, eps, params, true)?.2
            })
            .collect();
        for (&(a, b), h) in self.active.iter().zip(blocks) {
            if let Some(h) = h {
                pat.add_block(dofs, vals, &self.nodes(a, b), &h);
            }
        }
    }

    /// Largest fraction of `dx` from `x` keeping every pair's s above
    /// `KEEP` × its start value, `cand` holding every pair that could lose
    /// more.
    pub fn max_step(&self, cand: &[Cand], x0: &[V3], x: &[V3], dx: &[V3]) -> f64 {
        let moved = |e: [u32; 2]| dx[e[0] as usize].norm().max(dx[e[1] as usize].norm());
        // A pair's distance falls by at most its edges' largest moves: one
        // farther than those moves / (1 − KEEP) keeps its share; the gap
        // of the edges' spheres is a lower bound of the distance that
        // rules most pairs out without one.
        let (mid, half) = self.spheres(x);
        let mv = moves(x0, x);
        cand.par_iter()
            .with_min_len(256)
            .map(|&(a, b, s0)| {
                let xi = self.pair_xi(a, b);
                let m = moved(self.edges[a as usize]) + moved(self.edges[b as usize]);
                if self.s_below(&mv, a, b, s0) >= m / (1.0 - KEEP) + BOUND_MARGIN {
                    return 1.0;
                }
                let gap = (mid[a as usize] - mid[b as usize]).norm()
                    - half[a as usize]
                    - half[b as usize];
                if gap - xi >= m / (1.0 - KEEP) {
                    return 1.0;
                }
                let q = self.quad(x, a, b);
                if edge_barrier::proximity(&q).dist - xi >= m / (1.0 - KEEP) {
                    return 1.0;
                }
                let dq = self.nodes(a, b).map(|i| dx[i as usize]);
                edge_barrier::toi(&q, &dq, xi, KEEP, CCD_ITER)
            })
            .reduce(|| 1.0, f64::min)
    }
}
