//! Leaflet-to-leaflet contact as a [`Term`]: the barrier of `barrier.rs`
//! between every node and every triangle of every other leaflet within
//! reach (IPC's sum over point–triangle pairs).
//!
//! Why a sum and not the barrier of the distance to the other leaflet's
//! surface (the minimum over its triangles): that distance is not smooth
//! where the other leaflet folds towards the node (two faces both project
//! the node inside, the minimum switches between them with a kink in the
//! force); on the sample a node in such a fold swung between two faces by
//! 5 µm per iteration and the residual stalled at 3 mN. Each pair's
//! distance is C¹ across its closest-point regions, so the sum is too. The
//! price: a node near an edge or vertex of the other leaflet counts the
//! triangles around it, so the barrier is stiffer there than over a face
//! and the contact gap under a given pressure a little smaller; κ is set
//! for one face per node ([`BarrierParams::from_pressure`]). Every node
//! meets every other leaflet in the same way, so the term is symmetric in
//! the leaflets.
//!
//! # Offset
//!
//! The barrier acts for mid-surface distances d in (ξ, ξ + d̂). Two
//! touching leaflets have their mid-surfaces a thickness t apart. κ is set
//! so that two parallel sheets pressed by the closing pressure rest at
//! s = d − ξ = d̂/2 ([`BarrierParams::from_pressure`]), so the closure
//! passes ξ = t − d̂/2: pressed at the closing pressure the mid-surfaces sit
//! a thickness apart, pressed less they sit up to d̂/2 farther (the sheets
//! begin to feel each other d̂/2 before they touch), pressed more up to
//! d̂/2 closer (the tissue compressed). With ξ = t they rested a margin and
//! more beyond the thickness (0.65–0.75 mm for 0.5 mm leaflets): on the
//! sample (GOH, h 0.5 mm) the coaptation height was 6.66 mm against
//! 6.90 mm for the planes offset by half the thickness (the same
//! thickness between the sheets) and 7.29 mm for the planes through the
//! axis; with ξ = t − d̂/2 it is 6.87 mm. ξ = t − d̂ (force only once the
//! surfaces touch) gave 7.03 mm but the exact-tangent Newton stalled (101
//! iterations instead of 34): −b′ ∇²d grows as the offset shrinks. On a
//! mesh a node also feels the faces around the one below it (ξ is large
//! against d̂), so the sheets rest somewhat wider than d̂/2.
//!
//! # Candidates
//!
//! The pairs with s < d̂ + R at the state `Lists::x0` they were found at
//! are listed; at a state y with 2 max |y − x0| ≤ R every pair with s < d̂
//! is among them (a pair's distance falls by at most the moves of its two
//! sides), so energy and forces there are exact; a state beyond that is
//! searched afresh. The lists are kept across updates while they cover a
//! step of twice the last one, and found again with R = 8 × the last step
//! (0.1 mm to `reach`) otherwise: near convergence the steps are short and
//! the lists short and seldom rebuilt. [`Term::max_step`] cuts a step to
//! what the lists cover (the next update widens them).
//!
//! Edges of different leaflets are paired too (`edge_pairs.rs`, IPC's
//! edge–edge pairs): node–triangle pairs do not see an edge of one leaflet
//! come across an edge of another, so without them only the crossing test
//! below stood in the way of such a step.
//!
//! No interpenetration holds by construction: [`Term::max_step`] shortens a
//! step so that no node–triangle or edge–edge distance falls below
//! ξ + 0.1 s (additive CCD against everything it could reach), and
//! [`Term::admissible`] rejects a state where triangles of different
//! leaflets cross (exact triangle–triangle tests) that did not cross at the
//! start, with one exception: two triangles that both have a sutured node.
//! Those meet only at the commissures, where two leaflets are sewn onto
//! the same wall points (on the sample, edges of neighbouring leaflets
//! that both end on the suture line start 0 to 0.4 µm apart): edges
//! fanning out of two such points cross as soon as either turns, no offset
//! can keep them apart, and every step was refused there. That, not a
//! missing edge pair, was what stalled the sample (GOH, h 0.5 mm, sutured
//! first) at 0.36 N: with the exception alone it converges as well. It is
//! the rule of leaflets.json (`geom::crossings`), by which `closure.json`
//! judges the final state too: those pairs are counted as `sewn_contacts`,
//! every other pair as a crossing (on the sample and the real CT the sewn
//! ones meet in a point at the post, the sutured nodes of both leaflets
//! 0–18 µm apart there). A crossing the start had stays tolerated so that
//! the solve can run; `close_on` fails a final state that still has one.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use super::barrier::{
    self, BarrierParams, CCD_ITER, Hess12, KEEP, Proximity, least_near, start_offset,
};
use super::edge_pairs::{Cand, EdgePairs};
use crate::element::V3;
use crate::sparse::{Dofs, Pattern};
use crate::system::Term;
use coapt_geom::bvh::{Aabb, Bvh};
use coapt_geom::tri_tri;

