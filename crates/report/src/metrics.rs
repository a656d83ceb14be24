//! The coaptation numbers (docs/report.md: "Where leaflets touch", `report.json`):
//! heights along the valve axis measured from the annulus plane, areas on
//! the closed leaflets, the free edge, billowing, the regurgitant orifice.

use std::collections::BTreeMap;

use coapt_geom::Point3;

use super::ClosedValve;
use super::clip::{self, Vertex};
use super::coaptation::{Coaptation, Zone};
use super::orifice;

/// How heights and the orifice are measured.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Width of the radial columns across a coaptation strip, mm.
    pub column_mm: f64,
    /// Distance from the axis at which h_C-C is read, mm (seeds: 5 mm).
    pub hcc_radius_mm: f64,
    /// Pixel of the orifice raster, mm.
    pub pixel_mm: f64,
    /// Half the leaflet thickness, mm: the shadow of a mid-surface
    /// triangle reaches this far beyond its edges (two leaflets pressed
    /// together by true contact keep their mid-surfaces a thickness apart,
    /// and a bare mid-surface shadow leaves that slit open).
    pub half_thickness_mm: f64,
    /// Leaflets whose own numbers are reported (the first ones); the others
    /// only serve as neighbours (mirror images of a one-leaflet closure).
    /// `None`: all.
    pub measured: Option<usize>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            column_mm: 0.5,
            hcc_radius_mm: 5.0,
            pixel_mm: 0.05,
            half_thickness_mm: 0.0,
            measured: None,
        }
    }
}

/// Weighted summary of a distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    pub min: f64,
    pub mean: f64,
    pub max: f64,
    pub p10: f64,
    pub p25: f64,
    pub p50: f64,
    pub p75: f64,
    pub p90: f64,
}

impl Stats {
    /// `None` for no samples or zero total weight.
    pub fn weighted(samples: &[(f64, f64)]) -> Option<Stats> {
        let mut s: Vec<(f64, f64)> = samples
            .iter()
            .copied()
            .filter(|(v, w)| v.is_finite() && *w > 0.0)
            .collect();
        let total: f64 = s.iter().map(|x| x.1).sum();
        if s.is_empty() || total <= 0.0 {
            return None;
        }
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        let pct = |p: f64| {
            let mut acc = 0.0;
            for &(v, w) in &s {
                acc += w;
                if acc >= p * total {
                    return v;
                }
            }
            s[s.len() - 1].0
        };
        Some(Stats {
            min: s[0].0,
            mean: s.iter().map(|(v, w)| v * w).sum::<f64>() / total,
            max: s[s.len() - 1].0,
            p10: pct(0.10),
            p25: pct(0.25),
            p50: pct(0.50),
            p75: pct(0.75),
            p90: pct(0.90),
        })
    }
}

/// Two leaflets' common zone.
#[derive(Debug, Clone)]
pub struct Pair {
    /// 0-based leaflets (i < j).
    pub leaflets: [usize; 2],
    /// Seeds: largest axial extent over radial columns of both sides' zones.
    pub height_mm: Option<f64>,
    /// Zone area on leaflet i touching j, and on j touching i.
    pub area_mm2: [f64; 2],
    /// Axial extent of the zone in the column at `hcc_radius_mm` from the axis.
    pub h_cc_mm: Option<f64>,
    /// SlicerHeart: distance from each point of the base line (where the
    /// leaflets start to touch) to the margin line (the free edge in the
    /// zone), weighted by base-line length.
    pub base_to_margin_mm: Option<Stats>,
}

