//! Isotropic remeshing to a target edge length L (Botsch & Kobbelt 2004).
//!
//! Each iteration splits edges longer than 4/3·L at their midpoint, collapses
//! edges shorter than 4/5·L (refusing collapses that would break the link
//! condition, make an edge longer than 4/3·L or turn a triangle over), flips
//! edges towards valence 6, moves every vertex to the centroid of its
//! neighbours within its tangent plane, and projects it back onto the input
//! surface (closest point, parry's BVH).
//!
//! Labels: triangles keep their `region`. An edge between two regions is a
//! feature (the rim of a cap): it may be split, and collapsed only along
//! itself; it is never flipped. A vertex on exactly two feature edges slides
//! along the rim and is projected back onto the input's rim polyline; a vertex
//! on any other number of feature edges (a corner) never moves. A vertex off
//! the rims is projected onto the input triangles of its own region only, so
//! caps stay flat and walls stay walls.
//!
//! The mesh is a corner table: half-edge `c` of face `c / 3` runs from
//! `corner[c]` to the next corner of the face, `opp[c]` is its twin. Every
//! operation is local, sequential and in index order, and the parallel steps
//! (relaxation, projection) only map vertices independently, so the output is
//! bit-identical for any thread count.

use std::collections::BTreeMap;
use std::time::Instant;

use parry3d_f64::math::Vector as GVec;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{Polyline, TriMesh as PTriMesh};
use rayon::prelude::*;
use serde::Serialize;

use coapt_base::{Error, Result};
use coapt_geom::{Point3, TriMesh, Vector3};

const DEAD: u32 = u32::MAX;
/// Longest walk around a vertex before the structure is taken as corrupt.
const MAX_VALENCE: usize = 4096;

/// Parameters of [`remesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RemeshParams {
    /// Target edge length L, mm.
    pub target_edge: f64,
    /// Split / collapse / flip / relax / project rounds.
    pub iterations: usize,
}

impl RemeshParams {
    pub fn new(target_edge: f64) -> Self {
        RemeshParams {
            target_edge,
            iterations: 5,
        }
    }
}

/// What `surface.json` records about remeshing.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RemeshReport {
    pub target_edge_mm: f64,
    pub iterations: usize,
    pub input_vertices: usize,
    pub input_triangles: usize,
    pub output_vertices: usize,
    pub output_triangles: usize,
    pub splits: usize,
    pub collapses: usize,
    pub flips: usize,
    pub edge_mean_mm: f64,
    pub edge_min_mm: f64,
    pub edge_max_mm: f64,
    /// Edge length percentiles p1, p5, p50, p95, p99, mm.
    pub edge_percentiles_mm: BTreeMap<String, f64>,
    /// Edges within [4/5·L, 4/3·L], percent.
    pub edges_in_band_pct: f64,
    pub min_angle_deg: f64,
    /// 1st percentile of the triangles' smallest angles, degrees.
    pub min_angle_p1_deg: f64,
    /// Triangles with an angle below 20°, percent.
    pub triangles_below_20deg_pct: f64,
    /// Mean distance the vertices were moved off the input surface to cancel
    /// the chord error of the coarser triangles, mm.
    pub sag_offset_mean_mm: f64,
    /// (output − input) / input enclosed volume, percent.
    pub volume_change_pct: f64,
    pub time_s: f64,
}

#[inline]
fn nx(c: u32) -> u32 {
    if c % 3 == 2 { c - 2 } else { c + 1 }
}

#[inline]
fn pv(c: u32) -> u32 {
    if c % 3 == 0 { c + 2 } else { c - 1 }
}

fn g(p: &Point3) -> GVec {
    GVec::new(p.x, p.y, p.z)
}

/// Corner-table mesh under modification.
struct Work {
    pos: Vec<Point3>,
    corner: Vec<u32>,
    opp: Vec<u32>,
    label: Vec<u8>,
    /// An outgoing half-edge of each vertex (`DEAD` once removed).
    out: Vec<u32>,
    valence: Vec<u32>,
}