#[derive(Debug, Clone, Copy)]
struct Group {
    node: u32,
    body: u16,
    /// Candidate triangles: `cand[start..end]`, ascending.
    start: u32,
    end: u32,
}

/// Candidate pairs and where they were found: every node–triangle and
/// edge–edge pair with s < d̂ + `reach` at `x0` is listed, so at any state
/// y with 2 max |y − x0| ≤ `reach` every pair with s < d̂ is (a pair's
/// distance falls by at most the moves of its two sides).
struct Lists {
    reach: f64,
    x0: Vec<V3>,
    groups: Vec<Group>,
    cand: Vec<u32>,
    edge_cand: Vec<Cand>,
}

impl Lists {
    /// Largest nodal move from `x0` to `y`.
    fn moved(&self, y: &[V3]) -> f64 {
        largest_move(&self.x0, y)
    }

    fn covers(&self, y: &[V3]) -> bool {
        2.0 * self.moved(y) <= self.reach
    }
}

/// max_i |b_i − a_i| (exact in any order).
fn largest_move(a: &[V3], b: &[V3]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.par_iter()
        .with_min_len(1024)
        .zip(b.par_iter())
        .map(|(p, q)| (q - p).norm())
        .reduce(|| 0.0, f64::max)
}

/// Shortest reach the lists are built with (mm): below it a rebuild costs
/// more than the pairs it saves.
const MIN_REACH: f64 = 0.1;

/// The lists are built to hold for about this many steps of the last
/// step's size (a reach of 8 steps: a step up to twice the last one, plus
/// the moves since the build).
const REACH_PER_STEP: f64 = 8.0;

pub struct LeafletBarrier {
    tris: Vec<[u32; 3]>,
    node_body: Vec<u16>,
    tri_body: Vec<u16>,
    node_area: Vec<f64>,
    /// Offset ξ per node (mm).
    xi: Vec<f64>,
    node_fixed: Vec<bool>,
    pub params: BarrierParams,
    /// Largest reach of the lists (mm).
    reach: f64,
    bvh: Bvh,
    build_cost: f64,
    /// The state the tree is fitted to (the last update's).
    x_fit: Vec<V3>,
    /// Largest nodal move between the last two updates (∞ before).
    last_move: f64,
    /// The largest nodal move of the last step [`Term::max_step`] had to
    /// cut (f64 bits; 0: none since the update): what the lists should
    /// have covered.
    cut_from: AtomicU64,
    lists: Lists,
    /// Wider lists for the step being taken (found by [`Term::max_step`]
    /// when `lists` do not cover it) or for the last trial state beyond
    /// both; dropped at the next update. Which lists serve a state never
    /// changes a result: every one holds the same acting pairs in the same
    /// order.
    spare: Mutex<Option<Arc<Lists>>>,
    /// Pairs of `lists` within the margin at the last update (the
    /// couplings of the tangent).
    active: Vec<(u32, u32)>,
    /// Crossing triangle pairs of the start (placement), tolerated.
    start_crossings: Vec<(u32, u32)>,
    projected: bool,
    edges: EdgePairs,
}

