//! Where the closed leaflets touch (docs/report.md, "Where leaflets touch";
//! the seeds' group's convention): a point of leaflet i coapts with leaflet
//! j when its distance to j's surface is below a margin (≈ 1.8 ×
//! thickness). Triangles whose status could change inside them are refined
//! n×n and every sub-triangle is cut at the margin by linear interpolation
//! of the distance, so the zone boundary, its area and its heights do not
//! jump with the mesh.
//!
//! Zones are kept as small convex polygons on the leaflet surface, per
//! leaflet and target: each other leaflet, any other (the coaptation zone),
//! and all others (the central, triple zone).

use rayon::prelude::*;

use coapt_geom::Point3;
use coapt_geom::Vector3 as V3;
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::closest_point;

use super::ClosedValve;
use super::clip::{self, Vertex};

/// How the zone is found.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Distance below which two leaflets touch, mm.
    pub margin_mm: f64,
    /// Sub-triangles per edge for triangles that may be partly in contact.
    pub refine: usize,
}

/// What a zone is measured against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// One other leaflet (0-based).
    Leaflet(usize),
    /// Any other leaflet: the coaptation zone.
    Any,
    /// Every other leaflet: the central (triple) zone.
    All,
}

/// Part of one leaflet's surface within the margin of a target.
#[derive(Debug, Clone, Default)]
pub struct Zone {
    /// Convex pieces (≤ 5 vertices each), closed positions, mm.
    pub pieces: Vec<Vec<Point3>>,
    /// Pieces of the zone boundary inside the leaflet (where the distance
    /// crosses the margin): the line where leaflets start to touch.
    pub boundary: Vec<[Point3; 2]>,
    pub area_mm2: f64,
}

impl Zone {
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// Every vertex of every piece.
    pub fn points(&self) -> impl Iterator<Item = &Point3> {
        self.pieces.iter().flatten()
    }
}

/// The zones of every leaflet.
#[derive(Debug, Clone)]
pub struct Coaptation {
    pub options: Options,
    /// Per node: bit j set when the node is within the margin of leaflet j.
    pub node_mask: Vec<u8>,
    /// `pair[i][j]`: zone on leaflet i touching leaflet j (empty for i = j).
    pub pair: Vec<Vec<Zone>>,
    /// Zone on leaflet i touching any other leaflet.
    pub any: Vec<Zone>,
    /// Zone on leaflet i touching every other leaflet (needs ≥ 3 leaflets).
    pub all: Vec<Zone>,
    /// Triangles refined because their status could change inside them.
    pub refined_triangles: usize,
}

/// Distances from points to one leaflet's surface, capped (beyond the cap
/// only "far" matters).
struct Surface<'a> {
    x: &'a [V3],
    tris: &'a [[u32; 3]],
    bvh: Bvh,
}

impl Surface<'_> {
    fn distance(&self, p: &V3, cap: f64) -> f64 {
        let mut best = cap;
        self.bvh.query_sphere(p, cap, |t| {
            let [a, b, c] = self.tris[t as usize].map(|k| &self.x[k as usize]);
            let d = (closest_point(p, a, b, c).point - p).norm();
            if d < best {
                best = d;
            }
        });
        best
    }
}

/// Field values (distance − margin) of one point against every leaflet;
/// entries for the point's own leaflet are unused.
type Field = Vec<f64>;

fn combine(f: &Field, own: usize, target: Target) -> f64 {
    let others = (0..f.len()).filter(|&j| j != own);
    match target {
        Target::Leaflet(j) => f[j],
        Target::Any => others.map(|j| f[j]).fold(f64::INFINITY, f64::min),
        Target::All => others.map(|j| f[j]).fold(f64::NEG_INFINITY, f64::max),
    }
}

/// A plane standing in for a leaflet: the leaflet is the mirror image of
/// another across it (seed 001's one-leaflet set-up), and the gap to it is
/// twice the signed distance to the plane, negative behind it.
#[derive(Debug, Clone, Copy)]
pub struct MirrorPlane {
    /// The leaflet the plane stands in for (0-based).
    pub leaflet: usize,
    pub point: Point3,
    /// Unit normal towards the measured leaflet.
    pub normal: V3,
}

