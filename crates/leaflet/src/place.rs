//! Placement of a flat leaflet mesh in 3-D (seed 001 §2.1 step 3,
//! generalised): attachment nodes go by arc length onto the suture path;
//! every other node is extruded from its attachment point along
//! v = sin ω·e_r + cos ω·axis (e_r the leaflet's outward mid direction, so
//! ω < 0 leans the free edge towards the axis).
//!
//! * seed 001 templates: (t, t̂) are exact; the node sits at
//!   P(L(t)/L) + (t̂ − t̂_att(t))·v, which on the ideal cylinder is eq. 2–3.
//! * flat templates: (s, λ) come from two harmonic fields on the flat mesh
//!   (s = normalised arc length on both edges, λ = 0 sutured, 1 free), and
//!   the extrusion length is λ times the flat distance between the
//!   attachment and free-edge points of equal s (the template's "column").

use super::aft::FlatMesh;
use coapt_geom::{Point3, Vector3};
use coapt_template::Template;
use coapt_template::outline::P2;
use coapt_template::seed001::Seed001;

/// How a template's attachment edge is spread over a shorter suture path.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Gathering {
    /// Evenly: every piece of the edge shortened by the same ratio.
    Uniform,
    /// As Ozaki's running suture takes it (the seeds' group's
    /// `onethirdCDF`, benchmarks/Sewing): 1 : 1 up both posts and 3 : 1 in
    /// a middle stretch about the nadir, as wide as the excess needs. The
    /// posts keep the template's length, the belly takes the excess.
    Ozaki,
}

/// Arc-length parametrised 3-D polyline.
pub struct Path3 {
    pts: Vec<Point3>,
    cum: Vec<f64>,
    /// Path length over the attachment edge's (J₀ < 1) when the edge is
    /// gathered onto the path the Ozaki way; `at` then takes fractions of
    /// the edge, not of the path.
    ozaki_j0: Option<f64>,
}

impl Path3 {
    pub fn new(pts: Vec<Point3>) -> Path3 {
        let mut cum = vec![0.0];
        for w in pts.windows(2) {
            cum.push(cum.last().unwrap() + (w[1] - w[0]).norm());
        }
        Path3 {
            pts,
            cum,
            ozaki_j0: None,
        }
    }

    /// The path an attachment edge of `edge_mm` is sewn onto: `at(f)` is
    /// where the point at fraction f of the edge goes. The Ozaki rule
    /// needs 1 : 1 posts and at most 3 : 1 at the nadir, so it applies to
    /// a path 34–97 % of the edge's length (the group's own bounds, 0.34 and
    /// 0.97); outside them, and for a path longer than the edge, the edge
    /// is spread evenly.
    pub fn sewn(pts: Vec<Point3>, edge_mm: f64, gathering: Gathering) -> Path3 {
        let mut p = Path3::new(pts);
        let j0 = p.length() / edge_mm;
        if gathering == Gathering::Ozaki && (0.34..=0.97).contains(&j0) {
            p.ozaki_j0 = Some(j0);
        }
        p
    }

    pub fn length(&self) -> f64 {
        *self.cum.last().unwrap()
    }

    /// The gathering `at` applies ("ozaki" only within its range).
    pub fn gathering(&self) -> Gathering {
        if self.ozaki_j0.is_some() {
            Gathering::Ozaki
        } else {
            Gathering::Uniform
        }
    }

    /// Fraction of the path at which fraction x of the edge is sewn.
    fn gathered(&self, x: f64) -> f64 {
        let Some(j0) = self.ozaki_j0 else {
            return x;
        };
        // Three pieces: x/J₀ (1 : 1) up to 0.5 − d, slope 1/(3J₀) across
        // the middle 2d, 1 : 1 again after; d = 3(1 − J₀)/4 makes the
        // total come out at the path's length.
        let d = 0.75 * (1.0 - j0);
        if x < 0.5 - d {
            x / j0
        } else if x < 0.5 + d {
            (1.0 - 2.0 * d + x) / (3.0 * j0)
        } else {
            (x - 4.0 * d / 3.0) / j0
        }
    }

    /// Point at fraction f ∈ [0, 1] of the edge (of the path, unless
    /// gathered the Ozaki way).
    pub fn at(&self, f: f64) -> Point3 {
        let s = self.gathered(f.clamp(0.0, 1.0)) * self.length();
        let i = self
            .cum
            .partition_point(|&c| c <= s)
            .clamp(1, self.pts.len() - 1);
        let d = self.cum[i] - self.cum[i - 1];
        let t = if d > 0.0 {
            (s - self.cum[i - 1]) / d
        } else {
            0.0
        };
        self.pts[i - 1] + (self.pts[i] - self.pts[i - 1]) * t
    }
}