/// The triangle tree, labelled by leaflet (queries skip a leaflet's own
/// subtrees: on a closing valve most of what lies within reach of an item
/// is its own leaflet).
fn tree(x: &[V3], tris: &[[u32; 3]], tri_body: &[u16]) -> Bvh {
    let mut b = Bvh::build(x, tris);
    b.set_groups(tri_body);
    b
}

/// Per triangle at `x` a ball holding it: (centroid, largest distance of a
/// vertex from it). A node farther than r + b from the centre is farther
/// than b from the triangle: most candidate pairs are ruled out by that
/// before their closest point is sought.
fn tri_balls(x: &[V3], tris: &[[u32; 3]]) -> Vec<(V3, f64)> {
    tris.par_iter()
        .with_min_len(256)
        .map(|t| {
            let v = t.map(|k| x[k as usize]);
            let c = (v[0] + v[1] + v[2]) / 3.0;
            let r2 = (v[0] - c)
                .norm_squared()
                .max((v[1] - c).norm_squared())
                .max((v[2] - c).norm_squared());
            (c, r2.sqrt())
        })
        .collect()
}

/// Node `p` is certainly at least `b` from the triangle of `ball` (with a
/// relative margin far above the round-off of the test, so a pair this
/// rules out is one the exact distance rules out too).
#[inline]
fn beyond(ball: &(V3, f64), p: &V3, b: f64) -> bool {
    let lim = (ball.1 + b) * (1.0 + 1e-9);
    (p - ball.0).norm_squared() > lim * lim
}

/// Reference lumped node areas (mm²): a third of the incident areas.
fn node_areas(x: &[V3], tris: &[[u32; 3]]) -> Vec<f64> {
    let mut a = vec![0.0; x.len()];
    for t in tris {
        let ar = 0.5
            * (x[t[1] as usize] - x[t[0] as usize])
                .cross(&(x[t[2] as usize] - x[t[0] as usize]))
                .norm()
            / 3.0;
        for &i in t {
            a[i as usize] += ar;
        }
    }
    a
}

impl LeafletBarrier {
    /// `x`: the start (must be the state the solver starts from); `xi`: the
    /// mid-surface offset (thickness); `fixed`: nodes with no free
    /// coordinate; `reach`: the largest reach of the candidate lists (twice
    /// the step the lists must cover). Where a node starts closer than
    /// ξ + d̂ to another leaflet (sewn side by side at the commissures) its
    /// offset is lowered to d₀ − d̂ (no force at the start), but not below
    /// d₀/2: every start is admissible.
    pub fn new(
        x: &[V3],
        tris: &[[u32; 3]],
        tri_body: &[u16],
        fixed: &[bool],
        params: BarrierParams,
        xi: f64,
        reach: f64,
    ) -> LeafletBarrier {
        let mut node_body = vec![0u16; x.len()];
        for (t, b) in tris.iter().zip(tri_body) {
            for &i in t {
                node_body[i as usize] = *b;
            }
        }
        let bvh = tree(x, tris, tri_body);
        let mut me = LeafletBarrier {
            tris: tris.to_vec(),
            node_body,
            tri_body: tri_body.to_vec(),
            node_area: node_areas(x, tris),
            xi: vec![xi; x.len()],
            node_fixed: fixed.to_vec(),
            params,
            reach,
            build_cost: bvh.cost(),
            x_fit: x.to_vec(),
            last_move: f64::INFINITY,
            cut_from: AtomicU64::new(0),
            lists: Lists {
                reach: 0.0,
                x0: vec![],
                groups: vec![],
                cand: vec![],
                edge_cand: vec![],
            },
            spare: Mutex::new(None),
            active: vec![],
            start_crossings: vec![],
            projected: false,
            edges: EdgePairs::new(x, tris, tri_body, fixed, &bvh, &params, xi),
            bvh,
        };
        // Offsets from the start distances (ξ + d̂ is the farthest that can
        // lower one).
        let dmin = least_near(
            &me.bvh,
            x.len(),
            |i| (x[i], xi + params.dhat),
            |i, t| {
                if me.skip(i as u32, t) {
                    return f64::INFINITY;
                }
                let v = me.tris[t as usize].map(|k| x[k as usize]);
                barrier::proximity(&x[i], &v[0], &v[1], &v[2]).dist
            },
        );
        me.xi = dmin
            .into_iter()
            .map(|d| start_offset(xi, params.dhat, d))
            .collect();
        me.start_crossings = tri_tri::intersecting_pairs(x, tris, tri_body, &me.bvh);
        me.lists = me.find(x, me.reach, 0.0);
        me.set_active(x);
        me
    }