impl Work {
    fn build(mesh: &TriMesh, label: &[u8]) -> Result<Work> {
        let nv = mesh.vertices.len();
        let corner: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let mut keys: Vec<(u32, u32, u32)> = (0..corner.len() as u32)
            .map(|c| {
                let (a, b) = (corner[c as usize], corner[nx(c) as usize]);
                (a.min(b), a.max(b), c)
            })
            .collect();
        keys.sort_unstable();
        let mut opp = vec![DEAD; corner.len()];
        let bad = || Error::failed("surface", "remeshing needs a closed, manifold surface");
        let mut i = 0;
        while i < keys.len() {
            if i + 1 >= keys.len() || (keys[i].0, keys[i].1) != (keys[i + 1].0, keys[i + 1].1) {
                return Err(bad());
            }
            if i + 2 < keys.len() && (keys[i].0, keys[i].1) == (keys[i + 2].0, keys[i + 2].1) {
                return Err(bad());
            }
            let (c, d) = (keys[i].2, keys[i + 1].2);
            if corner[c as usize] == corner[d as usize] {
                return Err(bad());
            }
            opp[c as usize] = d;
            opp[d as usize] = c;
            i += 2;
        }
        let mut out = vec![DEAD; nv];
        let mut valence = vec![0u32; nv];
        for (c, &v) in corner.iter().enumerate() {
            out[v as usize] = c as u32;
            valence[v as usize] += 1;
        }
        let w = Work {
            pos: mesh.vertices.clone(),
            corner,
            opp,
            label: label.to_vec(),
            out,
            valence,
        };
        // A vertex whose triangles form more than one fan is non-manifold.
        for v in 0..nv {
            if w.out[v] != DEAD && w.ring_len(v as u32) != w.valence[v] as usize {
                return Err(bad());
            }
        }
        Ok(w)
    }

    #[inline]
    fn dest(&self, h: u32) -> u32 {
        self.corner[nx(h) as usize]
    }

    #[inline]
    fn alive(&self, h: u32) -> bool {
        self.corner[h as usize] != DEAD
    }

    /// Next outgoing half-edge around the source vertex of `h`.
    #[inline]
    fn turn(&self, h: u32) -> u32 {
        self.opp[pv(h) as usize]
    }

    #[inline]
    fn is_feature(&self, h: u32) -> bool {
        self.label[(h / 3) as usize] != self.label[(self.opp[h as usize] / 3) as usize]
    }

    fn ring_len(&self, v: u32) -> usize {
        let h0 = self.out[v as usize];
        let mut h = h0;
        let mut n = 0;
        loop {
            n += 1;
            h = self.turn(h);
            if h == h0 || n > MAX_VALENCE {
                return n;
            }
        }
    }

    /// Outgoing half-edges of `v` into `buf`.
    fn ring(&self, v: u32, buf: &mut Vec<u32>) {
        buf.clear();
        let h0 = self.out[v as usize];
        let mut h = h0;
        loop {
            buf.push(h);
            h = self.turn(h);
            if h == h0 {
                break;
            }
            assert!(buf.len() < MAX_VALENCE, "remesh: corrupt vertex ring");
        }
    }

    /// Feature edges at `v` and (when there are two) their far ends.
    fn features(&self, v: u32) -> (usize, [u32; 2]) {
        let h0 = self.out[v as usize];
        let mut h = h0;
        let mut n = 0;
        let mut ends = [DEAD; 2];
        loop {
            if self.is_feature(h) {
                if n < 2 {
                    ends[n] = self.dest(h);
                }
                n += 1;
            }
            h = self.turn(h);
            if h == h0 {
                return (n, ends);
            }
        }
    }

    fn sq_len(&self, h: u32) -> f64 {
        (self.pos[self.dest(h) as usize] - self.pos[self.corner[h as usize] as usize])
            .norm_squared()
    }