/// The sutured boundary chain in outline order (from one lug corner to the
/// other) and the free chain from the far lug back.
pub fn chains(m: &FlatMesh) -> (Vec<u32>, Vec<u32>) {
    let n = m.n_boundary;
    // The chain starts at a sutured node whose predecessor is free.
    let start = (0..n)
        .find(|&i| m.boundary[i] == 1 && m.boundary[(i + n - 1) % n] == 2)
        .unwrap_or(0);
    let mut sut = Vec::new();
    let mut free = Vec::new();
    for k in 0..n {
        let i = (start + k) % n;
        if m.boundary[i] == 1 && free.is_empty() {
            sut.push(i as u32);
        } else {
            free.push(i as u32);
        }
    }
    // The free chain runs from the last sutured node to the first.
    free.insert(0, *sut.last().unwrap());
    free.push(sut[0]);
    (sut, free)
}

fn cumulative(m: &FlatMesh, chain: &[u32]) -> Vec<f64> {
    let mut c = vec![0.0];
    for w in chain.windows(2) {
        let (a, b) = (m.nodes[w[0] as usize], m.nodes[w[1] as usize]);
        c.push(c.last().unwrap() + (a[0] - b[0]).hypot(a[1] - b[1]));
    }
    let t = *c.last().unwrap();
    c.iter().map(|x| x / t).collect()
}

/// Harmonic interpolation (uniform graph Laplacian, conjugate gradients)
/// of Dirichlet values given on the boundary nodes.
fn harmonic(m: &FlatMesh, fixed: &[Option<f64>]) -> Vec<f64> {
    let n = m.nodes.len();
    let mut nbr: Vec<Vec<u32>> = vec![Vec::new(); n];
    for t in &m.tris {
        for k in 0..3 {
            nbr[t[k] as usize].push(t[(k + 1) % 3]);
            nbr[t[(k + 1) % 3] as usize].push(t[k]);
        }
    }
    for v in nbr.iter_mut() {
        v.sort_unstable();
        v.dedup();
    }
    let free: Vec<usize> = (0..n).filter(|&i| fixed[i].is_none()).collect();
    let mut idx = vec![usize::MAX; n];
    for (k, &i) in free.iter().enumerate() {
        idx[i] = k;
    }
    let apply = |x: &[f64], out: &mut [f64]| {
        for (k, &i) in free.iter().enumerate() {
            let mut s = nbr[i].len() as f64 * x[k];
            for &j in &nbr[i] {
                if idx[j as usize] != usize::MAX {
                    s -= x[idx[j as usize]];
                }
            }
            out[k] = s;
        }
    };
    let b: Vec<f64> = free
        .iter()
        .map(|&i| nbr[i].iter().filter_map(|&j| fixed[j as usize]).sum())
        .collect();
    let nf = free.len();
    let mut x = vec![0.5; nf];
    let mut r = vec![0.0; nf];
    apply(&x, &mut r);
    for k in 0..nf {
        r[k] = b[k] - r[k];
    }
    let mut p = r.clone();
    let mut ap = vec![0.0; nf];
    let mut rr: f64 = r.iter().map(|v| v * v).sum();
    let bn: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-30);
    for _ in 0..4 * nf + 10 {
        if rr.sqrt() < 1e-12 * bn {
            break;
        }
        apply(&p, &mut ap);
        let pap: f64 = p.iter().zip(&ap).map(|(a, b)| a * b).sum();
        let a = rr / pap;
        for k in 0..nf {
            x[k] += a * p[k];
            r[k] -= a * ap[k];
        }
        let rr2: f64 = r.iter().map(|v| v * v).sum();
        for k in 0..nf {
            p[k] = r[k] + rr2 / rr * p[k];
        }
        rr = rr2;
    }
    (0..n)
        .map(|i| fixed[i].unwrap_or_else(|| x[idx[i]]))
        .collect()
}

/// Per node: normalised attachment abscissa s and extrusion length w (mm).
pub fn column_coords(t: &Template, m: &FlatMesh) -> (Vec<f64>, Vec<f64>) {
    if let Template::Seed001(s) = t {
        return seed001_coords(s, m);
    }
    let c = columns(m);
    let w = c.lam.iter().zip(&c.len).map(|(l, n)| l * n).collect();
    (c.s, w)
}

/// A flat template's columns: per node, the normalised attachment abscissa
/// s, the fraction λ of the way from the sutured edge (0) to the free edge
/// (1), and the flat length of its column (the distance between the
/// attachment and free-edge points of equal s).
pub struct Columns {
    pub s: Vec<f64>,
    pub lam: Vec<f64>,
    pub len: Vec<f64>,
}