    /// Pairs that never act: same body, or nothing free among the four.
    fn skip(&self, node: u32, t: u32) -> bool {
        self.tri_body[t as usize] == self.node_body[node as usize] || self.node_fixed[node as usize]
    }

    /// Triangle `t` has a fixed (sutured) node.
    fn on_suture_line(&self, t: u32) -> bool {
        self.tris[t as usize]
            .iter()
            .any(|&i| self.node_fixed[i as usize])
    }

    pub fn offsets(&self) -> &[f64] {
        &self.xi
    }

    pub fn start_crossings(&self) -> usize {
        self.start_crossings.len()
    }

    /// The pairs with s < d̂ + `reach` at `y`, the tree fitted to a state
    /// within `slack` of `y` (so its boxes are searched that much wider).
    fn find(&self, y: &[V3], reach: f64, slack: f64) -> Lists {
        // Per node: its (node, body) keys and their candidate lists.
        type Found = (Vec<(u32, u16)>, Vec<Vec<u32>>);
        let far = self.params.dhat + reach;
        let balls = tri_balls(y, &self.tris);
        let per: Vec<Found> = (0..y.len())
            .into_par_iter()
            .with_min_len(64)
            .map(|i| {
                let r = self.xi[i] + far + slack;
                let mut found: Vec<u32> = vec![];
                if self.node_fixed[i] {
                    return (vec![], vec![]);
                }
                // Subtrees of the node's own leaflet hold no pair.
                self.bvh
                    .query_sphere_apart(&y[i], r, self.node_body[i], |t| {
                        if !self.skip(i as u32, t)
                            && !beyond(&balls[t as usize], &y[i], self.xi[i] + far)
                        {
                            let q = self.quad(y, i as u32, t);
                            let d = barrier::proximity(&q[0], &q[1], &q[2], &q[3]).dist;
                            if d - self.xi[i] < far {
                                found.push(t);
                            }
                        }
                    });
                found.sort_unstable_by_key(|&t| (self.tri_body[t as usize], t));
                let mut keys = vec![];
                let mut lists: Vec<Vec<u32>> = vec![];
                for t in found {
                    let b = self.tri_body[t as usize];
                    if keys.last().map(|k: &(u32, u16)| k.1) != Some(b) {
                        keys.push((i as u32, b));
                        lists.push(vec![]);
                    }
                    lists.last_mut().expect("pushed").push(t);
                }
                (keys, lists)
            })
            .collect();
        let mut groups = vec![];
        let mut cand = vec![];
        for (keys, lists) in per {
            for (k, l) in keys.into_iter().zip(lists) {
                let start = cand.len() as u32;
                cand.extend_from_slice(&l);
                groups.push(Group {
                    node: k.0,
                    body: k.1,
                    start,
                    end: cand.len() as u32,
                });
            }
        }
        Lists {
            reach,
            x0: y.to_vec(),
            groups,
            cand,
            edge_cand: self.edges.find(y, &self.bvh, &self.params, reach, slack),
        }
    }