/// Find the zones of every leaflet of `v` against every target.
pub fn find(v: &ClosedValve, opts: &Options) -> Coaptation {
    find_with_planes(v, opts, &[])
}

/// As [`find`], with some leaflets replaced by their mirror planes: the
/// seed's zone (signed distance to the plane ≤ margin / 2), exactly.
pub fn find_with_planes(v: &ClosedValve, opts: &Options, planes: &[MirrorPlane]) -> Coaptation {
    let nl = v.leaflets;
    let x: Vec<V3> = v.x.iter().map(|p| p.coords).collect();
    let m = opts.margin_mm;
    // Distances are only needed up to a cap that is larger than the margin
    // plus the longest edge, so the Lipschitz bounds below are decided
    // exactly; farther is "far".
    let longest = v.tris.iter().map(|t| edge_max(&x, t)).fold(0.0, f64::max);
    let lip = if planes.is_empty() { 1.0 } else { 2.0 };
    let cap = m + lip * longest + 1e-9;
    let surfaces: Vec<Surface> = (0..nl)
        .map(|j| {
            let ids: Vec<u32> = (0..v.tris.len() as u32)
                .filter(|&t| v.tri_leaflet[t as usize] as usize == j)
                .collect();
            Surface {
                x: &x,
                tris: &v.tris,
                bvh: Bvh::build_subset(&x, &v.tris, &ids),
            }
        })
        .collect();
    let field_at = |p: &V3, own: usize, cap: f64| -> Field {
        (0..nl)
            .map(|j| {
                if j == own {
                    f64::INFINITY
                } else if let Some(pl) = planes.iter().find(|pl| pl.leaflet == j) {
                    2.0 * (p - pl.point.coords).dot(&pl.normal) - m
                } else {
                    surfaces[j].distance(p, cap) - m
                }
            })
            .collect()
    };

    let mut node_leaflet = vec![usize::MAX; x.len()];
    for (t, tri) in v.tris.iter().enumerate() {
        for &k in tri {
            node_leaflet[k as usize] = v.tri_leaflet[t] as usize;
        }
    }
    let node_field: Vec<Option<Field>> = (0..x.len())
        .into_par_iter()
        .map(|k| (node_leaflet[k] != usize::MAX).then(|| field_at(&x[k], node_leaflet[k], cap)))
        .collect();
    let node_mask: Vec<u8> = node_field
        .iter()
        .map(|f| match f {
            Some(f) => (0..nl.min(8))
                .filter(|&j| f[j] <= 0.0)
                .fold(0u8, |b, j| b | (1 << j)),
            None => 0,
        })
        .collect();

    let mut targets: Vec<Target> = (0..nl).map(Target::Leaflet).collect();
    targets.push(Target::Any);
    if nl >= 3 {
        targets.push(Target::All);
    }
    let n = opts.refine.max(1);
    let skip = |own: usize, ti: &Target| matches!(ti, Target::Leaflet(j) if *j == own);
    // Per triangle, in parallel: (target index, piece, cut) in a fixed order;
    // merged below in triangle order, so sums do not depend on threads.
    type Out = (bool, Vec<(usize, Vec<Point3>, Option<[Point3; 2]>)>);
    let per_triangle: Vec<Out> = (0..v.tris.len())
        .into_par_iter()
        .map(|t| {
            let tri = &v.tris[t];
            let own = v.tri_leaflet[t] as usize;
            let corners = tri.map(|k| x[k as usize]);
            let cf = tri.map(|k| node_field[k as usize].as_ref().expect("node of a triangle"));
            let lmax = edge_max(&x, tri);
            // The distance is 1-Lipschitz (a mirror gap 2-): a triangle is
            // wholly in (out of) the zone when every corner is in (out) by
            // more than that times the longest edge.
            let reach = lip * lmax;
            let decided = |ti: &Target| {
                let g = cf.map(|f| combine(f, own, *ti));
                g.iter().all(|&g| g + reach <= 0.0) || g.iter().all(|&g| g - reach > 0.0)
            };
            let split = targets.iter().any(|ti| !skip(own, ti) && !decided(ti));
            let subs: Vec<([V3; 3], [Field; 3])> = if split {
                // Within a refined triangle only the sign pattern of its
                // sub-triangles matters: distances beyond the margin plus
                // twice a sub-edge never change a cut.
                let sub_cap = m + 2.0 * lip * lmax / n as f64 + 1e-9;
                sub_triangles(&corners, n, |p| field_at(p, own, sub_cap))
            } else {
                vec![(corners, cf.map(|f| f.clone()))]
            };
            let mut out = Vec::new();
            for (k, ti) in targets.iter().enumerate() {
                if skip(own, ti) {
                    continue;
                }
                for (p, f) in &subs {
                    let poly: Vec<Vertex> = (0..3)
                        .map(|c| (Point3::from(p[c]), combine(&f[c], own, *ti)))
                        .collect();
                    let (piece, cut) = clip::clip_below(&poly);
                    if !piece.is_empty() || cut.is_some() {
                        out.push((k, piece, cut));
                    }
                }
            }
            (split, out)
        })
        .collect();
    // zones[i][target index]
    let mut zones: Vec<Vec<Zone>> = vec![vec![Zone::default(); targets.len()]; nl];
    let mut refined = 0;
    for (t, (split, out)) in per_triangle.into_iter().enumerate() {
        refined += split as usize;
        let own = v.tri_leaflet[t] as usize;
        for (k, piece, cut) in out {
            let zone = &mut zones[own][k];
            if let Some(c) = cut {
                zone.boundary.push(c);
            }
            if !piece.is_empty() {
                zone.area_mm2 += clip::area(&piece);
                zone.pieces.push(piece);
            }
        }
    }
    let mut pair = vec![Vec::new(); nl];
    let mut any = Vec::with_capacity(nl);
    let mut all = Vec::with_capacity(nl);
    for (i, mut zi) in zones.into_iter().enumerate() {
        let a = if nl >= 3 { zi.pop() } else { None };
        any.push(zi.pop().expect("target Any"));
        all.push(a.unwrap_or_default());
        pair[i] = zi;
    }
    if nl == 2 {
        // With two leaflets "all others" is the one other.
        all = any.clone();
    }
    Coaptation {
        options: *opts,
        node_mask,
        pair,
        any,
        all,
        refined_triangles: refined,
    }
}