pub fn columns(m: &FlatMesh) -> Columns {
    let (sut, free) = chains(m);
    let cs = cumulative(m, &sut);
    let cf = cumulative(m, &free);
    let n = m.nodes.len();
    let mut fs = vec![None; n];
    let mut fl = vec![None; n];
    for (k, &i) in sut.iter().enumerate() {
        fs[i as usize] = Some(cs[k]);
        fl[i as usize] = Some(0.0);
    }
    for (k, &i) in free.iter().enumerate().skip(1).take(free.len() - 2) {
        // Free edge runs from the far lug (s = 1) back to the first (s = 0).
        fs[i as usize] = Some(1.0 - cf[k]);
        fl[i as usize] = Some(1.0);
    }
    let s = harmonic(m, &fs);
    let lam = harmonic(m, &fl);
    let at = |chain: &[u32], c: &[f64], f: f64| -> P2 {
        let j = c.partition_point(|&x| x <= f).clamp(1, chain.len() - 1);
        let d = c[j] - c[j - 1];
        let u = if d > 0.0 { (f - c[j - 1]) / d } else { 0.0 };
        let (a, b) = (m.nodes[chain[j - 1] as usize], m.nodes[chain[j] as usize]);
        [a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u]
    };
    let len = (0..n)
        .map(|i| {
            let p = at(&sut, &cs, s[i]);
            let q = at(&free, &cf, 1.0 - s[i]);
            (p[0] - q[0]).hypot(p[1] - q[1])
        })
        .collect();
    Columns { s, lam, len }
}

fn seed001_coords(s: &Seed001, m: &FlatMesh) -> (Vec<f64>, Vec<f64>) {
    let total = s.attachment_length();
    let mut ss = Vec::with_capacity(m.nodes.len());
    let mut ww = Vec::with_capacity(m.nodes.len());
    for p in &m.nodes {
        let t = s.t_of_sigma(p[0]);
        ss.push(s.attachment_length_to(t) / total);
        ww.push(boundary_w(s, t, p[1], m.boundary[ss.len() - 1]));
    }
    (ss, ww)
}

/// Extrusion length of a node: boundary nodes sit exactly on eq. 2 (w = 0)
/// or at the eq. 3 free edge (w = d(t)); the flat outline is sampled, so
/// their t̂ carries the sampling's chord error, which must not leak into 3-D.
fn boundary_w(s: &Seed001, t: f64, that: f64, boundary: u8) -> f64 {
    match boundary {
        1 => 0.0,
        2 => s.d(t),
        _ => that - s.that_att(t),
    }
}

/// Patient placement: node = P(s) + w·(sin ω·e_r(s) + cos ω·axis), with
/// e_r(s) the outward radial unit at the attachment point. Radial (rather
/// than seed 001's single v per leaflet) keeps every node at the angle of
/// its attachment point, so each leaflet stays in the wedge between its two
/// commissures and leaflets cannot cross. |ω| is reduced, if needed, so no
/// node comes closer than `min_r` to the axis; the ω used is returned.
pub fn place_radial(
    s: &[f64],
    w: &[f64],
    path: &Path3,
    axis: &Vector3,
    centre: &Point3,
    omega: f64,
    min_r: f64,
) -> (Vec<Point3>, f64) {
    let radial = |p: &Point3| {
        let d = p - centre;
        let r = d - axis * d.dot(axis);
        (r.norm(), r.normalize())
    };
    let mut om = omega;
    if omega < 0.0 {
        for (&si, &wi) in s.iter().zip(w) {
            if wi > 0.0 {
                let (r, _) = radial(&path.at(si));
                let lim = ((r - min_r).max(0.0) / wi).min(1.0).asin();
                om = om.max(-lim);
            }
        }
    }
    // Two leaflets share the commissure posts (the straight parts of
    // their attachment lines lie at the commissure angle). Off the
    // attachment edge each node is turned about the axis towards the
    // leaflet's mid angle, by a tenth of its angular offset at most, so
    // only sutured nodes ever reach the wedge's bounding planes.
    let (_, ea) = radial(&path.at(0.0));
    let (_, eb) = radial(&path.at(1.0));
    let emid = (ea + eb).normalize();
    let x = s
        .iter()
        .zip(w)
        .map(|(&si, &wi)| {
            let p = path.at(si);
            let (_, er) = radial(&p);
            let q = p + (er * om.sin() + axis * om.cos()) * wi;
            if wi <= 0.0 {
                return q;
            }
            let off = emid.cross(&er).dot(axis).atan2(emid.dot(&er));
            let turn = -off * 0.1 * wi / (wi + 1.0);
            let d = q - centre;
            let (sn, cs) = turn.sin_cos();
            // Rodrigues rotation about the axis through the centre.
            centre + d * cs + axis.cross(&d) * sn + axis * axis.dot(&d) * (1.0 - cs)
        })
        .collect();
    (x, om)
}