    /// `f` of lists holding every pair acting at `y`: the stored ones when
    /// they cover `y`, else found afresh (a trial state farther than the
    /// lists were built for).
    fn with_lists<R>(&self, y: &[V3], f: impl FnOnce(&Lists) -> R) -> R {
        if self.lists.covers(y) {
            return f(&self.lists);
        }
        let spare = self.spare_lists();
        if let Some(l) = spare.filter(|l| l.covers(y)) {
            return f(&l);
        }
        let slack = largest_move(&self.x_fit, y);
        let l = Arc::new(self.find(y, 0.0, slack));
        *self.spare.lock().unwrap_or_else(|e| e.into_inner()) = Some(l.clone());
        f(&l)
    }

    fn spare_lists(&self) -> Option<Arc<Lists>> {
        self.spare.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The pairs of the lists within the margin at `x` (the update's
    /// state, which the lists cover).
    fn set_active(&mut self, x: &[V3]) {
        let lists = &self.lists;
        let balls = tri_balls(x, &self.tris);
        let act: Vec<Vec<(u32, u32)>> = lists
            .groups
            .par_iter()
            .with_min_len(64)
            .map(|g| {
                self.within_reach(lists, &balls, x, g)
                    .map(|(t, _, _)| (g.node, t))
                    .collect()
            })
            .collect();
        self.active = act.into_iter().flatten().collect();
        self.edges
            .set_active(x, &self.lists.x0, &self.lists.edge_cand, &self.params);
    }

    /// The closest candidate triangle of a group at `x` (ties: lower index).
    fn closest(&self, lists: &Lists, x: &[V3], g: &Group) -> Option<(u32, Proximity)> {
        let xi = &x[g.node as usize];
        let mut best: Option<(u32, Proximity)> = None;
        for &t in &lists.cand[g.start as usize..g.end as usize] {
            let v = self.tris[t as usize].map(|k| x[k as usize]);
            let p = barrier::proximity(xi, &v[0], &v[1], &v[2]);
            if best.as_ref().is_none_or(|b| p.dist < b.1.dist) {
                best = Some((t, p));
            }
        }
        best
    }

    fn quad(&self, x: &[V3], node: u32, t: u32) -> [V3; 4] {
        let v = self.tris[t as usize];
        [
            x[node as usize],
            x[v[0] as usize],
            x[v[1] as usize],
            x[v[2] as usize],
        ]
    }

    /// A group's candidate triangles whose pair acts at `x` (s < d̂; a NaN
    /// distance is kept so that the evaluation refuses it), with the pair's
    /// points and proximity, in list order: the order every sum over pairs
    /// keeps.
    fn within_reach<'a>(
        &'a self,
        lists: &'a Lists,
        balls: &'a [(V3, f64)],
        x: &'a [V3],
        g: &'a Group,
    ) -> impl Iterator<Item = (u32, [V3; 4], Proximity)> + 'a {
        let i = g.node as usize;
        let reach = self.xi[i] + self.params.dhat;
        lists.cand[g.start as usize..g.end as usize]
            .iter()
            .filter_map(move |&t| {
                if beyond(&balls[t as usize], &x[i], reach) {
                    return None;
                }
                let q = self.quad(x, g.node, t);
                let p = barrier::proximity(&q[0], &q[1], &q[2], &q[3]);
                (!(p.dist - self.xi[i] >= self.params.dhat)).then_some((t, q, p))
            })
    }