    fn area_vector(&self, f: u32) -> Vector3 {
        let c = 3 * f as usize;
        let [a, b, d] =
            [self.corner[c], self.corner[c + 1], self.corner[c + 2]].map(|v| self.pos[v as usize]);
        (b - a).cross(&(d - a))
    }

    fn centroid(&self, f: u32) -> Point3 {
        let c = 3 * f as usize;
        let s = self.pos[self.corner[c] as usize].coords
            + self.pos[self.corner[c + 1] as usize].coords
            + self.pos[self.corner[c + 2] as usize].coords;
        Point3::from(s / 3.0)
    }

    fn set_face(&mut self, f: u32, v: [u32; 3]) {
        let c = 3 * f as usize;
        self.corner[c..c + 3].copy_from_slice(&v);
    }

    fn new_face(&mut self, label: u8) -> u32 {
        let f = self.label.len() as u32;
        self.corner.extend_from_slice(&[DEAD; 3]);
        self.opp.extend_from_slice(&[DEAD; 3]);
        self.label.push(label);
        f
    }

    #[inline]
    fn link(&mut self, a: u32, b: u32) {
        self.opp[a as usize] = b;
        self.opp[b as usize] = a;
    }

    /// Split the edge of `h` at `p`: two triangles become four.
    fn split(&mut self, h: u32, p: Point3) {
        let t = self.opp[h as usize];
        let (f0, f1) = (h / 3, t / 3);
        let (a, b, c, d) = (
            self.corner[h as usize],
            self.dest(h),
            self.corner[pv(h) as usize],
            self.corner[pv(t) as usize],
        );
        let o_bc = self.opp[nx(h) as usize];
        let o_ca = self.opp[pv(h) as usize];
        let o_ad = self.opp[nx(t) as usize];
        let o_db = self.opp[pv(t) as usize];
        let m = self.pos.len() as u32;
        self.pos.push(p);
        self.valence.push(4);
        self.out.push(DEAD);
        self.valence[c as usize] += 1;
        self.valence[d as usize] += 1;
        let f2 = self.new_face(self.label[f0 as usize]);
        let f3 = self.new_face(self.label[f1 as usize]);
        self.set_face(f0, [a, m, c]);
        self.set_face(f2, [m, b, c]);
        self.set_face(f1, [m, a, d]);
        self.set_face(f3, [b, m, d]);
        let (f0, f1, f2, f3) = (3 * f0, 3 * f1, 3 * f2, 3 * f3);
        self.link(f0, f1);
        self.link(f0 + 1, f2 + 2);
        self.link(f0 + 2, o_ca);
        self.link(f2, f3);
        self.link(f2 + 1, o_bc);
        self.link(f1 + 1, o_ad);
        self.link(f1 + 2, f3 + 1);
        self.link(f3 + 2, o_db);
        self.out[a as usize] = f0;
        self.out[b as usize] = f2 + 1;
        self.out[c as usize] = f0 + 2;
        self.out[d as usize] = f3 + 2;
        self.out[m as usize] = f0 + 1;
    }

    /// Remove the source `a` of `h`, merging it into its destination `b`,
    /// which moves to `p`. `ring_a` holds a's outgoing half-edges.
    fn collapse(&mut self, h: u32, ring_a: &[u32], p: Point3) {
        let t = self.opp[h as usize];
        let (f0, f1) = (h / 3, t / 3);
        let (a, b, c, d) = (
            self.corner[h as usize],
            self.dest(h),
            self.corner[pv(h) as usize],
            self.corner[pv(t) as usize],
        );
        let x = self.opp[nx(h) as usize];
        let y = self.opp[pv(h) as usize];
        let z = self.opp[nx(t) as usize];
        let w = self.opp[pv(t) as usize];
        for &g in ring_a {
            self.corner[g as usize] = b;
        }
        self.link(x, y);
        self.link(z, w);
        self.out[b as usize] = y;
        self.out[c as usize] = x;
        self.out[d as usize] = z;
        self.out[a as usize] = DEAD;
        self.pos[b as usize] = p;
        self.valence[b as usize] = self.valence[a as usize] + self.valence[b as usize] - 4;
        self.valence[a as usize] = 0;
        self.valence[c as usize] -= 1;
        self.valence[d as usize] -= 1;
        for f in [f0, f1] {
            let k = 3 * f as usize;
            self.corner[k..k + 3].copy_from_slice(&[DEAD; 3]);
        }
    }