/// Fibre directions per triangle: M = cos θ e_x ± sin θ e_y on the flat
/// template, pushed forward by each triangle's flat → 3-D affine map.
pub fn fibres(m: &FlatMesh, x: &[Point3], theta: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut f1 = Vec::with_capacity(m.tris.len());
    let mut f2 = Vec::with_capacity(m.tris.len());
    for t in &m.tris {
        let [a, b, c] = t.map(|i| i as usize);
        let (u1, u2) = (
            [m.nodes[b][0] - m.nodes[a][0], m.nodes[b][1] - m.nodes[a][1]],
            [m.nodes[c][0] - m.nodes[a][0], m.nodes[c][1] - m.nodes[a][1]],
        );
        let det = u1[0] * u2[1] - u1[1] * u2[0];
        let (x1, x2) = (x[b] - x[a], x[c] - x[a]);
        let push = |m2: [f64; 2]| -> [f64; 3] {
            // Solve [u1 u2]·(α, β) = M, then F·M = α x1 + β x2.
            let al = (m2[0] * u2[1] - m2[1] * u2[0]) / det;
            let be = (u1[0] * m2[1] - u1[1] * m2[0]) / det;
            let v = (x1 * al + x2 * be).normalize();
            [v.x, v.y, v.z]
        };
        f1.push(push([theta.cos(), theta.sin()]));
        f2.push(push([theta.cos(), -theta.sin()]));
    }
    (f1, f2)
}

/// Seed 001 on its own ideal cylinder (local frame): eq. 2–3 exactly.
pub fn seed001_local(s: &Seed001, m: &FlatMesh) -> Vec<Point3> {
    let v = s.v();
    m.nodes
        .iter()
        .zip(&m.boundary)
        .map(|(p, &b)| {
            let t = s.t_of_sigma(p[0]);
            let c = s.rc(t);
            let w = boundary_w(s, t, p[1], b);
            Point3::new(c[0] + w * v[0], c[1] + w * v[1], c[2] + w * v[2])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight path along x, so a point's x is its arc length.
    fn line(len: f64) -> Vec<Point3> {
        (0..=200)
            .map(|k| Point3::new(len * k as f64 / 200.0, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn the_ozaki_gathering_sews_the_posts_one_to_one_and_the_nadir_three_to_one() {
        let (edge, path_len) = (70.0, 47.5);
        let p = Path3::sewn(line(path_len), edge, Gathering::Ozaki);
        let j0 = path_len / edge;
        let d = 0.75 * (1.0 - j0);
        let x = |f: f64| p.at(f).x;
        // Up either post, a millimetre of edge takes a millimetre of path.
        for f in [0.05, 0.1, 0.2, 0.5 - d - 0.01] {
            let along = x(f + 0.005) - x(f);
            assert!((along - 0.005 * edge).abs() < 1e-9, "f {f}: {along}");
            let back = x(1.0 - f) - x(1.0 - f - 0.005);
            assert!((back - 0.005 * edge).abs() < 1e-9, "f {f}: {back}");
        }
        // About the nadir, three millimetres of edge on one of path.
        for f in [0.5 - d + 0.01, 0.5, 0.5 + d - 0.02] {
            let along = x(f + 0.005) - x(f);
            assert!((3.0 * along - 0.005 * edge).abs() < 1e-9, "f {f}: {along}");
        }
        // The whole edge covers the whole path, continuously and in order;
        // symmetric, so the nadir of the edge lands on the path's middle.
        assert_eq!(x(0.0), 0.0);
        assert!((x(1.0) - path_len).abs() < 1e-9);
        assert!((x(0.5) - path_len / 2.0).abs() < 1e-9);
        let mut last = 0.0;
        for k in 1..=1000 {
            let f = k as f64 / 1000.0;
            assert!(x(f) > last, "not increasing at {f}");
            assert!(x(f) - last < 0.0011 * edge, "a jump at {f}");
            last = x(f);
        }
    }

    #[test]
    fn the_ozaki_gathering_spreads_evenly_outside_its_range() {
        // Past 3 : 1 all along (J₀ < 0.34), nearly equal (J₀ > 0.97) or a
        // path longer than the edge: the even spread, as the group's code.
        for path_len in [20.0, 68.5, 75.0] {
            let even = Path3::sewn(line(path_len), 70.0, Gathering::Uniform);
            let ozaki = Path3::sewn(line(path_len), 70.0, Gathering::Ozaki);
            for f in [0.1, 0.3, 0.5, 0.8] {
                assert_eq!(ozaki.at(f), even.at(f));
                assert!((even.at(f).x - f * path_len).abs() < 1e-9);
            }
        }
    }
}