    /// Per group: its energy and the gradient blocks of its acting pairs;
    /// `None` when a pair is inadmissible (d ≤ ξ).
    #[allow(clippy::type_complexity)]
    fn eval_groups(&self, lists: &Lists, x: &[V3]) -> Vec<Option<(f64, Vec<(u32, [V3; 4])>)>> {
        let balls = tri_balls(x, &self.tris);
        lists
            .groups
            .par_iter()
            .with_min_len(64)
            .map(|g| {
                let i = g.node as usize;
                let mut e = 0.0;
                let mut grads = vec![];
                for (t, q, p) in self.within_reach(lists, &balls, x, g) {
                    let (ep, gr, _) = barrier::pair_eval_at(
                        &q,
                        &p,
                        self.xi[i],
                        self.node_area[i],
                        &self.params,
                        false,
                    )?;
                    e += ep;
                    grads.push((t, gr));
                }
                Some((e, grads))
            })
            .collect()
    }

    /// The node–triangle and edge–edge energy at `x` from `lists` (which
    /// hold every acting pair), summed in the order [`Term::add_force`]
    /// visits the pairs; `None` when a pair is inadmissible (d ≤ ξ). No
    /// gradients: the line search asks for energies only.
    fn energy_in(&self, lists: &Lists, x: &[V3]) -> Option<f64> {
        let balls = tri_balls(x, &self.tris);
        let per: Vec<Option<f64>> = lists
            .groups
            .par_iter()
            .with_min_len(64)
            .map(|g| {
                let i = g.node as usize;
                let mut e = 0.0;
                for (_, q, p) in self.within_reach(lists, &balls, x, g) {
                    e += barrier::pair_eval_at(
                        &q,
                        &p,
                        self.xi[i],
                        self.node_area[i],
                        &self.params,
                        false,
                    )?
                    .0;
                }
                Some(e)
            })
            .collect();
        let mut e = 0.0;
        for v in per {
            e += v?;
        }
        self.edges
            .energy(&lists.edge_cand, &lists.x0, x, &self.params, e)
    }

    /// [`LeafletBarrier::energy_in`] at `x`, with lists that cover it.
    fn energy_at(&self, x: &[V3]) -> Option<f64> {
        self.with_lists(x, |lists| self.energy_in(lists, x))
    }

    /// Whether triangles of different leaflets cross at `x` that may not:
    /// those that did not cross at the start, unless both are on the
    /// suture line. The tree is refitted to `x` (the same boxes a fresh
    /// build has, so the same pairs are tested) and skips each triangle's
    /// own leaflet; the first forbidden crossing ends the search.
    fn crossing_free(&self, x: &[V3]) -> bool {
        let mut bvh = self.bvh.clone();
        bvh.refit(x);
        let tris = &self.tris;
        (0..tris.len()).into_par_iter().with_min_len(64).all(|i| {
            let ti = tris[i];
            let vi = ti.map(|k| &x[k as usize]);
            if tri_tri::is_degenerate(vi[0], vi[1], vi[2]) {
                return true;
            }
            let body = self.tri_body[i];
            let bx = Aabb::of_triangle(vi[0], vi[1], vi[2]);
            let mut ok = true;
            bvh.query_aabb_apart(&bx, body, |j| {
                if !ok || j as usize <= i || self.tri_body[j as usize] == body {
                    return;
                }
                let tj = tris[j as usize];
                if tj.iter().any(|v| ti.contains(v)) {
                    return;
                }
                let p = (i as u32, j);
                if self.start_crossings.binary_search(&p).is_ok()
                    || (self.on_suture_line(p.0) && self.on_suture_line(p.1))
                {
                    return;
                }
                if tri_tri::tri_tri_intersect(vi, tj.map(|k| &x[k as usize])) {
                    ok = false;
                }
            });
            ok
        })
    }

    /// Bit b set on a node whose distance to leaflet b is within ξ + d̂.
    fn mask(&self, x: &[V3]) -> Vec<u8> {
        self.with_lists(x, |lists| {
            let mut m = vec![0u8; x.len()];
            for g in &lists.groups {
                if let Some((_, p)) = self.closest(lists, x, g) {
                    if p.dist - self.xi[g.node as usize] < self.params.dhat && g.body < 8 {
                        m[g.node as usize] |= 1 << g.body;
                    }
                }
            }
            m
        })
    }