    /// Flip the edge of `h` to join the two opposite corners.
    fn flip(&mut self, h: u32) {
        let t = self.opp[h as usize];
        let (f0, f1) = (h / 3, t / 3);
        let (a, b, c, d) = (
            self.corner[h as usize],
            self.dest(h),
            self.corner[pv(h) as usize],
            self.corner[pv(t) as usize],
        );
        let o1 = self.opp[nx(h) as usize];
        let o2 = self.opp[pv(h) as usize];
        let o3 = self.opp[nx(t) as usize];
        let o4 = self.opp[pv(t) as usize];
        self.set_face(f0, [a, d, c]);
        self.set_face(f1, [d, b, c]);
        let (f0, f1) = (3 * f0, 3 * f1);
        self.link(f0, o3);
        self.link(f0 + 1, f1 + 2);
        self.link(f0 + 2, o2);
        self.link(f1, o4);
        self.link(f1 + 1, o1);
        self.out[a as usize] = f0;
        self.out[d as usize] = f0 + 1;
        self.out[c as usize] = f0 + 2;
        self.out[b as usize] = f1 + 1;
        self.valence[a as usize] -= 1;
        self.valence[b as usize] -= 1;
        self.valence[c as usize] += 1;
        self.valence[d as usize] += 1;
    }

    fn split_long(&mut self, high2: f64) -> usize {
        let mut n = 0;
        for _pass in 0..10 {
            let mut any = false;
            let mut h = 0u32;
            while (h as usize) < self.corner.len() {
                if self.alive(h) && h < self.opp[h as usize] && self.sq_len(h) > high2 {
                    let a = self.pos[self.corner[h as usize] as usize];
                    let b = self.pos[self.dest(h) as usize];
                    self.split(h, Point3::from(0.5 * (a.coords + b.coords)));
                    n += 1;
                    any = true;
                }
                h += 1;
            }
            if !any {
                break;
            }
        }
        n
    }

    /// Where the vertices of `h` would merge when its source `a` is removed
    /// into its destination `b`, if that is allowed: the midpoint when `a`
    /// and `b` are of one kind (both off the rims, or both inner rim vertices
    /// on this rim edge), else `b` (a rim or corner vertex stays put).
    fn can_collapse(
        &self,
        h: u32,
        high2: f64,
        ring_a: &mut Vec<u32>,
        ring_b: &mut Vec<u32>,
    ) -> Option<Point3> {
        let t = self.opp[h as usize];
        let (a, b) = (self.corner[h as usize], self.dest(h));
        let (c, d) = (self.corner[pv(h) as usize], self.corner[pv(t) as usize]);
        let (fa, _) = self.features(a);
        match fa {
            0 => {}
            // Along the rim only.
            2 if self.is_feature(h) => {}
            _ => return None,
        }
        if self.valence[c as usize] <= 3 || self.valence[d as usize] <= 3 {
            return None;
        }
        self.ring(a, ring_a);
        self.ring(b, ring_b);
        // Link condition: the one-rings of a and b share c and d only.
        let mut common = 0;
        for &ha in ring_a.iter() {
            let u = self.dest(ha);
            if ring_b.iter().any(|&hb| self.dest(hb) == u) {
                common += 1;
            }
        }
        if common != 2 {
            return None;
        }
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let p = if self.features(b).0 == fa {
            Point3::from(0.5 * (pa.coords + pb.coords))
        } else {
            pb
        };
        let (f0, f1) = (h / 3, t / 3);
        let mut nref = Vector3::zeros();
        for &g in ring_a.iter().chain(ring_b.iter()) {
            nref += self.area_vector(g / 3);
        }
        let nref = nref.try_normalize(1e-300)?;
        for (ring, other) in [(&*ring_a, b), (&*ring_b, a)] {
            for &g in ring {
                let u = self.dest(g);
                let pu = self.pos[u as usize];
                if u != other && (pu - p).norm_squared() > high2 {
                    return None;
                }
                let f = g / 3;
                if f == f0 || f == f1 {
                    continue;
                }
                let pw = self.pos[self.corner[pv(g) as usize] as usize];
                let n_new = (pu - p).cross(&(pw - p));
                let norm = n_new.norm();
                // No triangle turned over or made degenerate.
                if norm == 0.0 || n_new.dot(&nref) < 0.3 * norm {
                    return None;
                }
            }
        }
        Some(p)
    }