fn edge_max(x: &[V3], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|k| x[k as usize]);
    (b - a).norm().max((c - b).norm()).max((a - c).norm())
}

/// The n² sub-triangles of a triangle (same orientation), with the field at
/// their corners; each grid point is evaluated once.
fn sub_triangles(
    c: &[V3; 3],
    n: usize,
    field: impl Fn(&V3) -> Field,
) -> Vec<([V3; 3], [Field; 3])> {
    // Grid point (i, j), i + j ≤ n: c0 + (c1 − c0)·i/n + (c2 − c0)·j/n.
    let mut pts = Vec::new();
    let mut at = vec![vec![usize::MAX; n + 1]; n + 1];
    for i in 0..=n {
        for j in 0..=n - i {
            let p = c[0]
                + (c[1] - c[0]) * (i as f64 / n as f64)
                + (c[2] - c[0]) * (j as f64 / n as f64);
            at[i][j] = pts.len();
            pts.push(p);
        }
    }
    let f: Vec<Field> = pts.iter().map(&field).collect();
    let tri = |a: usize, b: usize, d: usize| {
        (
            [pts[a], pts[b], pts[d]],
            [f[a].clone(), f[b].clone(), f[d].clone()],
        )
    };
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n - i {
            out.push(tri(at[i][j], at[i + 1][j], at[i][j + 1]));
            if i + j + 1 < n {
                out.push(tri(at[i + 1][j], at[i + 1][j + 1], at[i][j + 1]));
            }
        }
    }
    out
}