/// One leaflet's numbers.
#[derive(Debug, Clone)]
pub struct Leaflet {
    pub coaptation_area_mm2: f64,
    pub free_edge_length_mm: f64,
    /// Area before closure: on the flat template when the mesh has `ref_uv`,
    /// else as placed.
    pub leaflet_area_mm2: f64,
    pub cusp_area_closed_mm2: f64,
    /// Depth of the lowest point below the plane of the three lowest sutured
    /// points (positive: the belly bulges below it).
    pub billowing_mm: f64,
    /// Height above the annulus plane of the free-edge point nearest the axis.
    pub central_free_edge_height_mm: Option<f64>,
    /// Distance of that point from the axis.
    pub central_free_edge_radius_mm: Option<f64>,
    pub lowest_free_edge_mm: f64,
}

/// Everything measured on one closed valve.
#[derive(Debug, Clone)]
pub struct Metrics {
    pub coaptation_height_mm: Option<f64>,
    pub central_coaptation_height_mm: Option<f64>,
    /// At the closing pressure (the positions measured).
    pub effective_height_mm: Option<f64>,
    /// On an extra closure at a low pressure (the seeds' 3 mmHg), when the
    /// close stage made one; set by the stage with [`effective_height_at`].
    pub effective_height_low_pressure_mm: Option<f64>,
    /// Top of the zone where all three leaflets touch, above the annulus.
    pub central_coaptation_top_mm: Option<f64>,
    /// Highest point of the measured leaflets above the annulus plane.
    pub highest_leaflet_mm: f64,
    pub h_cc_mm: Option<f64>,
    pub h_avr_mm: Option<f64>,
    pub ncca: Option<f64>,
    /// `None` when only some leaflets are measured (the mirror images of a
    /// one-leaflet closure do not tile the lumen).
    pub regurgitant_orifice_area_mm2: Option<f64>,
    pub lumen_area_mm2: Option<f64>,
    /// Pixel of the orifice raster, mm, when it was drawn.
    pub orifice_pixel_mm: Option<f64>,
    /// The central coaptation (where all three leaflets touch; without one,
    /// the zones where two touch) lies above the annulus plane.
    pub coaptation_above_vaj: Option<bool>,
    /// Lowest point of the central coaptation above the annulus plane.
    pub lowest_central_coaptation_mm: Option<f64>,
    /// Lowest point of any coaptation (two leaflets touching, next to the
    /// commissures too) above the annulus plane.
    pub lowest_coaptation_mm: Option<f64>,
    pub lowest_free_edge_mm: f64,
    pub closed: bool,
    pub leaflets: Vec<Leaflet>,
    pub pairs: Vec<Pair>,
}

/// Height above the annulus plane and distance from the axis.
fn hr(v: &ClosedValve, p: &Point3) -> (f64, f64) {
    let (h, _, r) = v.frame.to_cylindrical(p);
    (h, r)
}

fn extent(points: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    points.fold(None, |acc, z| match acc {
        None => Some((z, z)),
        Some((lo, hi)) => Some((lo.min(z), hi.max(z))),
    })
}

/// Axial extent (lo, hi) per radial column [c·w, (c+1)·w) of zone pieces.
fn columns(v: &ClosedValve, zones: &[&Zone], w: f64) -> BTreeMap<i64, (f64, f64)> {
    let mut out: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
    for z in zones {
        for piece in &z.pieces {
            let r: Vec<f64> = piece.iter().map(|p| hr(v, p).1).collect();
            let (rlo, rhi) = extent(r.iter().copied()).expect("pieces have vertices");
            for c in (rlo / w).floor() as i64..=(rhi / w).floor() as i64 {
                if let Some((lo, hi)) = band(v, piece, c as f64 * w, (c + 1) as f64 * w) {
                    let e = out.entry(c).or_insert((lo, hi));
                    e.0 = e.0.min(lo);
                    e.1 = e.1.max(hi);
                }
            }
        }
    }
    out
}

/// Axial extent of the part of a piece whose distance from the axis lies in
/// [lo, hi].
fn band(v: &ClosedValve, piece: &[Point3], lo: f64, hi: f64) -> Option<(f64, f64)> {
    let a: Vec<Vertex> = piece.iter().map(|p| (*p, lo - hr(v, p).1)).collect();
    let (a, _) = clip::clip_below(&a);
    let b: Vec<Vertex> = a.iter().map(|p| (*p, hr(v, p).1 - hi)).collect();
    let (b, _) = clip::clip_below(&b);
    extent(b.iter().map(|p| hr(v, p).0))
}