    fn collapse_short(&mut self, low2: f64, high2: f64) -> usize {
        let mut n = 0;
        let (mut ra, mut rb) = (Vec::new(), Vec::new());
        for h in 0..self.corner.len() as u32 {
            if !self.alive(h) {
                continue;
            }
            let t = self.opp[h as usize];
            if h > t || self.sq_len(h) >= low2 {
                continue;
            }
            let ok_h = self.can_collapse(h, high2, &mut ra, &mut rb);
            let ok_t = self.can_collapse(t, high2, &mut rb, &mut ra);
            let (a, b) = (self.corner[h as usize], self.dest(h));
            // Both allowed: remove the vertex of higher valence.
            let (g, p) = match (ok_h, ok_t) {
                (None, None) => continue,
                (Some(p), None) => (h, p),
                (None, Some(p)) => (t, p),
                (Some(p), Some(q)) => {
                    if self.valence[a as usize] >= self.valence[b as usize] {
                        (h, p)
                    } else {
                        (t, q)
                    }
                }
            };
            let src = self.corner[g as usize];
            self.ring(src, &mut ra);
            let ring = std::mem::take(&mut ra);
            self.collapse(g, &ring, p);
            ra = ring;
            n += 1;
        }
        n
    }

    fn flip_to_valence_six(&mut self) -> usize {
        let mut n = 0;
        let mut ring = Vec::new();
        for h in 0..self.corner.len() as u32 {
            if !self.alive(h) {
                continue;
            }
            let t = self.opp[h as usize];
            if h > t || self.is_feature(h) {
                continue;
            }
            let (a, b) = (self.corner[h as usize], self.dest(h));
            let (c, d) = (self.corner[pv(h) as usize], self.corner[pv(t) as usize]);
            let val = |v: u32| self.valence[v as usize] as i64;
            if c == d || val(a) <= 3 || val(b) <= 3 {
                continue;
            }
            // An ear is a triangle with two rim edges: three nearly collinear
            // rim vertices, angles down to 7° on the phantom's caps, which
            // the valence count (blind to which side of a rim an edge lies)
            // kept. Its third edge is flipped whatever the valences, and no
            // flip may make one.
            let f = |g: u32| self.is_feature(g);
            let ear = (f(nx(h)) && f(pv(h))) || (f(nx(t)) && f(pv(t)));
            let makes_ear = (f(nx(t)) && f(pv(h))) || (f(pv(t)) && f(nx(h)));
            if makes_ear {
                continue;
            }
            let dev = |x: i64| (x - 6) * (x - 6);
            let before = dev(val(a)) + dev(val(b)) + dev(val(c)) + dev(val(d));
            let after = dev(val(a) - 1) + dev(val(b) - 1) + dev(val(c) + 1) + dev(val(d) + 1);
            if after >= before && !ear {
                continue;
            }
            // c and d must not be joined already.
            self.ring(c, &mut ring);
            if ring.iter().any(|&g| self.dest(g) == d) {
                continue;
            }
            let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.pos[v as usize]);
            let Some(navg) =
                (self.area_vector(h / 3) + self.area_vector(t / 3)).try_normalize(1e-300)
            else {
                continue;
            };
            let n0 = (pd - pa).cross(&(pc - pa));
            let n1 = (pb - pd).cross(&(pc - pd));
            if n0.dot(&navg) <= 0.3 * n0.norm() || n1.dot(&navg) <= 0.3 * n1.norm() {
                continue;
            }
            if n0.norm() == 0.0 || n1.norm() == 0.0 {
                continue;
            }
            self.flip(h);
            n += 1;
        }
        n
    }

    fn vertex_normals(&self) -> Vec<Vector3> {
        let mut n = vec![Vector3::zeros(); self.pos.len()];
        for f in 0..self.label.len() as u32 {
            if !self.alive(3 * f) {
                continue;
            }
            let av = self.area_vector(f);
            for k in 0..3 {
                n[self.corner[(3 * f + k) as usize] as usize] += av;
            }
        }
        n
    }

    /// Tangential relaxation then projection onto the input surface.
    fn relax_and_project(&mut self, target: &Target) {
        let normals = self.vertex_normals();
        let me = &*self;
        let new: Vec<Point3> = (0..me.pos.len() as u32)
            .into_par_iter()
            .map(|v| {
                let p = me.pos[v as usize];
                if me.out[v as usize] == DEAD {
                    return p;
                }
                match me.features(v) {
                    (0, _) => {
                        let h0 = me.out[v as usize];
                        let (mut s, mut k, mut h) = (Vector3::zeros(), 0.0, h0);
                        loop {
                            // Area-weighted centroid of the incident triangles
                            // (evens out sizes better than the neighbours' mean).
                            let f = h / 3;
                            let a = me.area_vector(f).norm();
                            s += a * me.centroid(f).coords;
                            k += a;
                            h = me.turn(h);
                            if h == h0 {
                                break;
                            }
                        }
                        if k == 0.0 {
                            return p;
                        }
                        let u = s / k - p.coords;
                        let q = match normals[v as usize].try_normalize(1e-300) {
                            Some(n) => p + (u - n * n.dot(&u)),
                            None => p,
                        };
                        let label = me.label[(me.out[v as usize] / 3) as usize];
                        target.on_region(label, &q)
                    }
                    (2, [e1, e2]) => {
                        let (p1, p2) = (me.pos[e1 as usize], me.pos[e2 as usize]);
                        let q = Point3::from(0.5 * (p1.coords + p2.coords));
                        let q = match (p2 - p1).try_normalize(1e-300) {
                            Some(e) => p + e * e.dot(&(q - p)),
                            None => p,
                        };
                        target.on_rim(&q)
                    }
                    _ => p,
                }
            })
            .collect();
        self.pos = new;
    }

    /// Offset each vertex off the rims along its normal by the mean gap
    /// between its triangles and the input surface. With every vertex on a
    /// curved surface, the triangles cut inside it (by ~κL²/8, a volume loss
    /// of ~3L²/8R² on a sphere); this cancels that bias to first order and
    /// leaves flat parts (caps) alone. Returns the mean |offset|.
    fn correct_sag(&mut self, target: &Target) -> f64 {
        let me = &*self;
        let gap: Vec<(f64, f64)> = (0..me.label.len() as u32)
            .into_par_iter()
            .map(|f| {
                if !me.alive(3 * f) {
                    return (0.0, 0.0);
                }
                let av = me.area_vector(f);
                let a = av.norm();
                if a == 0.0 {
                    return (0.0, 0.0);
                }
                let q = me.centroid(f);
                let s = target.on_region(me.label[f as usize], &q);
                (a, (s - q).dot(&av) / a)
            })
            .collect();
        let normals = me.vertex_normals();
        // Mean sag over an equilateral triangle is 3/4 of the sag at its
        // centroid (a paraboloid over the triangle).
        let offset: Vec<f64> = (0..me.pos.len() as u32)
            .into_par_iter()
            .map(|v| {
                if me.out[v as usize] == DEAD || me.features(v).0 != 0 {
                    return 0.0;
                }
                let h0 = me.out[v as usize];
                let (mut s, mut w, mut h) = (0.0, 0.0, h0);
                loop {
                    let (a, d) = gap[(h / 3) as usize];
                    s += a * d;
                    w += a;
                    h = me.turn(h);
                    if h == h0 {
                        break;
                    }
                }
                if w > 0.0 { 0.75 * s / w } else { 0.0 }
            })
            .collect();
        let mut sum = 0.0;
        let mut n = 0usize;
        for (v, &d) in offset.iter().enumerate() {
            if let Some(nv) = normals[v].try_normalize(1e-300) {
                self.pos[v] += nv * d;
                sum += d.abs();
                n += 1;
            }
        }
        sum / n.max(1) as f64
    }

    fn into_mesh(self) -> (TriMesh, Vec<u8>) {
        let mut id = vec![DEAD; self.pos.len()];
        let mut verts = Vec::new();
        for (v, &o) in self.out.iter().enumerate() {
            if o != DEAD {
                id[v] = verts.len() as u32;
                verts.push(self.pos[v]);
            }
        }
        let mut tris = Vec::new();
        let mut labels = Vec::new();
        for f in 0..self.label.len() {
            if self.corner[3 * f] == DEAD {
                continue;
            }
            tris.push([0, 1, 2].map(|k| id[self.corner[3 * f + k] as usize]));
            labels.push(self.label[f]);
        }
        (TriMesh::new(verts, tris), labels)
    }
}