    /// Largest fraction of `dx` from `x` keeping every node–triangle
    /// pair's s above `KEEP` × its start value, `lists` holding every pair
    /// that could lose more.
    fn node_max_step(&self, lists: &Lists, x: &[V3], dx: &[V3]) -> f64 {
        let balls = tri_balls(x, &self.tris);
        lists
            .groups
            .par_iter()
            .with_min_len(64)
            .map(|g| {
                let i = g.node as usize;
                let mut t_min: f64 = 1.0;
                for &t in &lists.cand[g.start as usize..g.end as usize] {
                    let q = self.quad(x, g.node, t);
                    let v = self.tris[t as usize];
                    let d = [
                        dx[i],
                        dx[v[0] as usize],
                        dx[v[1] as usize],
                        dx[v[2] as usize],
                    ];
                    // The distance falls by at most the node's move plus
                    // the triangle's largest.
                    let m = d[0].norm() + d[1].norm().max(d[2].norm()).max(d[3].norm());
                    if beyond(&balls[t as usize], &x[i], self.xi[i] + m / (1.0 - KEEP)) {
                        continue;
                    }
                    let s = barrier::proximity(&q[0], &q[1], &q[2], &q[3]).dist - self.xi[i];
                    if s >= m / (1.0 - KEEP) {
                        continue;
                    }
                    t_min = t_min.min(barrier::toi(&q, &d, self.xi[i], KEEP, CCD_ITER));
                }
                t_min
            })
            // min is exact whatever the order: thread-independent.
            .reduce(|| 1.0, f64::min)
    }
}