/// Edges of the free edge (boundary edges with a free-edge node) per leaflet.
pub fn free_edges(v: &ClosedValve) -> Vec<Vec<[u32; 2]>> {
    let mut count: BTreeMap<[u32; 2], (usize, usize)> = BTreeMap::new();
    for (t, tri) in v.tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let e = count.entry([a.min(b), a.max(b)]).or_insert((0, t));
            e.0 += 1;
        }
    }
    let mut out = vec![Vec::new(); v.leaflets];
    for (e, (n, t)) in count {
        if n == 1 && (v.boundary[e[0] as usize] == 2 || v.boundary[e[1] as usize] == 2) {
            out[v.tri_leaflet[t] as usize].push(e);
        }
    }
    out
}

fn point_segment(p: &Point3, a: &Point3, b: &Point3) -> f64 {
    let ab = b - a;
    let t = if ab.norm_squared() > 0.0 {
        ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

fn tri_area(a: &Point3, b: &Point3, c: &Point3) -> f64 {
    0.5 * (b - a).cross(&(c - a)).norm()
}

/// The free-edge point nearest the axis (on the segments): (distance from
/// the axis, height above the annulus plane), for positions `x`.
pub fn central_free_edge(v: &ClosedValve, x: &[Point3], edges: &[[u32; 2]]) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    for e in edges {
        let (a, b) = (
            v.frame.to_local(&x[e[0] as usize]),
            v.frame.to_local(&x[e[1] as usize]),
        );
        let d = b - a;
        let dd = d.x * d.x + d.y * d.y;
        let t = if dd > 0.0 {
            (-(a.x * d.x + a.y * d.y) / dd).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = a + d * t;
        let r = q.x.hypot(q.y);
        if best.is_none_or(|(br, _)| r < br) {
            best = Some((r, q.z));
        }
    }
    best
}

/// Effective height on other positions of the same leaflets (e.g. an extra
/// closure at the seeds' 3 mmHg): mean over the measured leaflets of the
/// height of the free-edge point nearest the axis.
pub fn effective_height_at(v: &ClosedValve, x: &[Point3], measured: usize) -> Option<f64> {
    let free = free_edges(v);
    let h: Vec<f64> = free
        .iter()
        .take(measured)
        .filter_map(|e| central_free_edge(v, x, e).map(|b| b.1))
        .collect();
    (!h.is_empty()).then(|| h.iter().sum::<f64>() / h.len() as f64)
}

/// Highest point above the annulus plane of the first `measured` leaflets
/// at positions `x`.
pub fn highest_at(v: &ClosedValve, x: &[Point3], measured: usize) -> f64 {
    let mut on = vec![false; x.len()];
    for (t, tri) in v.tris.iter().enumerate() {
        if (v.tri_leaflet[t] as usize) < measured {
            for &k in tri {
                on[k as usize] = true;
            }
        }
    }
    x.iter()
        .zip(&on)
        .filter(|(_, on)| **on)
        .map(|(p, _)| hr(v, p).0)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Measure a closed valve whose zones are `c`.
pub fn measure(v: &ClosedValve, c: &Coaptation, opts: &Options) -> Metrics {
    let nl = v.leaflets;
    let nm = opts.measured.unwrap_or(nl).min(nl);
    let free = free_edges(v);
    let x = &v.x;

    // Per-leaflet areas and free edge.
    let mut cusp = vec![0.0; nl];
    let mut flat = vec![0.0; nl];
    for (t, tri) in v.tris.iter().enumerate() {
        let l = v.tri_leaflet[t] as usize;
        let [a, b, d] = tri.map(|k| k as usize);
        cusp[l] += tri_area(&x[a], &x[b], &x[d]);
        flat[l] += match &v.ref_uv {
            Some(uv) => {
                let p = |k: usize| Point3::new(uv[k][0], uv[k][1], 0.0);
                tri_area(&p(a), &p(b), &p(d))
            }
            None => tri_area(&v.x0[a], &v.x0[b], &v.x0[d]),
        };
    }

    // Billowing: plane through the lowest sutured point of each leaflet.
    let mut lowest_sutured: Vec<Option<Point3>> = vec![None; nl];
    let mut node_leaflet = vec![usize::MAX; x.len()];
    for (t, tri) in v.tris.iter().enumerate() {
        for &k in tri {
            node_leaflet[k as usize] = v.tri_leaflet[t] as usize;
        }
    }
    for (k, p) in x.iter().enumerate() {
        let l = node_leaflet[k];
        if l == usize::MAX || v.boundary[k] != 1 {
            continue;
        }
        let h = hr(v, p).0;
        if lowest_sutured[l].is_none_or(|q| h < hr(v, &q).0) {
            lowest_sutured[l] = Some(*p);
        }
    }
    let axis = v.frame.axis;
    let (plane_p, plane_n) = match lowest_sutured.as_slice() {
        [Some(a), Some(b), Some(d)] => {
            let n = (b - a).cross(&(d - a));
            match n.try_normalize(1e-9) {
                Some(n) => (*a, if n.dot(&axis) < 0.0 { -n } else { n }),
                None => (*a, axis),
            }
        }
        _ => {
            let low = lowest_sutured
                .iter()
                .flatten()
                .min_by(|p, q| hr(v, p).0.total_cmp(&hr(v, q).0))
                .copied()
                .unwrap_or(v.frame.origin_mm);
            (low, axis)
        }
    };

    let mut leaflets = Vec::with_capacity(nm);
    for l in 0..nm {
        let mut depth = f64::NEG_INFINITY;
        for (k, p) in x.iter().enumerate() {
            if node_leaflet[k] == l {
                depth = depth.max(-(p - plane_p).dot(&plane_n));
            }
        }
        let edges = &free[l];
        let length: f64 = edges
            .iter()
            .map(|e| (x[e[1] as usize] - x[e[0] as usize]).norm())
            .sum();
        let best = central_free_edge(v, x, edges);
        let lowest_free = edges
            .iter()
            .flatten()
            .map(|&k| hr(v, &x[k as usize]).0)
            .fold(f64::INFINITY, f64::min);
        leaflets.push(Leaflet {
            coaptation_area_mm2: c.any[l].area_mm2,
            free_edge_length_mm: length,
            leaflet_area_mm2: flat[l],
            cusp_area_closed_mm2: cusp[l],
            // The plane passes through each leaflet's lowest sutured point:
            // when nothing lies lower the depth is zero up to round-off,
            // which printed as −0 and −4e-16 in reports.
            billowing_mm: if depth.abs() < 1e-9 { 0.0 } else { depth },
            central_free_edge_height_mm: best.map(|b| b.1),
            central_free_edge_radius_mm: best.map(|b| b.0),
            lowest_free_edge_mm: lowest_free,
        });
    }

    // Pairs: seeds' column heights, h_C-C, SlicerHeart base-to-margin.
    let w = opts.column_mm;
    let mut pairs = Vec::new();
    for i in 0..nm {
        for j in i + 1..nl {
            let zi = &c.pair[i][j];
            let zj = &c.pair[j][i];
            let cols = columns(v, &[zi, zj], w);
            let height = cols
                .values()
                .map(|(lo, hi)| hi - lo)
                .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))));
            let r0 = opts.hcc_radius_mm;
            let hcc = [zi, zj]
                .iter()
                .flat_map(|z| z.pieces.iter())
                .filter_map(|p| band(v, p, r0 - 0.5 * w, r0 + 0.5 * w))
                .fold(None, |acc: Option<(f64, f64)>, (lo, hi)| {
                    Some(acc.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))))
                })
                .map(|(lo, hi)| hi - lo);
            let mut samples = Vec::new();
            for (a, b, z) in [(i, j, zi), (j, i, zj)] {
                let margin: Vec<&[u32; 2]> = free[a]
                    .iter()
                    .filter(|e| e.iter().all(|&k| c.node_mask[k as usize] & (1 << b) != 0))
                    .collect();
                if margin.is_empty() {
                    continue;
                }
                for s in &z.boundary {
                    let mid = Point3::from((s[0].coords + s[1].coords) * 0.5);
                    let len = (s[1] - s[0]).norm();
                    let d = margin
                        .iter()
                        .map(|e| point_segment(&mid, &x[e[0] as usize], &x[e[1] as usize]))
                        .fold(f64::INFINITY, f64::min);
                    samples.push((d, len));
                }
            }
            pairs.push(Pair {
                leaflets: [i, j],
                height_mm: height,
                area_mm2: [zi.area_mm2, zj.area_mm2],
                h_cc_mm: hcc,
                base_to_margin_mm: Stats::weighted(&samples),
            });
        }
    }

    let coaptation_height = pairs
        .iter()
        .filter_map(|p| p.height_mm)
        .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))));
    let central = extent(
        c.all[..nm]
            .iter()
            .flat_map(|z| z.points())
            .map(|p| hr(v, p).0),
    );
    let central_height = central.map(|(lo, hi)| hi - lo);
    let closed = central.is_some();
    let hcc: Vec<f64> = pairs.iter().filter_map(|p| p.h_cc_mm).collect();
    let h_cc = (!hcc.is_empty()).then(|| hcc.iter().sum::<f64>() / hcc.len() as f64);
    let eff: Vec<f64> = leaflets
        .iter()
        .filter_map(|l| l.central_free_edge_height_mm)
        .collect();
    let effective = (!eff.is_empty()).then(|| eff.iter().sum::<f64>() / eff.len() as f64);
    let coapt_total: f64 = leaflets.iter().map(|l| l.coaptation_area_mm2).sum();
    let free_total: f64 = leaflets.iter().map(|l| l.free_edge_length_mm).sum();
    let cusp_total: f64 = cusp[..nm].iter().sum();
    let any_zone = extent(
        c.any[..nm]
            .iter()
            .flat_map(|z| z.points())
            .map(|p| hr(v, p).0),
    );
    let orifice = (nm == nl).then(|| orifice::measure(v, opts.pixel_mm, opts.half_thickness_mm));
    Metrics {
        coaptation_height_mm: coaptation_height,
        central_coaptation_height_mm: central_height,
        effective_height_mm: effective,
        effective_height_low_pressure_mm: None,
        central_coaptation_top_mm: central.map(|(_, hi)| hi),
        highest_leaflet_mm: highest_at(v, x, nm),
        h_cc_mm: h_cc,
        h_avr_mm: (free_total > 0.0).then(|| coapt_total / free_total),
        ncca: (cusp_total > 0.0).then(|| coapt_total / cusp_total),
        regurgitant_orifice_area_mm2: orifice.as_ref().map(|o| o.uncovered_mm2),
        lumen_area_mm2: orifice.as_ref().map(|o| o.lumen_mm2),
        orifice_pixel_mm: orifice.as_ref().map(|o| o.pixel_mm),
        // Without a triple zone the pairwise zones are all there is to place.
        coaptation_above_vaj: central.or(any_zone).map(|(lo, _)| lo > 0.0),
        lowest_central_coaptation_mm: central.map(|(lo, _)| lo),
        lowest_coaptation_mm: any_zone.map(|(lo, _)| lo),
        lowest_free_edge_mm: leaflets
            .iter()
            .map(|l| l.lowest_free_edge_mm)
            .fold(f64::INFINITY, f64::min),
        closed,
        leaflets,
        pairs,
    }
}