/// The input surface, by region, and its rims.
struct Target {
    regions: Vec<Option<PTriMesh>>,
    rims: Option<Polyline>,
}

impl Target {
    fn new(mesh: &TriMesh, label: &[u8]) -> Result<Target> {
        let verts: Vec<GVec> = mesh.vertices.iter().map(g).collect();
        let nl = label.iter().copied().max().map_or(0, |m| m as usize + 1);
        let mut regions = Vec::with_capacity(nl);
        for l in 0..nl {
            let tris: Vec<[u32; 3]> = mesh
                .triangles
                .iter()
                .zip(label)
                .filter(|&(_, &r)| r as usize == l)
                .map(|(t, _)| *t)
                .collect();
            regions.push(if tris.is_empty() {
                None
            } else {
                Some(PTriMesh::new(verts.clone(), tris).map_err(|e| {
                    Error::failed("surface", format!("surface cannot be indexed: {e}"))
                })?)
            });
        }
        let adj = mesh.adjacency();
        let rim: Vec<[u32; 2]> = (0..adj.edges.len())
            .filter(|&e| {
                let ts = adj.triangles_of_edge(e);
                ts.len() == 2 && label[ts[0] as usize] != label[ts[1] as usize]
            })
            .map(|e| adj.edges[e])
            .collect();
        let rims = (!rim.is_empty()).then(|| Polyline::new(verts, Some(rim)));
        Ok(Target { regions, rims })
    }