impl Term for LeafletBarrier {
    fn name(&self) -> &'static str {
        "leaflet-barrier"
    }

    /// Refits the tree; finds the pairs afresh only when the lists would
    /// not cover a step up to twice the last one, or are far wider than
    /// that needs (a step of `last` moves no node farther than `last`).
    fn update(&mut self, x: &[V3]) {
        // A solver phase starts with an update where the last ended: that
        // says nothing about the step to come.
        let moved = largest_move(&self.x_fit, x);
        if moved > 0.0 {
            self.last_move = moved;
        }
        self.x_fit = x.to_vec();
        *self.spare.get_mut().unwrap_or_else(|e| e.into_inner()) = None;
        self.bvh.refit(x);
        if self.bvh.cost() > 2.0 * self.build_cost {
            self.bvh = tree(x, &self.tris, &self.tri_body);
            self.build_cost = self.bvh.cost();
        }
        // A cut step asks for lists that hold it (it was cut, not limited
        // by the pairs: sizing for the cut move alone would cut again).
        let cut = f64::from_bits(self.cut_from.swap(0, Ordering::Relaxed));
        let want = (REACH_PER_STEP * self.last_move.max(cut)).clamp(MIN_REACH, self.reach);
        let moved = self.lists.moved(x);
        if 2.0 * (moved + 2.0 * self.last_move.max(cut)) > self.lists.reach
            || self.lists.reach > 2.0 * want
        {
            self.lists = self.find(x, want, 0.0);
        }
        self.set_active(x);
    }

    fn energy(&self, x: &[V3]) -> Option<f64> {
        Some(self.energy_at(x).unwrap_or(f64::INFINITY))
    }

    /// An inadmissible group (d ≤ ξ) adds nothing: the solver never takes
    /// such a state ([`Term::admissible`]).
    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        self.with_lists(x, |lists| {
            for (g, v) in lists.groups.iter().zip(self.eval_groups(lists, x)) {
                let Some((_, grads)) = v else { continue };
                for (t, gr) in grads {
                    let v = self.tris[t as usize];
                    f[g.node as usize] -= gr[0];
                    for k in 0..3 {
                        f[v[k] as usize] -= gr[k + 1];
                    }
                }
            }
            if let Some(acting) = self
                .edges
                .acting(&lists.edge_cand, &lists.x0, x, &self.params)
            {
                self.edges.add_force(&acting, f);
            }
        })
    }
    fn couplings(&self, out: &mut Vec<[u32; 2]>) {
        // The triangle's own vertex pairs are mesh edges already.
        for &(n, t) in &self.active {
            for v in self.tris[t as usize] {
                out.push([n, v]);
            }
        }
        self.edges.couplings(out);
    }

    fn add_tangent(&self, x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        let blocks: Vec<Option<Hess12>> = self
            .active
            .par_iter()
            .with_min_len(16)
            .map(|&(n, t)| {
                let q = self.quad(x, n, t);
                let i = n as usize;
                if self.projected {
                    return barrier::pair_gauss_newton(
                        &q,
                        self.xi[i],
                        self.node_area[i],
                        &self.params,
                    );
                }
                barrier::pair_eval(&q, self.xi[i], self.node_area[i], &self.params, true)?.2
            })
            .collect();
        for (&(n, t), h) in self.active.iter().zip(blocks) {
            if let Some(h) = h {
                let v = self.tris[t as usize];
                pat.add_block(dofs, vals, &[n, v[0], v[1], v[2]], &h);
            }
        }
        self.edges
            .add_tangent(x, &self.params, self.projected, dofs, pat, vals);
    }

    fn set_projected(&mut self, projected: bool) {
        self.projected = projected;
    }

    fn stats(&self) -> Option<(&'static str, usize)> {
        Some(("contact_pairs", self.active.len() + self.edges.active_len()))
    }

    fn contact_mask(&self, x: &[V3]) -> Option<Vec<u8>> {
        Some(self.mask(x))
    }

    /// A step is cut to what the lists cover: pairs outside them had
    /// s ≥ d̂ + R where they were built, at least d̂ + R − 2·moved now, and
    /// a step of c·dmax takes at most 2c·dmax from them, so they keep
    /// their KEEP share for c ≤ (1 − KEEP)(d̂ + R − 2·moved)/(2·dmax); the
    /// line search's states stay covered for c ≤ (R/2 − moved)/dmax. The
    /// next update sizes the lists for the step taken (a cut step is at
    /// least twice the last one: `update` keeps that much room).
    fn max_step(&self, x: &[V3], dx: &[V3]) -> f64 {
        let dmax = dx.iter().map(|v| v.norm()).fold(0.0, f64::max);
        if dmax == 0.0 {
            return 1.0;
        }
        if !dmax.is_finite() {
            return 0.0;
        }
        let lists = &self.lists;
        let moved = lists.moved(x);
        let c = ((1.0 - KEEP) * (self.params.dhat + lists.reach - 2.0 * moved) / (2.0 * dmax))
            .min((0.5 * lists.reach - moved) / dmax);
        // (A hair short when cut: x + c Δx − x rounds.)
        let cover = if c >= 1.0 {
            1.0
        } else {
            c.max(0.0) * (1.0 - 1e-9)
        };
        if cover == 0.0 {
            return 0.0;
        }
        if cover < 1.0 {
            self.cut_from.store(dmax.to_bits(), Ordering::Relaxed);
        }
        let cut: Vec<V3>;
        let dx = if cover < 1.0 {
            cut = dx.iter().map(|v| v * cover).collect();
            &cut[..]
        } else {
            dx
        };
        let t = self.node_max_step(lists, x, dx).min(self.edges.max_step(
            &lists.edge_cand,
            &lists.x0,
            x,
            dx,
        ));
        cover * t
    }

    fn admissible(&self, x: &[V3]) -> bool {
        self.energy_at(x).is_some() && self.crossing_free(x)
    }
}