    fn on_region(&self, label: u8, p: &Point3) -> Point3 {
        match self.regions.get(label as usize) {
            Some(Some(m)) => {
                let q = m.project_local_point(g(p), false).point;
                Point3::new(q.x, q.y, q.z)
            }
            _ => *p,
        }
    }

    fn on_rim(&self, p: &Point3) -> Point3 {
        match &self.rims {
            Some(r) => {
                let q = r.project_local_point(g(p), false).point;
                Point3::new(q.x, q.y, q.z)
            }
            None => *p,
        }
    }
}

/// Most triangles a remeshed wall may have (a whole thoracic aorta at
/// 0.2 mm edges has about 2e6).
pub const MAX_TRIANGLES: f64 = 4e6;

/// Remesh a closed, manifold, labelled surface to edges of about
/// `params.target_edge`. Returns the new mesh (vertices and triangles only;
/// same frame), its labels and the report.
pub fn remesh(
    mesh: &TriMesh,
    label: &[u8],
    params: &RemeshParams,
) -> Result<(TriMesh, Vec<u8>, RemeshReport)> {
    let t0 = Instant::now();
    let l = params.target_edge;
    if !(l.is_finite() && l > 0.0) {
        return Err(Error::value(format!(
            "target edge {l} mm: expected a positive length"
        )));
    }
    assert_eq!(label.len(), mesh.triangles.len(), "one label per triangle");
    // Equilateral triangles of edge l cover √3/4 l² each: the count the
    // remeshing will build, judged before it builds it (0.05 mm edges on a
    // root and arch ran past 20 s towards 1e7 triangles).
    let estimate = mesh.total_area() / (3f64.sqrt() / 4.0 * l * l);
    if estimate > MAX_TRIANGLES {
        return Err(Error::value(format!(
            "--target-edge {l} mm: the {:.0} mm² surface would need about {:.1e} triangles, more than {MAX_TRIANGLES:.0e}: use an edge of at least {:.2} mm",
            mesh.total_area(),
            estimate,
            (mesh.total_area() / (3f64.sqrt() / 4.0 * MAX_TRIANGLES)).sqrt()
        )));
    }
    let mut w = Work::build(mesh, label)?;
    let target = Target::new(mesh, label)?;
    let (low2, high2) = ((0.8 * l).powi(2), (4.0 / 3.0 * l).powi(2));
    let mut rep = RemeshReport {
        target_edge_mm: l,
        iterations: params.iterations,
        input_vertices: mesh.vertices.len(),
        input_triangles: mesh.triangles.len(),
        ..Default::default()
    };
    for _ in 0..params.iterations {
        rep.splits += w.split_long(high2);
        rep.collapses += w.collapse_short(low2, high2);
        rep.flips += w.flip_to_valence_six();
        w.relax_and_project(&target);
    }
    rep.sag_offset_mean_mm = w.correct_sag(&target);
    let (mut out, labels) = w.into_mesh();
    out.frame = mesh.frame;
    rep.time_s = t0.elapsed().as_secs_f64();
    fill_stats(&mut rep, mesh, &out);
    Ok((out, labels, rep))
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

fn fill_stats(rep: &mut RemeshReport, input: &TriMesh, out: &TriMesh) {
    let l = rep.target_edge_mm;
    rep.output_vertices = out.vertices.len();
    rep.output_triangles = out.triangles.len();
    let adj = out.adjacency();
    let mut len: Vec<f64> = adj
        .edges
        .iter()
        .map(|&[a, b]| (out.vertices[a as usize] - out.vertices[b as usize]).norm())
        .collect();
    len.sort_by(f64::total_cmp);
    let n = len.len().max(1) as f64;
    rep.edge_mean_mm = len.iter().sum::<f64>() / n;
    rep.edge_min_mm = len.first().copied().unwrap_or(f64::NAN);
    rep.edge_max_mm = len.last().copied().unwrap_or(f64::NAN);
    for (k, q) in [
        ("p1", 0.01),
        ("p5", 0.05),
        ("p50", 0.5),
        ("p95", 0.95),
        ("p99", 0.99),
    ] {
        rep.edge_percentiles_mm
            .insert(k.to_string(), percentile(&len, q));
    }
    rep.edges_in_band_pct = 100.0
        * len
            .iter()
            .filter(|&&x| x >= 0.8 * l && x <= 4.0 / 3.0 * l)
            .count() as f64
        / n;
    let mut ang: Vec<f64> = (0..out.triangles.len())
        .map(|t| out.quality(t).min_angle.to_degrees())
        .collect();
    ang.sort_by(f64::total_cmp);
    rep.min_angle_deg = ang.first().copied().unwrap_or(f64::NAN);
    rep.min_angle_p1_deg = percentile(&ang, 0.01);
    rep.triangles_below_20deg_pct =
        100.0 * ang.iter().filter(|&&a| a < 20.0).count() as f64 / ang.len().max(1) as f64;
    let (v0, v1) = (input.signed_volume(), out.signed_volume());
    rep.volume_change_pct = 100.0 * (v1 - v0) / v0;
}
